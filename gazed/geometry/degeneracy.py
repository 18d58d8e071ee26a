"""Refuse correspondences that cannot fix a plane homography, saying why (DESIGN §4).

A homography needs four points with no three in a line, or dually four lines with no three
through one point. A set of n >= 4 lacks such a four exactly when two entries repeat or n - 1 of
them are dependent: n - 1 points on one line, or n - 1 lines through one point — parallel lines
meet at infinity, so three parallel lines of four are degenerate, while a rectangle's two pairs
of parallel sides are not (the paper's lawn). For four entries this is "three collinear points"
/ "three concurrent (or parallel) lines".

Entries are homogeneous 3-vectors (points (x, y, 1), lines (cos phi, sin phi, -d)) in
normalised coordinates (normalisation.py), so the tolerance is relative to the spread.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import numpy as np

from gazed.geometry.calibration import CalibrationError

# |det| of unit homogeneous vectors below which entries count as dependent: about 0.07 % of the
# spread (1.5 cm across a 20 m lawn).
DEPENDENCE_TOLERANCE = 1e-3


def require_general_position(
    entries: np.ndarray, labels: Sequence[str], kind: Literal["points", "lines"], where: str
) -> None:
    """Raise CalibrationError unless `entries` (N, 3) contain four in general position.

    `where` says which plane is tested (" on the ground", " in the gaze angles")."""
    n = len(entries)
    if n < 4:
        raise CalibrationError(f"need at least 4 {kind} to fix the homography, got {n}")
    unit = entries / np.linalg.norm(entries, axis=1, keepdims=True)
    joins = np.cross(unit[:, None, :], unit[None, :, :])  # (n, n, 3): line through / meet of i, j
    sizes = np.linalg.norm(joins, axis=2)
    upper = np.triu(np.ones((n, n), dtype=bool), k=1)
    repeated = np.argwhere(upper & (sizes < DEPENDENCE_TOLERANCE))
    if len(repeated):
        i, j = repeated[0]
        raise CalibrationError(f"{labels[i]} and {labels[j]} are the same {kind[:-1]}{where}")
    joins = joins / np.where(sizes > 0, sizes, 1.0)[..., None]
    dependent = np.abs(np.einsum("ijc,kc->ijk", joins, unit)) < DEPENDENCE_TOLERANCE
    counts = np.where(upper, dependent.sum(axis=2), 0)
    i, j = np.unravel_index(np.argmax(counts), counts.shape)
    if counts[i, j] >= n - 1:
        members = np.flatnonzero(dependent[i, j])
        names = _join_names([labels[k] for k in members])
        raise CalibrationError(
            f"{names} {_dependence(kind, joins[i, j])}{where}: with {n} {kind}, "
            f"{len(members)} of them {_cannot(kind)} leave the homography undetermined "
            f"(need 4 {kind} with no 3 {_relation(kind)})"
        )


def _dependence(kind: str, common: np.ndarray) -> str:
    if kind == "points":
        return "are collinear"
    # `common` is the point the lines share; at infinity (third coordinate ~0) they are parallel
    return "are parallel" if abs(common[2]) < DEPENDENCE_TOLERANCE else "meet in one point"


def _cannot(kind: str) -> str:
    return "on one line" if kind == "points" else "through one point (or parallel)"


def _relation(kind: str) -> str:
    return "in a line" if kind == "points" else "through one point or parallel"


def _join_names(names: list[str]) -> str:
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]
