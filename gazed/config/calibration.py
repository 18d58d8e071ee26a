"""`[calibration]`: the frontal-plane -> ground homography and the height correction."""

from __future__ import annotations

import math
from typing import Annotated

from pydantic import Field, model_validator

from gazed.config.section import Section


class CalibrationSection(Section):
    homography: list[Annotated[list[float], Field(min_length=3, max_length=3)]] | None = Field(
        None,
        min_length=3,
        max_length=3,
        description="3x3 matrix M (rows) mapping frontal-plane points to ground XY (metres), "
        "M33 = 1 when the rest gaze points below the horizon, else a unit third row; lambda = "
        "(M x)_3 > 0 below the horizon. "
        "Written by `gazed calibrate points|lines FILE --write RIG`.",
    )
    camera_xyz_m: tuple[float, float, float] | None = Field(
        None,
        description="Camera rotation centre on the ground plane (X, Y) and its height Z, "
        "for height correction and the zoom's size at a target's distance.",
    )
    target_height_m: float = Field(
        0.0,
        ge=0,
        le=100,
        description="Height above the ground of the tracked point (a torso: about 1 m).",
    )

    @model_validator(mode="after")
    def _homography(self) -> CalibrationSection:
        if self.homography is not None:
            values = [v for row in self.homography for v in row]
            if not all(math.isfinite(v) for v in values):
                raise ValueError("homography: not finite (expected 3 rows of 3 finite numbers)")
            (a, b, c), (d, e, f), (g, h, i) = self.homography
            determinant = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
            scale = math.sqrt(sum(v * v for v in values))
            if abs(determinant) <= 1e-12 * scale**3:
                raise ValueError(
                    "homography: singular "
                    "(expected an invertible matrix, as `gazed calibrate` writes)"
                )
        if self.camera_xyz_m is not None and self.target_height_m >= self.camera_xyz_m[2]:
            raise ValueError(
                "target_height_m: not below the camera (expected target_height_m < camera_xyz_m[2])"
            )
        if self.target_height_m > 0 and self.camera_xyz_m is None:
            raise ValueError(
                "camera_xyz_m: missing "
                "(expected [X, Y, Z] when target_height_m > 0, for the height correction)"
            )
        return self
