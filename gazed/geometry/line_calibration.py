"""Homography from four or more traced ground lines (seed 000 §3.2), no endpoint matching.

A ground line is U = (cos Phi, sin Phi, -D): unit normal at angle Phi and signed distance D
from the origin. The camera traces it (§3.2.1, gaze `trace` state); each gaze sample gives a
frontal-plane point and a total-least-squares line u = (cos phi, sin phi, -d) is fitted to
them. Lines map by the dual of X ≃ M x: u ≃ L U with L = M^T. With L33 = 1 each line gives

    [U w  V w  W w  0    0    0    -U u  -V u] l = W u
    [0    0    0    U w  V w  W w  -U v  -V v] l = W v

for l = (L11, L12, L13, L21, L22, L23, L31, L32), solved by least squares on coordinates
normalised in both planes (normalisation.py): frontal by all traced samples (so L33 = M33 is
lambda at their centroid, never zero), ground by the lines' pairwise crossings.
"""

from __future__ import annotations

import math
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
from gazed.geometry.normalisation import (
    similarity_normaliser,
    transform_lines,
    transform_points,
)

# Crossings of lines meeting at less than this angle are too ill-defined to centre the ground
# normalisation on (unless no pair crosses more steeply).
STEEP_CROSSING_RAD = math.radians(10.0)


@dataclass(frozen=True, eq=False)
class CalibrationLine:
    """One ground line (normal angle, signed distance) and the (pan, tilt) samples (K, 2)
    gathered while tracing it, in radians."""

    phi_rad: float
    d_m: float
    samples_rad: np.ndarray
    label: str


def ground_line(phi_rad: float, d_m: float) -> np.ndarray:
    """U = (cos Phi, sin Phi, -D) (§3.2): U · (X, Y, 1) is the signed distance in metres."""
    return np.array([math.cos(phi_rad), math.sin(phi_rad), -d_m])


def fit_frontal_line(points: np.ndarray) -> np.ndarray:
    """Total-least-squares line u = (cos phi, sin phi, -d) through points (K, 2), K >= 2."""
    points = np.asarray(points, dtype=float)
    centre = points.mean(axis=0)
    _, _, vt = np.linalg.svd(points - centre)
    normal = vt[1]
    return np.array([normal[0], normal[1], -float(normal @ centre)])


def fit_lines(
    frontal_samples: Sequence[np.ndarray], ground_lines: np.ndarray, labels: Sequence[str]
) -> GroundHomography:
    """M from traced frontal-plane samples (one (K, 2) array per line) and the ground lines
    (N, 3) they follow, N >= 4 (§3.2).

    Raises CalibrationError for non-finite values, fewer than 4 lines, a line with fewer than 2
    distinct samples, repeated lines, or n - 1 of n lines through one point or parallel."""
    ground_lines = np.asarray(ground_lines, dtype=float)
    samples = [np.asarray(s, dtype=float).reshape(-1, 2) for s in frontal_samples]
    for label, line, points in zip(labels, ground_lines, samples, strict=True):
        if not np.all(np.isfinite(line)):
            raise CalibrationError(f"{label}: ground line is not finite: {line}")
        if not np.all(np.isfinite(points)):
            raise CalibrationError(f"{label}: gaze samples are not finite")
        if len(points) < 2 or np.ptp(points, axis=0).max() == 0:
            raise CalibrationError(
                f"{label}: needs at least 2 distinct gaze samples to fit its frontal-plane line, "
                f"got {len(np.unique(points, axis=0))}"
            )
    if len(labels) < 4:
        raise CalibrationError(f"need at least 4 lines to fix the homography, got {len(labels)}")
    t_frontal = similarity_normaliser(np.vstack(samples))
    t_ground = _ground_normaliser(ground_lines)
    u = np.array([fit_frontal_line(transform_points(t_frontal, s)) for s in samples])
    big_u = transform_lines(t_ground, ground_lines)
    require_general_position(big_u, labels, "lines", " on the ground")
    require_general_position(u, labels, "lines", " in the gaze angles")
    uu, vv, ww = u[:, :1], u[:, 1:2], u[:, 2:3]
    zeros = np.zeros((len(u), 3))
    rows_u = np.hstack([big_u * ww, zeros, -big_u[:, :2] * uu])
    rows_v = np.hstack([zeros, big_u * ww, -big_u[:, :2] * vv])
    a = np.vstack([rows_u, rows_v])
    b = np.concatenate([big_u[:, 2] * u[:, 0], big_u[:, 2] * u[:, 1]])
    l_normalised = np.append(solve_least_squares(a, b), 1.0).reshape(3, 3)
    matrix = np.linalg.inv(t_ground) @ l_normalised.T @ t_frontal
    return canonical_homography(matrix, samples, labels)


def line_distances_m(
    homography: GroundHomography, frontal_samples: np.ndarray, line: np.ndarray
) -> np.ndarray:
    """Signed ground distances (K,) of traced samples, mapped by M, from a ground line U."""
    ground = homography.ground_from_frontal(frontal_samples)
    return ground @ line[:2] + line[2]


def calibrate_lines(
    lines: Sequence[CalibrationLine], head: HeadKinematics, limits: HeadSection | None
) -> CalibrationResult:
    """Fit M to the lines; each line's residual is the rms ground distance of its samples."""
    labels = [line.label for line in lines]
    samples = [
        np.array(
            [
                checked_frontal(pan, tilt, head, limits, f"{line.label} sample {k + 1}")
                for k, (pan, tilt) in enumerate(np.asarray(line.samples_rad).reshape(-1, 2))
            ]
        ).reshape(-1, 2)
        for line in lines
    ]
    ground = np.array([ground_line(line.phi_rad, line.d_m) for line in lines]).reshape(-1, 3)
    homography = fit_lines(samples, ground, labels)

    def fit(indices: list[int]) -> GroundHomography:
        return fit_lines(
            [samples[i] for i in indices], ground[indices], [labels[i] for i in indices]
        )

    def error_m(h: GroundHomography, i: int) -> float:
        return float(np.sqrt(np.mean(line_distances_m(h, samples[i], ground[i]) ** 2)))

    residuals = np.array([error_m(homography, i) for i in range(len(lines))])
    held_out = leave_one_out(len(lines), fit, error_m)
    return CalibrationResult(homography, tuple(labels), residuals, held_out)


def _ground_normaliser(lines: np.ndarray) -> np.ndarray:
    """Similarity normalising the ground by the lines' crossings (steep ones if any)."""
    crossings, steep = [], []
    for i in range(len(lines)):
        for j in range(i + 1, len(lines)):
            point = np.cross(lines[i], lines[j])
            sine = abs(point[2]) / (np.linalg.norm(lines[i][:2]) * np.linalg.norm(lines[j][:2]))
            if sine > 1e-9:
                crossings.append(point[:2] / point[2])
                steep.append(sine > math.sin(STEEP_CROSSING_RAD))
    if not crossings:
        return np.eye(3)
    chosen = [c for c, s in zip(crossings, steep, strict=True) if s] or crossings
    return similarity_normaliser(np.array(chosen))
