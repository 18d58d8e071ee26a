"""What point and line calibration share (seed 000 §3.1-3.2): checked gaze angles, the
fitted homography in canonical form, the least-squares solve, residuals in metres and
leave-one-out errors."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from gazed.config import HeadSection
from gazed.geometry.homography import GroundHomography, HorizonError
from gazed.geometry.kinematics import HeadKinematics

# Smallest singular value of a normalised calibration system, relative to the largest, that
# still determines the eight unknowns.
CONDITION_LIMIT = 1e-10


class CalibrationError(ValueError):
    """Calibration input that cannot give a homography; the message names the entries at fault."""


@dataclass(frozen=True)
class Outlier:
    """The entry that disagrees with the rest (outlier.py): its index, the angle (rad) by which
    the homography of the others misses its measured gaze, and the chi-square tail
    probabilities of the fit with and without it."""

    index: int
    miss_rad: float
    probability_with: float
    probability_without: float


@dataclass(frozen=True, eq=False)
class CalibrationResult:
    """A fitted homography and how well each correspondence agrees with it.

    `residuals_m[i]`: ground distance between where M puts entry i and where the file says it is
    (a line: rms distance of its traced samples from the ground line). `leave_one_out_m[i]`: the
    same for the homography fitted without entry i (None when fewer than 5 entries, or when the
    others alone are degenerate); an entry with a large value disagrees with the rest.
    Point calibration also gives the rms angle residual (rad) and the outlier test's verdict:
    `consistent` is False when the entries disagree beyond the head's angle noise, `outlier`
    names the one entry whose removal explains it."""

    homography: GroundHomography
    labels: tuple[str, ...]
    residuals_m: np.ndarray
    leave_one_out_m: tuple[float | None, ...]
    angle_rms_rad: float | None = None
    consistent: bool | None = None
    outlier: Outlier | None = None

    @property
    def n(self) -> int:
        return len(self.labels)

    @property
    def rms_m(self) -> float:
        return float(np.sqrt(np.mean(self.residuals_m**2)))

    @property
    def max_m(self) -> float:
        return float(np.max(self.residuals_m))


def checked_frontal(
    pan_rad: float, tilt_rad: float, head: HeadKinematics, limits: HeadSection | None, label: str
) -> np.ndarray:
    """Frontal-plane point (2,) of a calibration gaze (seed 000 §3 eq. for x), refusing
    non-finite angles, angles outside the head's limits, and gazes that miss the frontal plane."""
    if not (math.isfinite(pan_rad) and math.isfinite(tilt_rad)):
        raise CalibrationError(f"{label}: angles are not finite (pan {pan_rad}, tilt {tilt_rad})")
    pan_deg, tilt_deg = math.degrees(pan_rad), math.degrees(tilt_rad)
    if limits is not None:
        for axis, value, low, high in (
            ("pan", pan_deg, limits.pan_min_deg, limits.pan_max_deg),
            ("tilt", tilt_deg, limits.tilt_min_deg, limits.tilt_max_deg),
        ):
            if not low <= value <= high:
                raise CalibrationError(
                    f"{label}: {axis} {value:.3f} deg is outside the head's {axis} limits "
                    f"[{low:g}, {high:g}] deg"
                )
    try:
        return np.array(head.frontal_from_angles(pan_rad, tilt_rad))
    except ValueError as exc:
        raise CalibrationError(
            f"{label}: gaze (pan {pan_deg:.3f}, tilt {tilt_deg:.3f} deg) does not meet the "
            "frontal plane: |pan| and |tilt| must stay below 90 deg"
        ) from exc


def canonical_homography(
    matrix: np.ndarray, visible_frontal: Sequence[np.ndarray], labels: Sequence[str]
) -> GroundHomography:
    """M in canonical form (homography.py), with every calibration gaze below its horizon;
    names the entries that a fitted M puts on the other side of the horizon from the rest."""
    lams = [np.atleast_2d(f) @ matrix[2, :2] + matrix[2, 2] for f in visible_frontal]
    sign = 1.0 if sum(float(np.sum(np.sign(lam))) for lam in lams) >= 0 else -1.0
    wrong = [labels[i] for i, lam in enumerate(lams) if np.any(lam * sign <= 0)]
    if wrong:
        raise CalibrationError(
            f"{', '.join(wrong)}: the fitted homography puts these gazes on the other side of the "
            "horizon from the rest: some angles or ground coordinates are wrong (two swapped?)"
        )
    return GroundHomography.from_matrix(matrix * sign)


def leave_one_out(
    n: int,
    fit: Callable[[list[int]], GroundHomography],
    error_m: Callable[[GroundHomography, int], float],
) -> tuple[float | None, ...]:
    """For each entry i, its error under the fit of the others; None where fewer than 5
    entries or the others alone are degenerate."""
    if n < 5:
        return (None,) * n
    held_out: list[float | None] = []
    for i in range(n):
        try:
            homography = fit([j for j in range(n) if j != i])
        except CalibrationError:
            held_out.append(None)
            continue
        held_out.append(_error_or_inf(error_m, homography, i))
    return tuple(held_out)


def _error_or_inf(
    error_m: Callable[[GroundHomography, int], float], homography: GroundHomography, i: int
) -> float:
    try:
        return float(error_m(homography, i))
    except HorizonError:
        return math.inf


def solve_least_squares(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """m = (A^T A)^-1 A^T b (§3.1, §3.2), refusing a rank-deficient A."""
    m, _, _, singular = np.linalg.lstsq(a, b, rcond=None)
    if len(singular) < a.shape[1] or singular[-1] < CONDITION_LIMIT * singular[0]:
        raise CalibrationError(
            "the correspondences do not determine the homography (the least-squares system is "
            "rank-deficient): add entries spread over the area"
        )
    return m
