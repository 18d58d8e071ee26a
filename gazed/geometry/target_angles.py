"""The joint angles that centre a pixel seen from a known head pose, and their derivative by
the pixel (seed 000 §2: the observer trajectory of the target).

A pixel's base-frame ray is d = R(pan, tilt) · flip_y · K^-1 (u, v, 1) (kinematics.py); the
angles are `angles_from_direction(d)` and d(angles)/d(u, v) = J_dir(d) · R · flip_y · dray/d(u, v).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics


@dataclass(frozen=True, eq=False)
class TargetAngles:
    pan_rad: float
    tilt_rad: float
    pixel_jacobian: np.ndarray  # d(pan, tilt)/d(u, v), 2x2, rad/px

    def rates(self, du_px_s: float, dv_px_s: float) -> tuple[float, float]:
        """Angular rates of the target for an image velocity (independent of the head's own
        rotation: the head's rates drop out, see estimation/observation.py)."""
        pan_rate, tilt_rate = self.pixel_jacobian @ np.array([du_px_s, dv_px_s])
        return float(pan_rate), float(tilt_rate)


def target_angles(
    camera: CameraModel,
    kinematics: HeadKinematics,
    pan_rad: float,
    tilt_rad: float,
    u_px: float,
    v_px: float,
) -> TargetAngles:
    """Angles that put pixel (u, v) of a frame taken at (pan, tilt) on the optical axis."""
    camera_to_base = kinematics.camera_to_base(pan_rad, tilt_rad)
    ray, ray_by_pixel = camera.ray_with_jacobian(u_px, v_px)
    direction = camera_to_base @ ray
    pan, tilt = kinematics.angles_from_direction(direction)
    jacobian = kinematics.direction_angles_jacobian(direction) @ camera_to_base @ ray_by_pixel
    return TargetAngles(float(pan), float(tilt), jacobian)
