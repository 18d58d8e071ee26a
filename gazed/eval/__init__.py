"""Offline evaluation: `gazed eval estimator` (and, later, the closed loop)."""
