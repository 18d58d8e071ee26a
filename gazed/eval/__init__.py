"""Offline and closed-loop evaluation: `gazed eval estimator` and `gazed eval loop`."""
