"""Where joint angles appear in a frame taken from a known head pose: the pixel of the ray that
the angles `(pan, tilt)` would centre, seen by the camera at the frame's pose."""

from __future__ import annotations

import math

import numpy as np

from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.messages import HeadPose


class ImageProjection:
    """Gaze angles -> pixels of a frame, and the side of the fovea in pixels."""

    def __init__(self, camera: CameraModel, kinematics: HeadKinematics, fovea_rad: float):
        self.camera = camera
        self.kinematics = kinematics
        self.fovea_px = 2.0 * camera.focal_px * math.tan(fovea_rad / 2.0)

    def pixel(self, head: HeadPose, pan_rad: float, tilt_rad: float) -> tuple[float, float] | None:
        """The pixel (u, v) at which the direction `(pan_rad, tilt_rad)` centres appears in a frame
        taken at `head`; None when it lies behind the camera."""
        direction = self.kinematics.gaze(pan_rad, tilt_rad)
        ray = self.kinematics.camera_to_base(head.pan_rad, head.tilt_rad).T @ direction
        if ray[2] <= 1e-6:
            return None
        u, v = self.camera.pixel(np.asarray(ray))
        return float(u), float(v)

    @property
    def centre_px(self) -> tuple[float, float]:
        return float(self.camera.K[0, 2]), float(self.camera.K[1, 2])
