"""How long a move takes under the head's rate and acceleration limits, and how far apart two
gaze directions are (seed 000 §2, seed 004 §2)."""

from __future__ import annotations

import math

from gazed.geometry.kinematics import HeadKinematics


def move_duration_s(distance_rad: float, rate_max_rad_s: float, accel_max_rad_s2: float) -> float:
    """Time of a rest-to-rest move at the limits: a triangle or trapezoid velocity profile."""
    distance = abs(distance_rad)
    ramp_distance = rate_max_rad_s**2 / accel_max_rad_s2  # accelerate and brake at full rate
    if distance <= ramp_distance:
        return 2.0 * math.sqrt(distance / accel_max_rad_s2)
    return 2.0 * rate_max_rad_s / accel_max_rad_s2 + (distance - ramp_distance) / rate_max_rad_s


def angle_between(
    pan_a: float, tilt_a: float, pan_b: float, tilt_b: float, kinematics: HeadKinematics
) -> float:
    """The angle between two gaze directions (radians)."""
    a, b = kinematics.gaze(pan_a, tilt_a), kinematics.gaze(pan_b, tilt_b)
    return float(math.acos(max(-1.0, min(1.0, float(a @ b)))))
