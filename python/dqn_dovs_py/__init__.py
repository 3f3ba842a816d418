"""dqn_dovs_py: the Python half of the dqn_dovs ROS package (trainer, network model, weight exporter, reports).

Its import name differs from the ROS package's generated messages (dqn_dovs.msg, dqn_dovs.srv), so both import
side by side from any path order, and `pip install -e python/` needs no name-space workaround.
"""
