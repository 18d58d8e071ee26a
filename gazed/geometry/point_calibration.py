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

`calibrate_points` refines that solution to the maximum-likelihood M under joint-angle noise
(`refine_points`; identical on exact data), reports residuals in metres, leave-one-out errors
and which point, if any, disagrees with the others (outlier.py).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gazed.config import HeadSection
from gazed.geometry.calibration import (
    CalibrationError,
    CalibrationResult,
    Outlier,
    canonical_homography,
    checked_frontal,
    leave_one_out,
    solve_least_squares,
)
from gazed.geometry.degeneracy import require_general_position
from gazed.geometry.homography import GroundHomography
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.normalisation import similarity_normaliser, transform_points
from gazed.geometry.outlier import find_outlier

REFINE_ITERATIONS = 50


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


def angle_errors(
    homography: GroundHomography, head: HeadKinematics, angles_rad: np.ndarray, ground_m: np.ndarray
) -> np.ndarray:
    """(pan, tilt) that centre each ground point (n, 2) under `homography`, minus the measured
    angles (n, 2), pan wrapped to (-pi, pi]: the residuals in the units the head measures."""
    pan, tilt = head.angles_from_direction(homography.direction_from_ground(ground_m))
    errors = np.stack([pan, tilt], axis=-1) - angles_rad
    errors[:, 0] = np.angle(np.exp(1j * errors[:, 0]))
    return errors


def refine_points(
    homography: GroundHomography,
    angles_rad: np.ndarray,
    ground_m: np.ndarray,
    head: HeadKinematics,
    labels: Sequence[str],
) -> GroundHomography:
    """Maximum-likelihood M under independent joint-angle noise: Levenberg-Marquardt on the
    angle residuals (`angle_errors`), started from the §3.1 least squares.

    The algebraic least squares weights each point by its ground scale, not by how well the
    head measured it; this step minimises what the head actually got wrong. It works on
    W = M^-1, which maps a ground point to its ray linearly: angles(W (X, Y, 1))."""
    ground_h = np.hstack([ground_m, np.ones((len(ground_m), 1))])
    w = homography.inverse / np.linalg.norm(homography.inverse)

    def residuals(w: np.ndarray) -> np.ndarray:
        pan, tilt = head.angles_from_direction(ground_h @ w.T)
        errors = np.stack([pan, tilt], axis=-1) - angles_rad
        errors[:, 0] = np.angle(np.exp(1j * errors[:, 0]))
        return errors.ravel()

    r = residuals(w)
    cost = float(r @ r)
    damping = None
    for _ in range(REFINE_ITERATIONS):
        rays = ground_h @ w.T
        jacobian = np.vstack(
            [
                np.einsum("ar,c->arc", head.direction_angles_jacobian(ray), point).reshape(2, 9)
                for ray, point in zip(rays, ground_h, strict=True)
            ]
        )
        normal = jacobian.T @ jacobian
        gradient = jacobian.T @ r
        if damping is None:
            damping = 1e-3 * float(np.max(np.diag(normal)))
        while True:
            step = np.linalg.solve(normal + damping * np.eye(9), -gradient)
            trial = w + step.reshape(3, 3)
            trial /= np.linalg.norm(trial)
            r_trial = residuals(trial)
            cost_trial = float(r_trial @ r_trial)
            if cost_trial < cost:
                break
            damping *= 4.0
            if damping > 1e12 * float(np.max(np.diag(normal))):
                return canonical_homography(np.linalg.inv(w), _frontal_rays(w, ground_h), labels)
        improvement = cost - cost_trial
        w, r, cost, damping = trial, r_trial, cost_trial, damping / 3.0
        if improvement <= 1e-12 * cost:
            break
    return canonical_homography(np.linalg.inv(w), _frontal_rays(w, ground_h), labels)


def calibrate_points(
    points: Sequence[CalibrationPoint],
    head: HeadKinematics,
    limits: HeadSection | None,
    angle_noise_rad: float,
) -> CalibrationResult:
    """Fit M to the points (§3.1 least squares refined to maximum likelihood) and measure each
    point's ground residual, its leave-one-out error and whether one point disagrees with the
    others beyond `angle_noise_rad` (outlier.py)."""
    labels = [p.label for p in points]
    n = len(points)
    frontal = np.array(
        [checked_frontal(p.pan_rad, p.tilt_rad, head, limits, p.label) for p in points]
    ).reshape(-1, 2)
    angles = np.array([[p.pan_rad, p.tilt_rad] for p in points], dtype=float).reshape(-1, 2)
    ground_m = np.array([[p.x_m, p.y_m] for p in points], dtype=float).reshape(-1, 2)
    fits: dict[tuple[int, ...], GroundHomography] = {}

    def fit(indices: list[int]) -> GroundHomography:
        key = tuple(indices)
        if key not in fits:
            names = [labels[i] for i in indices]
            initial = fit_points(frontal[indices], ground_m[indices], names)
            fits[key] = refine_points(initial, angles[indices], ground_m[indices], head, names)
        return fits[key]

    def error_m(h: GroundHomography, i: int) -> float:
        return float(np.linalg.norm(h.ground_from_frontal(frontal[i]) - ground_m[i]))

    def chi_square(indices: list[int]) -> float:
        errors = angle_errors(fit(indices), head, angles[indices], ground_m[indices])
        return float(np.sum(errors**2)) / angle_noise_rad**2

    homography = fit(list(range(n)))
    residuals = np.array([error_m(homography, i) for i in range(n)])
    angle_rms = float(
        np.sqrt(np.mean(np.sum(angle_errors(homography, head, angles, ground_m) ** 2, axis=1)))
    )
    if n < 5:
        return CalibrationResult(homography, tuple(labels), residuals, (None,) * n, angle_rms)
    held_out = leave_one_out(n, fit, error_m)
    verdict = find_outlier(n, chi_square)
    outlier = None
    if verdict.outlier is not None:
        k = verdict.outlier
        others = fit([j for j in range(n) if j != k])
        miss = angle_errors(others, head, angles[k : k + 1], ground_m[k : k + 1])[0]
        assert verdict.probability_without is not None
        outlier = Outlier(
            k, float(np.linalg.norm(miss)), verdict.probability_with, verdict.probability_without
        )
    return CalibrationResult(
        homography, tuple(labels), residuals, held_out, angle_rms, verdict.consistent, outlier
    )


def _frontal_rays(w: np.ndarray, ground_h: np.ndarray) -> list[np.ndarray]:
    """Frontal-plane points of the rays W (X, Y, 1) (for the canonical sign)."""
    rays = ground_h @ w.T
    return list(rays[:, :2] / rays[:, 2:3])
