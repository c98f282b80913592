"""The embedded simulated rig: finger trajectories, electrostatic physics (eq. 1 of Zhao et al.) and the simulated display."""
