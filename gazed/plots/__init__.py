"""The paper's figures as PNG files (matplotlib, headless): trajectories on the ground, gaze
error over time, model probabilities, latency per hop (`gazed plot`, `--plot DIR`)."""
