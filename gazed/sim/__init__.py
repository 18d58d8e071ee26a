"""The simulated rig (DESIGN §9): the world, target trajectories, the camera renderer, and the
head emulator that answers the rig's serial protocol on a pty (`gazed.sim.head_emulator`).
"""
