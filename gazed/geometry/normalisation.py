"""Coordinate normalisation before solving for a homography (Hartley, "In defense of the
eight-point algorithm", applied to seed 000 §3.1-3.2 as DESIGN §4 asks).

A similarity T moves the points' centroid to the origin and scales their mean distance from it
to sqrt(2). Points transform as x' = T x, lines as u' = T^-T u, and a homography fitted between
normalised planes, M', gives M = T_ground^-1 M' T_frontal.
"""

from __future__ import annotations

import math

import numpy as np


def similarity_normaliser(points: np.ndarray) -> np.ndarray:
    """T (3x3) for points (N, 2), N >= 1; coincident points get unit scale."""
    points = np.asarray(points, dtype=float)
    centre = points.mean(axis=0)
    mean_distance = float(np.mean(np.linalg.norm(points - centre, axis=1)))
    scale = math.sqrt(2.0) / mean_distance if mean_distance > 0 else 1.0
    return np.array(
        [[scale, 0.0, -scale * centre[0]], [0.0, scale, -scale * centre[1]], [0.0, 0.0, 1.0]]
    )


def transform_points(transform: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply a 3x3 affine `transform` to points (..., 2)."""
    return np.asarray(points, dtype=float) @ transform[:2, :2].T + transform[:2, 2]


def transform_lines(transform: np.ndarray, lines: np.ndarray) -> np.ndarray:
    """Lines (..., 3) of the plane x, as lines of the plane T x, each scaled to unit length."""
    moved = np.asarray(lines, dtype=float) @ np.linalg.inv(transform)
    return moved / np.linalg.norm(moved, axis=-1, keepdims=True)
