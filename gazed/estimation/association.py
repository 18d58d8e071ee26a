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
its wide gate), plus, where both carry an appearance descriptor, that of `h² = 1 - BC`, the
squared Hellinger distance between their normalised colour histograms (BC, the Bhattacharyya
coefficient, is 1 for the same colours), under the distribution of it the track has measured
over the detections it has taken (`appearance_model`) — so a person whose colours vary from
frame to frame (changing light, a turning body) is compared more loosely than one whose colours
hold. Where positions are ambiguous the appearance decides; the gate is on the positions alone
(a person's colours change where a blob merges or a part of them is hidden).

Two tracks are of one target (`same_target`) when the difference of their positions and
velocities lies inside the χ² gate of that dimension against the sum of their covariances
(Bar-Shalom, "On the track-to-track correlation problem", IEEE TAC 26(2), 1981; the two
estimates' cross-covariance is left out, which widens the test a little), with the target's
extent added to the positions: a detector may report one part of a person to one track and
another part to the other.

A detector can report people who walk together as one blob, whose point lies between them: in
no one's gate, or in one's gate at the pair's midpoint. So where a confirmed track is left
without a detection, the blob hypothesis is tested against the one-person one: the detection as
the centroid of the two tracks' predictions (`group_prediction`), its covariance widened by the
unknown share each member has of the blob (its visible area), taken as uniform over the simplex
(Dirichlet(1, …, 1)). Where that hypothesis costs less, and its d² lies inside the gate, each
member takes the detection as a measurement of itself (`member_measurement`): the blob's
centroid less the other members' predictions, with the noise that leaves. Neither track is
pulled onto the pair's midpoint; both follow the pair's common motion and keep their ids, and
the separation the predictions carry is kept until the blob splits. Where the caller knows which
tracks can lie inside each detection's silhouette (`silhouette_reach`), only those are members.

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

from gazed.estimation.appearance_model import appearance_costs
from gazed.estimation.chi_square import chi2_quantile
from gazed.estimation.measurement import Measurement
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
    appearance_mean: np.ndarray | None = None,
    appearance_shape: np.ndarray | None = None,
) -> np.ndarray:
    """(T, D) costs: `d² + ln det S (- 2 ln p(h²))`, inf where `d²` is outside the gate.

    predicted (T, m), measured (D, m); S (T, m, m) per track, or (T, D, m, m) per pair where
    each detection carries its own measurement noise (S = H P Hᵀ + R_d); appearances (T, B)
    and (D, B), rows summing to 1 (a row of NaN for a track or detection without one), and each
    track's mean h² and shape (T,) (`appearance_model`); all four or none."""
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
        assert appearance_mean is not None and appearance_shape is not None, "and their fits"
        h2 = hellinger_squared(track_appearance, detection_appearance)
        costs = costs + np.nan_to_num(appearance_costs(h2, appearance_mean, appearance_shape))
    return np.where(d2 <= gate_d2, costs, np.inf)


def group_prediction(
    predicted: np.ndarray, P: np.ndarray, R: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Where one blob of n members (predictions (n, m), covariances P (n, m, m)) is measured with
    noise R (m, m): the centroid `x̄` and its innovation covariance `ΣP / n² + R + W`, where
    `W` (`weight_spread`) is the spread each member's unknown share of the blob adds."""
    n = len(predicted)
    return predicted.mean(axis=0), P.sum(axis=0) / n**2 + R + weight_spread(predicted)


def weight_spread(points: np.ndarray) -> np.ndarray:
    """`W = Σ (x_i - x̄)(x_i - x̄)ᵀ / (n (n + 1))` of n points (n, m): the covariance of
    `Σ w_i x_i` for weights w uniform over the simplex."""
    n = len(points)
    spread = points - points.mean(axis=0)
    return spread.T @ spread / (n * (n + 1))


def member_measurement(z: Measurement, member: int, states: list[PredictedState]) -> Measurement:
    """A blob's measurement z as one of its members' (`states`, one per member): `n z - Σ x̂_j`
    over the others, with covariance `n² (R + W) + Σ P_j` (W of the predicted positions,
    `weight_spread`). Its d² against the member's prediction is the blob's against the
    group's, so a filter gates it alike. The blob's velocity is left out: it is the pair's
    mean velocity, not a member's."""
    n = len(states)
    predicted = np.array([s.position for s in states])
    others = [j for j in range(n) if j != member]
    P_others = sum((states[j].covariance[:2, :2] for j in others), np.zeros((2, 2)))
    R = z.position_cov + weight_spread(predicted)
    position = n * z.position - predicted[others].sum(axis=0)
    return Measurement(z.t_s, position, n**2 * R + P_others)


@dataclass(frozen=True)
class Blob:
    """One detection (a column) taken as the blob of two tracks (rows)."""

    rows: tuple[int, int]
    column: int


def find_blobs(
    predicted: np.ndarray,
    P: np.ndarray,
    confirmed: np.ndarray,
    measured: list[Measurement],
    pairs: dict[int, int],
    costs: np.ndarray,
    gate_d2: float,
    appearance: tuple[np.ndarray, ...] = (),
    inside: np.ndarray | None = None,
) -> list[Blob]:
    """The detections better taken as the blob of two confirmed tracks than as one person.

    Tried for each confirmed track left without a detection by the assignment `pairs` (row ->
    column, of `costs`): with the confirmed track that took the detection, or, where a tentative
    track or none took it, with another such lone track. Kept where its cost (`pair_costs` of
    the group's centroid, its appearance against the mean of the members' templates) is inside
    the gate and below the cost of the detection's own pair; the least costly first, each
    track and detection in one blob at most. predicted (T, m), P (T, m, m), confirmed (T,);
    `appearance` as `pair_costs` takes it for all tracks and detections, or (); `inside` (T, D):
    whether each track can lie in each detection's silhouette (`silhouette_reach`), None: any."""
    lone = [r for r in range(len(predicted)) if confirmed[r] and r not in pairs]
    holder = {c: r for r, c in pairs.items()}
    options = []
    for row in lone:
        for column, z in enumerate(measured):
            held = holder.get(column)
            partners = [held] if held is not None and confirmed[held] else lone
            single = costs[held, column] if held is not None else np.inf
            for partner in (p for p in partners if p != row):
                if inside is not None and not (inside[row, column] and inside[partner, column]):
                    continue
                rows = [row, partner]
                mean, S = group_prediction(predicted[rows], P[rows], z.position_cov)
                looks = ()
                if appearance:
                    templates, seen, means, shapes = appearance
                    looks = (
                        templates[rows].mean(axis=0)[None],
                        seen[column][None],
                        means[rows].mean()[None],
                        shapes[rows].mean()[None],
                    )
                cost = float(
                    pair_costs(mean[None], S[None], z.position[None], gate_d2, *looks)[0, 0]
                )
                if cost < single:
                    options.append((cost, row, partner, column))
    blobs: list[Blob] = []
    used_rows: set[int] = set()
    used_columns: set[int] = set()
    for _, row, partner, column in sorted(options):
        if row in used_rows or partner in used_rows or column in used_columns:
            continue
        blobs.append(Blob((row, partner), column))
        used_rows |= {row, partner}
        used_columns.add(column)
    return blobs


def same_target(
    a: PredictedState, b: PredictedState, gate_d2: float, extent_cov: np.ndarray | None = None
) -> bool:
    """Whether two tracks' states at one instant are estimates of one target: `Δᵀ C⁻¹ Δ` over
    [position, velocity] at most `gate_d2` (the χ² gate of 4 dimensions), where
    `C = Pa + Pb`, plus twice `extent_cov` (2, 2) on the positions where each track may follow
    a different part of one extended target. Where C is singular (a model without spread on an
    axis), a difference on that axis is not one target's."""
    delta = np.concatenate([a.position - b.position, a.velocity - b.velocity])
    C = a.covariance + b.covariance
    if extent_cov is not None:
        C[:2, :2] += 2.0 * extent_cov
    try:
        x = np.linalg.solve(C, delta)  # C⁻¹ Δ
    except np.linalg.LinAlgError:  # singular: an axis where neither state has a spread
        x = np.linalg.pinv(C) @ delta
        if not np.allclose(C @ x, delta):  # a difference where neither state admits one
            return False
    return float(delta @ x) <= gate_d2


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
