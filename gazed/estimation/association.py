"""Which detection belongs to which track: global nearest neighbour on the tracks' predictions.

Each track predicts its measurement `ẑ` with innovation covariance `S = H P Hᵀ + R` at the
detections' capture time. A detection `z` is a candidate for a track when its Mahalanobis
distance `d² = (z - ẑ)ᵀ S⁻¹ (z - ẑ)` lies inside the gate, the χ² quantile of the measurement's
dimension at `gate_probability` (Bar-Shalom, Willett & Tian, "Tracking and Data Fusion", 2011,
§2.3). Among the candidates, all tracks and detections are assigned jointly: the assignment
that minimises the summed cost (Munkres' problem, solved by SciPy's `linear_sum_assignment`),
so where people cross, pass or walk together one track cannot take another's detection because
it is a little nearer to it.

The cost of a pair is its negative log-likelihood, doubled and without constants:
`d² + ln det S` for the position (a track whose prediction is uncertain does not win merely by
its wide gate), plus `h² / σ²` where both carry an appearance descriptor: `h² = 1 - BC` is the
squared Hellinger distance between their normalised colour histograms (BC, the Bhattacharyya
coefficient, is 1 for the same colours), and `σ²` the track's own spread of it, measured over
the detections it has taken — so a person whose colours vary from frame to frame (changing
light, a turning body) is compared more loosely than one whose colours hold. Where positions are
ambiguous the appearance decides; where they are not it barely matters.

Two tracks are of one target (`same_target`) when the difference of their positions and
velocities lies inside the χ² gate of that dimension against the sum of their covariances
(Bar-Shalom, "On the track-to-track correlation problem", IEEE TAC 26(2), 1981; the two
estimates' cross-covariance is left out, which widens the test a little), with the target's
extent added to the positions: a detector may report one part of a person to one track and
another part to the other.

The joint assignment is SciPy's; `scipy.optimize` takes long to import (on a busy machine,
longer than a bus link's lease), so the estimator imports it beside its start-up
(`load_solver`) rather than in the step where several tracks first compete: a step that long
holds up the bus's receive thread past the lease, and the link closes.
"""

from __future__ import annotations

import importlib
import threading
from dataclasses import dataclass

import numpy as np

from gazed.estimation.chi_square import chi2_quantile
from gazed.estimation.results import PredictedState

SOLVER_MODULE = "scipy.optimize"

UNASSIGNABLE = 1e12  # the cost of a pair outside the gate


@dataclass(frozen=True)
class Assignment:
    """Pairs (track row, detection index) and what is left on each side."""

    pairs: tuple[tuple[int, int], ...]
    lone_tracks: tuple[int, ...]
    lone_detections: tuple[int, ...]
    costs: np.ndarray  # (T, D): each pair's cost, inf outside the gate


def gate_threshold(probability: float, dimension: int) -> float:
    """The d² inside which a measurement of `dimension` falls with `probability`."""
    return chi2_quantile(probability, dimension)


def hellinger_squared(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """`1 - Σ √(a b)` over the last axis of two sets of normalised histograms, every pair:
    (A, B), from 0 (the same) to 1 (nothing in common)."""
    coefficient = (np.sqrt(a)[:, None, :] * np.sqrt(b)[None, :, :]).sum(axis=-1)
    return np.clip(1.0 - coefficient, 0.0, 1.0)


def pair_costs(
    predicted: np.ndarray,
    S: np.ndarray,
    measured: np.ndarray,
    gate_d2: float,
    track_appearance: np.ndarray | None = None,
    detection_appearance: np.ndarray | None = None,
    appearance_variance: np.ndarray | None = None,
) -> np.ndarray:
    """(T, D) costs: `d² + ln det S (+ h² / σ²)`, inf where `d²` is outside the gate.

    predicted (T, m), measured (D, m); S (T, m, m) per track, or (T, D, m, m) per pair where
    each detection carries its own measurement noise (S = H P Hᵀ + R_d); appearances (T, B)
    and (D, B), rows summing to 1 (a row of NaN for a track or detection without one), and each
    track's σ² (T,); all three or none."""
    T, D = len(predicted), len(measured)
    if T == 0 or D == 0:
        return np.full((T, D), np.inf)
    y = measured[None, :, :] - predicted[:, None, :]  # (T, D, m)
    S_pairs = S if S.ndim == 4 else S[:, None]  # (T, D or 1, m, m)
    if y.shape[-1] == 2:  # closed forms of the 2x2 inverse and determinant
        a, b, d = S_pairs[..., 0, 0], S_pairs[..., 0, 1], S_pairs[..., 1, 1]
        det = a * d - b * b
        y0, y1 = y[..., 0], y[..., 1]
        d2 = (d * y0 * y0 - 2.0 * b * y0 * y1 + a * y1 * y1) / det
        log_det = np.log(det)
    else:
        d2 = np.einsum("tdi,tdij,tdj->td", y, np.linalg.inv(S_pairs), y)
        log_det = np.linalg.slogdet(S_pairs)[1]
    costs = d2 + log_det
    if track_appearance is not None and detection_appearance is not None:
        assert appearance_variance is not None, "an appearance needs each track's spread"
        h2 = hellinger_squared(track_appearance, detection_appearance)
        costs = costs + np.nan_to_num(h2 / appearance_variance[:, None], nan=0.0)
    return np.where(d2 <= gate_d2, costs, np.inf)


def same_target(
    a: PredictedState, b: PredictedState, gate_d2: float, extent_cov: np.ndarray | None = None
) -> bool:
    """Whether two tracks' states at one instant are estimates of one target: `Δᵀ C⁻¹ Δ` over
    [position, velocity] at most `gate_d2` (the χ² gate of 4 dimensions), where
    `C = Pa + Pb`, plus twice `extent_cov` (2, 2) on the positions where each track may follow
    a different part of one extended target."""
    delta = np.concatenate([a.position - b.position, a.velocity - b.velocity])
    C = a.covariance + b.covariance
    if extent_cov is not None:
        C[:2, :2] += 2.0 * extent_cov
    return float(delta @ np.linalg.solve(C, delta)) <= gate_d2


def load_solver() -> threading.Thread:
    """Start importing the assignment's solver on a thread of its own, so that the first frame
    where several tracks compete finds it imported (module docstring); the thread is returned."""
    thread = threading.Thread(
        target=importlib.import_module, args=(SOLVER_MODULE,), name="import-solver", daemon=True
    )
    thread.start()
    return thread


def associate(costs: np.ndarray) -> Assignment:
    """The joint assignment of least total cost among the pairs inside the gate."""
    T, D = costs.shape
    pairs: list[tuple[int, int]] = []
    if T and D and (T == 1 or D == 1):  # one track (or detection): its least cost in the gate
        k = int(np.argmin(costs))
        r, c = divmod(k, D)
        if np.isfinite(costs[r, c]):
            pairs = [(r, c)]
    elif T and D:
        from scipy.optimize import linear_sum_assignment  # imported by then (`load_solver`)

        finite = np.where(np.isfinite(costs), costs, UNASSIGNABLE)
        rows, cols = linear_sum_assignment(finite)
        pairs = [
            (int(r), int(c)) for r, c in zip(rows, cols, strict=True) if np.isfinite(costs[r, c])
        ]
    taken_tracks = {r for r, _ in pairs}
    taken_detections = {c for _, c in pairs}
    return Assignment(
        pairs=tuple(pairs),
        lone_tracks=tuple(r for r in range(T) if r not in taken_tracks),
        lone_detections=tuple(c for c in range(D) if c not in taken_detections),
        costs=costs,
    )
