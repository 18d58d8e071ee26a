"""Homography from four or more gaze-angle <-> ground-point correspondences (seed 000 §3.1).

Each point: centre the camera on a ground mark whose (X, Y) is known and read the joint angles.
Its frontal-plane point x = (x, y, 1) and ground point X give two rows of A m = b, with the
unknowns m = (M11, M12, M13, M21, M22, M23, M31, M32) and M33 = 1:

    [x  y  1  0  0  0  -X x  -X y] m = X
    [0  0  0  x  y  1  -Y x  -Y y] m = Y

(the printed first row has X_i for x_i and -X_i X_i for -X_i x_i; the second row is right).
The system is solved by least squares on coordinates normalised in both planes
(normalisation.py), where fixing M33 = 1 is always well-posed: it fixes lambda at the centroid
of the calibration gazes, which all meet the ground. M is then put in canonical form.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gazed.config import HeadSection
from gazed.geometry.calibration import (
    CalibrationError,
    CalibrationResult,
    canonical_homography,
    checked_frontal,
    leave_one_out,
    solve_least_squares,
)
from gazed.geometry.degeneracy import require_general_position
from gazed.geometry.homography import GroundHomography
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.normalisation import similarity_normaliser, transform_points

@dataclass(frozen=True)
class CalibrationPoint:
    """One calibration point: joint angles that centre it and its ground coordinates."""

    pan_rad: float
    tilt_rad: float
    x_m: float
    y_m: float
    label: str


def fit_points(
    frontal: np.ndarray, ground_m: np.ndarray, labels: Sequence[str]
) -> GroundHomography:
    """M from frontal-plane points (N, 2) and their ground points (N, 2), N >= 4 (§3.1).

    Raises CalibrationError for non-finite values, fewer than 4 points, repeated points, or
    n - 1 of n points on one line (on the ground or in the gaze angles)."""
    frontal = np.asarray(frontal, dtype=float)
    ground_m = np.asarray(ground_m, dtype=float)
    for i, label in enumerate(labels):
        if not np.all(np.isfinite(ground_m[i])):
            raise CalibrationError(f"{label}: ground coordinates are not finite: {ground_m[i]}")
        if not np.all(np.isfinite(frontal[i])):
            raise CalibrationError(f"{label}: gaze angles are not finite")
    if len(labels) < 4:
        raise CalibrationError(f"need at least 4 points to fix the homography, got {len(labels)}")
    t_frontal = similarity_normaliser(frontal)
    t_ground = similarity_normaliser(ground_m)
    x = transform_points(t_frontal, frontal)
    g = transform_points(t_ground, ground_m)
    ones = np.ones((len(x), 1))
    require_general_position(np.hstack([g, ones]), labels, "points", " on the ground")
    require_general_position(np.hstack([x, ones]), labels, "points", " in the gaze angles")
    zeros = np.zeros((len(x), 3))
    xy1 = np.hstack([x, ones])
    rows_x = np.hstack([xy1, zeros, -g[:, :1] * x])
    rows_y = np.hstack([zeros, xy1, -g[:, 1:2] * x])
    a = np.vstack([rows_x, rows_y])
    b = np.concatenate([g[:, 0], g[:, 1]])
    m = solve_least_squares(a, b)
    m_normalised = np.append(m, 1.0).reshape(3, 3)
    matrix = np.linalg.inv(t_ground) @ m_normalised @ t_frontal
    return canonical_homography(matrix, list(frontal), labels)


def calibrate_points(
    points: Sequence[CalibrationPoint], head: HeadKinematics, limits: HeadSection | None
) -> CalibrationResult:
    """Fit M to the points and measure each point's ground residual and leave-one-out error."""
    labels = [p.label for p in points]
    frontal = np.array(
        [checked_frontal(p.pan_rad, p.tilt_rad, head, limits, p.label) for p in points]
    ).reshape(-1, 2)
    ground_m = np.array([[p.x_m, p.y_m] for p in points], dtype=float).reshape(-1, 2)
    homography = fit_points(frontal, ground_m, labels)

    def fit(indices: list[int]) -> GroundHomography:
        return fit_points(frontal[indices], ground_m[indices], [labels[i] for i in indices])

    def error_m(h: GroundHomography, i: int) -> float:
        return float(np.linalg.norm(h.ground_from_frontal(frontal[i]) - ground_m[i]))

    residuals = np.array([error_m(homography, i) for i in range(len(points))])
    held_out, others_rms = leave_one_out(len(points), fit, error_m)
    return CalibrationResult(homography, tuple(labels), residuals, held_out, others_rms)
