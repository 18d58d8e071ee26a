"""A head's true pose in the world: what the simulator renders and what tests calibrate against.

World frame: X, Y on the ground plane, Z up (metres). The head's rotation centre stands at
(Xc, Yc, Zc), Zc > 0. Its base frame (x right, y up, z along the rest gaze; kinematics.py) is
turned by `yaw_rad` (heading of the rest gaze on the ground, from +X towards +Y, as
`[sim] camera_yaw_deg`), then raised by `pitch_rad` (> 0 lifts the rest gaze above the
horizon, like tilt), then rolled by `roll_rad` about the rest gaze (> 0 lowers the base's right
side). B (3x3, columns = the base axes in world coordinates) maps base directions to the world.

From it follow everything seed 000 §3 leaves unknown: the true frontal->ground homography, the
joint angles that centre any world point (on the ground or at a height), the pixel a world
point lands on for given joint angles, and the ground->image homography a renderer warps a
ground texture with. Point arguments are arrays (..., 3) and results are vectorised over them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from gazed.config import Rig
from gazed.geometry.camera import CameraModel
from gazed.geometry.ground import GroundGeometry
from gazed.geometry.height import HeightCorrection
from gazed.geometry.homography import GroundHomography
from gazed.geometry.kinematics import FLIP_Y, HeadKinematics, rot_x, rot_z


@dataclass(frozen=True, eq=False)
class CameraPose:
    """Rotation centre `centre_m` = (Xc, Yc, Zc) and base orientation (module docstring)."""

    centre_m: np.ndarray
    yaw_rad: float
    pitch_rad: float = 0.0
    roll_rad: float = 0.0
    head: HeadKinematics = field(default_factory=HeadKinematics)
    base_to_world: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        centre = np.array(self.centre_m, dtype=float)
        if centre.shape != (3,) or not np.all(np.isfinite(centre)) or centre[2] <= 0:
            raise ValueError(f"camera centre must be finite (X, Y, Z) with Z > 0, got {centre}")
        psi = self.yaw_rad
        forward = np.array([math.cos(psi), math.sin(psi), 0.0])
        up = np.array([0.0, 0.0, 1.0])
        right = np.array([math.sin(psi), -math.cos(psi), 0.0])
        level = np.column_stack([right, up, forward])
        base = level @ rot_x(-self.pitch_rad) @ rot_z(-self.roll_rad)
        centre.setflags(write=False)
        base.setflags(write=False)
        object.__setattr__(self, "centre_m", centre)
        object.__setattr__(self, "base_to_world", base)

    @classmethod
    def from_rig(cls, rig: Rig) -> CameraPose:
        """The simulator's true pose: `[sim] camera_xyz_m`, `camera_yaw_deg`, `camera_pitch_deg`,
        `camera_roll_deg`, `[head] kinematics`."""
        return cls(
            np.array(rig.sim.camera_xyz_m),
            math.radians(rig.sim.camera_yaw_deg),
            math.radians(rig.sim.camera_pitch_deg),
            math.radians(rig.sim.camera_roll_deg),
            head=HeadKinematics.from_section(rig.head),
        )

    def base_directions(self, points_m: np.ndarray) -> np.ndarray:
        """Base-frame rays (..., 3) from the rotation centre to world point(s) (..., 3)."""
        return (np.asarray(points_m, dtype=float) - self.centre_m) @ self.base_to_world

    def frontal_to_ground(self) -> GroundHomography:
        """The true M: X ≃ M d for a base-frame ray d (homography.py's closed form)."""
        b0, b1, b2 = self.base_to_world
        xc, yc, zc = self.centre_m
        return GroundHomography.from_matrix(np.array([zc * b0 - xc * b2, zc * b1 - yc * b2, -b2]))

    def ground_geometry(self, camera: CameraModel, target_height_m: float = 0.0) -> GroundGeometry:
        """A GroundGeometry with the true M (and the height correction for targets at h)."""
        height = HeightCorrection(self.centre_m, target_height_m) if target_height_m > 0 else None
        return GroundGeometry(camera, self.head, self.frontal_to_ground(), height)

    def gaze_angles(self, points_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(pan, tilt) in radians that centre world point(s) (..., 3) on the optical axis."""
        return self.head.angles_from_direction(self.base_directions(points_m))

    def camera_directions(
        self, points_m: np.ndarray, pan_rad: float, tilt_rad: float
    ) -> np.ndarray:
        """World point(s) (..., 3) as OpenCV camera-frame directions (x right, y down, z forward)
        for the head at (pan, tilt)."""
        camera_to_base = self.head.camera_to_base(pan_rad, tilt_rad)
        return self.base_directions(points_m) @ camera_to_base

    def pixels(
        self, points_m: np.ndarray, pan_rad: float, tilt_rad: float, camera: CameraModel
    ) -> np.ndarray:
        """Pixel(s) (..., 2) where world point(s) (..., 3) land, lens distortion included.

        Raises ValueError if a point is behind the camera."""
        return camera.pixel(self.camera_directions(points_m, pan_rad, tilt_rad))

    def ground_to_image(self, pan_rad: float, tilt_rad: float, camera: CameraModel) -> np.ndarray:
        """H (3x3) with pixel ≃ H (X, Y, 1) for ground points, pinhole part (no distortion).

        H = K · flip_y · R^T · B^T · [[1, 0, -Xc], [0, 1, -Yc], [0, 0, -Zc]]. Its sign is kept so
        that (H X)_3 > 0 exactly for ground points in front of the camera."""
        to_centre = np.array([[1.0, 0.0, -self.centre_m[0]], [0.0, 1.0, -self.centre_m[1]]])
        to_centre = np.vstack([to_centre, [0.0, 0.0, -self.centre_m[2]]])
        rotation = self.head.rotation(pan_rad, tilt_rad)
        return camera.K @ FLIP_Y @ rotation.T @ self.base_to_world.T @ to_centre

    def horizon_line(self, pan_rad: float, tilt_rad: float, camera: CameraModel) -> np.ndarray:
        """Image line l (3,) of the horizon, scaled so l · (u, v, 1) < 0 for pixels that see the
        ground and > 0 for pixels that see the sky; |(l0, l1)| = 1 makes it a distance in px
        (pinhole part)."""
        rays_to_world = self.base_to_world @ self.head.camera_to_base(pan_rad, tilt_rad)
        line = (rays_to_world @ camera.K_inv)[2]
        scale = math.hypot(line[0], line[1])
        return line / scale if scale > 0 else line
