"""A person's size in a still calibrated camera's pixels, where they stand.

The rig's ground geometry (`[calibration]`: the ground homography and the camera's position)
places a foot pixel on the ground; a person standing there is `PERSON_HEIGHT_M` tall and
`PERSON_WIDTH_M` across (shoulders and swinging arms), so their head is the pixel of the point
that high above the foot, and their width the distance between the pixels of the ground points
half that width to either side, across the line of sight. The detector's silhouettes are judged
against it (`gazed.vision.movers.split_blob`): a blob as wide as two people holds two.
"""

from __future__ import annotations

import numpy as np

from gazed.config import Rig
from gazed.geometry.camera import CameraModel
from gazed.geometry.ground import GroundGeometry
from gazed.geometry.height import HeightCorrection
from gazed.geometry.homography import GroundHomography, HorizonError
from gazed.geometry.kinematics import HeadKinematics

PERSON_HEIGHT_M = 1.7  # an adult, standing
PERSON_WIDTH_M = 0.5  # shoulders and swinging arms


class PersonSize:
    """A person's pixel width and height at a foot pixel of `camera` seen at rest (pan and
    tilt 0) through the rig's ground geometry."""

    def __init__(
        self,
        camera: CameraModel,
        head: HeadKinematics,
        homography: GroundHomography,
        camera_xyz_m: tuple[float, float, float],
    ) -> None:
        self.ground = GroundGeometry(camera, head, homography)
        self.camera_xy_m = np.asarray(camera_xyz_m, float)[:2]
        self.top = GroundGeometry(
            camera, head, homography, HeightCorrection(np.asarray(camera_xyz_m), PERSON_HEIGHT_M)
        )

    @classmethod
    def from_rig(cls, rig: Rig, camera: CameraModel) -> PersonSize | None:
        """From the rig's `[head]` and `[calibration]`; None where it has no homography or no
        camera position."""
        homography = GroundHomography.from_section(rig.calibration)
        if homography is None or rig.calibration.camera_xyz_m is None:
            return None
        return cls(
            camera, HeadKinematics.from_section(rig.head), homography, rig.calibration.camera_xyz_m
        )

    def at(self, u_px: float, v_px: float) -> tuple[float, float] | None:
        """(width, height) in pixels of a person whose feet are at pixel (u, v); None where
        that pixel does not see the ground."""
        try:
            foot = self.ground.ground_from_gaze(0.0, 0.0, u_px, v_px)
            across = foot - self.camera_xy_m
            across = np.array([-across[1], across[0]]) / max(float(np.hypot(*across)), 1e-9)
            half = 0.5 * PERSON_WIDTH_M * across
            left = self.ground.pixel_from_ground(*(foot - half), 0.0, 0.0)
            right = self.ground.pixel_from_ground(*(foot + half), 0.0, 0.0)
            top = self.top.pixel_from_ground(*foot, 0.0, 0.0)
        except (HorizonError, ValueError):
            return None
        return float(np.hypot(*(right - left))), float(np.hypot(top[0] - u_px, top[1] - v_px))
