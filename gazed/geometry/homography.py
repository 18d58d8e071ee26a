"""The frontal-plane -> ground-plane homography M: X ≃ M x (seed 000 §3, DESIGN §4).

x = (x, y, 1) is where a gaze ray meets the frontal plane z = 1 of the head base frame; more
generally M maps any base-frame direction d of a ray from the rotation centre: X ≃ M d.

Canonical form (what `from_matrix` returns and `gazed calibrate --write` stores):

- Sign: the homogeneous scale lambda = (M d)_3 is positive for every ray that meets the ground
  (it points below the horizon) and negative for rays above it. With this sign M^-1 (X, Y, 1)
  is a positive multiple of the real ray to a ground point, even one behind the frontal plane.
- Scale: M33 = 1 (§3.1) when the rest gaze (pan = tilt = 0) points at least 0.5° below the
  horizon. A head whose rest gaze is level — what `[head] tilt_zero_deg` asks for — has
  M33 = 0 exactly (the rest gaze meets the ground at infinity; the case §3.2 "safely ignores"),
  and a raised one has M33 < 0 under the sign above; both store M with a unit third row instead.

For the true map of a head at ground position (Xc, Yc), height Zc, whose base axes have world
coordinates given by the rows b0, b1, b2 of the base-to-world rotation, the map with unit third
row is M = [Zc b0 - Xc b2; Zc b1 - Yc b2; -b2] (`CameraPose.frontal_to_ground`), so a calibrated
M also tells where the camera is (`implied_camera_xyz_m`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from gazed.config import CalibrationSection

# The rest gaze must point at least this far below the horizon for M33 = 1 to be used.
REST_DEPRESSION_MIN_RAD = math.radians(0.5)


class HorizonError(ValueError):
    """A gaze that does not meet the ground, or a ground point behind the frontal plane."""


@dataclass(frozen=True, eq=False)
class GroundHomography:
    """M (3x3, canonical sign and scale) and its inverse."""

    matrix: np.ndarray
    inverse: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        matrix = np.array(self.matrix, dtype=float)
        if matrix.shape != (3, 3) or not np.all(np.isfinite(matrix)):
            raise ValueError(f"homography must be 3x3 and finite, got {matrix.tolist()}")
        if abs(np.linalg.det(matrix / np.linalg.norm(matrix))) < 1e-12:
            raise ValueError("homography is singular: it maps the frontal plane onto a line")
        matrix.setflags(write=False)
        inverse = np.linalg.inv(matrix)
        inverse.setflags(write=False)
        object.__setattr__(self, "matrix", matrix)
        object.__setattr__(self, "inverse", inverse)

    @classmethod
    def from_matrix(cls, matrix: np.ndarray) -> GroundHomography:
        """Scale M to canonical form (module docstring), keeping its sign: the caller makes
        lambda positive on the ground (`calibration.canonical_homography` does it for fits)."""
        m = np.asarray(matrix, dtype=float) + 0.0  # + 0.0: no negative zeros in stored matrices
        row_norm = float(np.linalg.norm(m[2]))
        if m[2, 2] >= math.sin(REST_DEPRESSION_MIN_RAD) * row_norm:
            return cls(m / m[2, 2])
        return cls(m / row_norm)

    @classmethod
    def from_section(cls, calibration: CalibrationSection) -> GroundHomography | None:
        """The rig's `[calibration] homography`; None where it has none."""
        if calibration.homography is None:
            return None
        return cls.from_matrix(np.array(calibration.homography))

    @property
    def rest_gaze_meets_ground(self) -> bool:
        """True when M33 = 1 (the rest gaze points at least 0.5° below the horizon)."""
        return bool(self.matrix[2, 2] == 1.0)

    def ground_from_direction(self, direction: np.ndarray) -> np.ndarray:
        """Ground XY (..., 2) where base-frame ray(s) (..., 3) meet the ground.

        Raises HorizonError for a ray at or above the horizon (it never meets the ground)."""
        q = np.asarray(direction, dtype=float) @ self.matrix.T
        lam = q[..., 2]
        if (lam <= 0).any():
            raise HorizonError(
                "gaze does not meet the ground: it points at or above the horizon"
                + ("" if np.ndim(lam) == 0 else f" ({int(np.sum(lam <= 0))} of {lam.size} rays)")
            )
        return q[..., :2] / lam[..., None]

    def ground_from_frontal(self, frontal: np.ndarray) -> np.ndarray:
        """Ground XY (..., 2) of frontal-plane point(s) (..., 2): X ≃ M (x, y, 1) (§3)."""
        frontal = np.asarray(frontal, dtype=float)
        return self.ground_from_direction(_homogeneous(frontal))

    def ground_jacobian(self, direction: np.ndarray) -> np.ndarray:
        """d(X, Y)/d(direction) of `ground_from_direction` at one ray, 2x3."""
        q = self.matrix @ np.asarray(direction, dtype=float)
        ground = q[:2] / q[2]
        return (self.matrix[:2] - np.outer(ground, self.matrix[2])) / q[2]

    def direction_from_ground(self, ground: np.ndarray) -> np.ndarray:
        """Base-frame ray(s) (..., 3) from the rotation centre to ground point(s) (..., 2):
        M^-1 (X, Y, 1), a positive multiple of the real ray (canonical sign)."""
        return _homogeneous(np.asarray(ground, dtype=float)) @ self.inverse.T

    def frontal_from_ground(self, ground: np.ndarray) -> np.ndarray:
        """Frontal-plane point(s) (..., 2) whose gaze meets ground point(s) (..., 2).

        Raises HorizonError for a ground point behind the frontal plane (its gaze has
        |pan| or |tilt| >= 90°)."""
        d = self.direction_from_ground(ground)
        if np.any(d[..., 2] <= 0):
            raise HorizonError("ground point is behind the frontal plane (|pan| or |tilt| >= 90°)")
        return d[..., :2] / d[..., 2:3]

    def implied_camera_xyz_m(self) -> np.ndarray:
        """The rotation centre (Xc, Yc, Zc) this M implies (module docstring): with the third row
        scaled to unit length, Xc = m0 · m2, Yc = m1 · m2, Zc = |m0 - Xc m2| (mean with row 1).

        Exact for a noise-free M in metric ground coordinates; a plausibility check otherwise."""
        m = self.matrix / np.linalg.norm(self.matrix[2])
        m2 = m[2]
        xc, yc = float(m[0] @ m2), float(m[1] @ m2)
        zc = 0.5 * (np.linalg.norm(m[0] - xc * m2) + np.linalg.norm(m[1] - yc * m2))
        return np.array([xc, yc, zc])


def _homogeneous(points: np.ndarray) -> np.ndarray:
    return np.concatenate([points, np.ones((*points.shape[:-1], 1))], axis=-1)
