"""The simulated rig (DESIGN §9): the world at each capture (`world`), target trajectories, the
camera renderer and when it captures, renders and publishes (`camera_schedule`), and the head
emulator that answers the rig's serial protocol on a pty (`gazed.sim.head_emulator`).
"""
