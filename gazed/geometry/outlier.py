"""Which calibration entry disagrees with the others, so the person calibrating knows what to
re-measure (seed 000 §3.1 gives the fit; this reads its residuals).

The test works in joint-angle units, where every reading has the same noise sigma
(`[head] angle_noise_deg`). For a maximum-likelihood fit (point_calibration.refine_points) the
sum of squared angle residuals over sigma² is chi-square with m n - 8 degrees of freedom when
every entry is right (m residuals per entry, 8 homography parameters). The entries disagree when
that sum is improbable (P < 1e-3); the entry that stands out is the one whose removal leaves the
most consistent set, named when the other n - 1 then agree (P > 1e-2). Chi-square tails of
even degrees of freedom have a closed form: P(chi²_2k > x) = exp(-x/2) sum_{i<k} (x/2)^i / i!.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from gazed.geometry.calibration import CalibrationError

DISAGREE_PROBABILITY = 1e-3
AGREE_PROBABILITY = 1e-2
FIT_PARAMETERS = 8


@dataclass(frozen=True)
class Verdict:
    """`consistent`: the entries agree within the noise. `outlier`: the index of the entry
    whose removal makes them agree, with the tail probabilities with and without it."""

    consistent: bool
    outlier: int | None
    probability_with: float
    probability_without: float | None


def chi_square_tail(x: float, dof: int) -> float:
    """P(chi² > x) for an even, positive number of degrees of freedom."""
    if dof <= 0 or dof % 2:
        raise ValueError(f"dof must be even and positive, got {dof}")
    half = x / 2.0
    term, total = 1.0, 1.0
    for i in range(1, dof // 2):
        term *= half / i
        total += term
    return math.exp(-half) * total


def find_outlier(
    n: int, chi_square: Callable[[list[int]], float], residuals_per_entry: int = 2
) -> Verdict:
    """Test n entries; `chi_square(indices)` is the normalised sum of squared residuals of the
    fit to those entries. Needs (n - 1) m - 8 >= 2; with fewer entries nothing can be named."""
    value = chi_square(list(range(n)))
    probability_with = chi_square_tail(value, n * residuals_per_entry - FIT_PARAMETERS)
    if probability_with >= DISAGREE_PROBABILITY:
        return Verdict(True, None, probability_with, None)
    dof_without = (n - 1) * residuals_per_entry - FIT_PARAMETERS
    if dof_without < 2:
        return Verdict(False, None, probability_with, None)
    best: tuple[float, int] | None = None
    for k in range(n):
        try:
            candidate = (chi_square([j for j in range(n) if j != k]), k)
        except CalibrationError:
            continue
        best = candidate if best is None else min(best, candidate)
    if best is None:
        return Verdict(False, None, probability_with, None)
    probability_without = chi_square_tail(best[0], dof_without)
    outlier = best[1] if probability_without > AGREE_PROBABILITY else None
    return Verdict(False, outlier, probability_with, probability_without)
