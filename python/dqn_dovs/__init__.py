"""DQN-DOVS: trainer, network model, weight exporter and plots of the dqn_dovs package."""

# The ROS build installs this package's messages as dqn_dovs.msg / dqn_dovs.srv in another directory
# of the path; let both halves of the name space import side by side.
__path__ = __import__("pkgutil").extend_path(__path__, __name__)
