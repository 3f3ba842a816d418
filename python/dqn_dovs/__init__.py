"""DQN-DOVS: trainer, network model, weight exporter and plots of the dqn_dovs package."""
