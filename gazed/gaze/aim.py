"""Aims: where a target is at an instant, how long the head's move there takes under its rate
and acceleration limits, and where the target will be when that move ends (seed 000 §2,
seed 004 §2)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.target_angles import target_angles
from gazed.geometry.zoom import ZoomLens
from gazed.messages import Detection, HeadPose, Prediction


@dataclass(frozen=True)
class Aim:
    """A target direction at an instant, with its angular rates."""

    t_ns: int
    pan_rad: float
    tilt_rad: float
    pan_rate_rad_s: float = 0.0
    tilt_rate_rad_s: float = 0.0

    def at(self, t_ns: int) -> tuple[float, float]:
        """The direction extrapolated at constant rates to `t_ns`."""
        dt = (t_ns - self.t_ns) / 1e9
        return self.pan_rad + self.pan_rate_rad_s * dt, self.tilt_rad + self.tilt_rate_rad_s * dt

    @classmethod
    def of_prediction(cls, p: Prediction) -> Aim:
        """The estimator's prediction, for the instant it was made for."""
        return cls(p.t_effect_ns, p.pan_rad, p.tilt_rad, p.pan_rate_rad_s, p.tilt_rate_rad_s)


def image_aim(
    camera: CameraModel,
    kinematics: HeadKinematics,
    head: HeadPose,
    t_ns: int,
    point_px: tuple[float, float],
    velocity_px_s: tuple[float, float],
) -> Aim:
    """The joint angles and rates that put an image point, moving in the image, on the optical
    axis, as seen from the head pose at the frame's capture `t_ns`."""
    target = target_angles(camera, kinematics, head.pan_rad, head.tilt_rad, *point_px)
    pan_rate, tilt_rate = target.rates(*velocity_px_s)
    return Aim(t_ns, target.pan_rad, target.tilt_rad, pan_rate, tilt_rate)


def detection_aim(lens: ZoomLens, kinematics: HeadKinematics, detection: Detection) -> Aim:
    """Where a detection says the target is, at its capture (through the lens at its zoom)."""
    assert detection.head is not None
    return image_aim(
        lens.at_pose(detection.head),
        kinematics,
        detection.head,
        detection.t_capture_ns,
        (detection.u_px, detection.v_px),
        (detection.du_px_s, detection.dv_px_s),
    )


def move_duration_s(distance_rad: float, rate_max_rad_s: float, accel_max_rad_s2: float) -> float:
    """Time of a rest-to-rest move at the limits: a triangle or trapezoid velocity profile."""
    distance = abs(distance_rad)
    ramp_distance = rate_max_rad_s**2 / accel_max_rad_s2  # accelerate and brake at full rate
    if distance <= ramp_distance:
        return 2.0 * math.sqrt(distance / accel_max_rad_s2)
    return 2.0 * rate_max_rad_s / accel_max_rad_s2 + (distance - ramp_distance) / rate_max_rad_s


@dataclass(frozen=True)
class MoveLimits:
    """The head's rate and acceleration limits per axis (pan, tilt)."""

    rate_max_rad_s: tuple[float, float]
    accel_max_rad_s2: tuple[float, float]

    def duration_s(self, pan_rad: float, tilt_rad: float) -> float:
        """Time of a rest-to-rest move by these joint angles: the slower axis's."""
        return max(
            move_duration_s(pan_rad, self.rate_max_rad_s[0], self.accel_max_rad_s2[0]),
            move_duration_s(tilt_rad, self.rate_max_rad_s[1], self.accel_max_rad_s2[1]),
        )


def arrival_aim(
    target: Aim,
    head_rad: tuple[float, float],
    now_ns: int,
    limits: MoveLimits,
    settle_s: float,
) -> Aim:
    """Where the target will be when the head, at `head_rad` now, has moved to where the target
    is now (at its limits) and settled: the goal of a ballistic move, at the arrival instant."""
    pan_now, tilt_now = target.at(now_ns)
    duration_s = limits.duration_s(pan_now - head_rad[0], tilt_now - head_rad[1])
    arrival_ns = now_ns + round((duration_s + settle_s) * 1e9)
    pan, tilt = target.at(arrival_ns)
    return Aim(arrival_ns, pan, tilt)


def angle_between(
    pan_a: float, tilt_a: float, pan_b: float, tilt_b: float, kinematics: HeadKinematics
) -> float:
    """The angle between two gaze directions (radians)."""
    a, b = kinematics.gaze(pan_a, tilt_a), kinematics.gaze(pan_b, tilt_b)
    return float(math.acos(max(-1.0, min(1.0, float(a @ b)))))
