"""Geometry: camera model, head kinematics, frontal plane, homography, calibration."""
