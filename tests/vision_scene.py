"""A synthetic scene for the vision tests: a head panning at a constant rate (so interpolated
odometry is exact) pursuing a textured target, its odometry, and its frames as a source hands
them out."""

from __future__ import annotations

import math

import numpy as np

from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.messages import HeadPose, Odometry
from gazed.vision.frames import CapturedFrame
from gazed.vision.synthetic import SceneTruth, SyntheticScene

T0_NS = 1_700_000_000 * 10**9
RATE_HZ = 25.0
PAN_RATE = math.radians(30.0)
CAMERA_BODY = """
[camera]
source = "sim"
width_px = 320
height_px = 240
hfov_deg = 60
"""  # a rig's camera as the scene renders it


def head(t_s: float) -> HeadPose:
    """Panning at a constant 30°/s (so interpolated odometry is exact)."""
    return HeadPose(pan_rad=-0.3 + PAN_RATE * t_s, tilt_rad=0.05, pan_rate_rad_s=PAN_RATE)


def scene() -> SyntheticScene:
    camera = CameraModel.from_fov(320, 240, math.radians(60))
    # the head pursues a target moving at 30°/s with a small offset
    return SyntheticScene(
        camera,
        HeadKinematics(),
        head,
        lambda t: (-0.3 + PAN_RATE * t + 0.02 * math.sin(3 * t), 0.05 + 0.01 * t),
        seed=31,
        field_rad=0.9,
    )


def odometry(t_s: float) -> Odometry:
    pose = head(t_s)
    return Odometry(
        t_capture_ns=T0_NS + round(t_s * 1e9),
        pan_rad=pose.pan_rad,
        tilt_rad=pose.tilt_rad,
        pan_rate_rad_s=pose.pan_rate_rad_s,
    )


def captured(image: np.ndarray, truth: SceneTruth, seq: int) -> CapturedFrame:
    return CapturedFrame(image, "bgr8", T0_NS + round(truth.t_s * 1e9), seq, (("sim", 1),))
