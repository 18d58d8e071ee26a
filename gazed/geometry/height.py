"""Height correction for a tracked point h metres above the ground (seed 000 §3.1, end).

The gaze through a point at height h meets the ground at X, beyond the point. The paper moves
X towards the camera's ground position (Xc, Yc) by h cot(alpha), alpha being the gaze's angle
below the horizontal plane through the rotation centre:

    X' = X + h cot(alpha) (Xc - X) / |Xc - X|.

With the camera's height Zc known, cot(alpha) = |Xc - X| / Zc, so the correction is the exact
similar-triangles map X' = X + (h / Zc) (Xc - X), linear in X with Jacobian (1 - h/Zc) I.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gazed.config import CalibrationSection


@dataclass(frozen=True, eq=False)
class HeightCorrection:
    """The tracked point's height and the camera's rotation centre (Xc, Yc, Zc), metres."""

    camera_xyz_m: np.ndarray
    target_height_m: float
    fraction: float = field(init=False)

    def __post_init__(self) -> None:
        camera = np.array(self.camera_xyz_m, dtype=float)
        if camera.shape != (3,) or not np.all(np.isfinite(camera)):
            raise ValueError(f"camera_xyz_m must be 3 finite numbers, got {self.camera_xyz_m}")
        if not 0.0 <= self.target_height_m < camera[2]:
            raise ValueError(
                f"target height {self.target_height_m} m must be >= 0 and below the camera's "
                f"height {camera[2]} m: no gaze from the camera reaches the ground through it"
            )
        camera.setflags(write=False)
        object.__setattr__(self, "camera_xyz_m", camera)
        object.__setattr__(self, "fraction", self.target_height_m / camera[2])

    @classmethod
    def from_section(cls, calibration: CalibrationSection) -> HeightCorrection | None:
        """From [calibration]; None when target_height_m is 0 (nothing to correct)."""
        if calibration.target_height_m == 0 or calibration.camera_xyz_m is None:
            return None
        return cls(np.array(calibration.camera_xyz_m), calibration.target_height_m)

    def target_from_hit(self, hit_m: np.ndarray) -> np.ndarray:
        """Ground position (..., 2) under the target from where its gaze hits the ground."""
        hit_m = np.asarray(hit_m, dtype=float)
        return hit_m + self.fraction * (self.camera_xyz_m[:2] - hit_m)

    def hit_from_target(self, target_m: np.ndarray) -> np.ndarray:
        """Where the gaze through a target above ground position(s) (..., 2) hits the ground."""
        target_m = np.asarray(target_m, dtype=float)
        return (target_m - self.fraction * self.camera_xyz_m[:2]) / (1.0 - self.fraction)

    @property
    def jacobian_scale(self) -> float:
        """d(target)/d(hit) = (1 - h/Zc) I."""
        return 1.0 - self.fraction
