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
    for i in range(n):
        for j in range(i + 1, n):
            join = np.cross(unit[i], unit[j])
            size = np.linalg.norm(join)
            if size < DEPENDENCE_TOLERANCE:
                raise CalibrationError(
                    f"{labels[i]} and {labels[j]} are the same {kind[:-1]}{where}"
                )
            members = np.flatnonzero(np.abs(unit @ (join / size)) < DEPENDENCE_TOLERANCE)
            if len(members) >= n - 1:
                names = _join_names([labels[k] for k in members])
                raise CalibrationError(
                    f"{names} {_dependence(kind, join / size)}{where}: with {n} {kind}, "
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
