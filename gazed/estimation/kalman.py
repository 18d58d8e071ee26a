"""Kalman and IMM steps over a bank of tracks, computed by the compiled `_kalman` kernel.

A bank holds N tracks of M models of an n-state filter: x (N, M, n), P (N, M, n, n) and, for
an IMM, mu (N, M), all C-contiguous float64, updated in place. `idx` selects the tracks a step
works on: `slice(None)` (all of them, the fast case) or an index array (K,); everything else
has one row per selected track, in that order.

How the models move and are measured is one of two kinds:
- ground (`ground`: the (M, 4) parameters of `ground_models.GroundModelBank`): the CSD / CS /
  CD extended Kalman filters of seed 000 §4.1 on [X, Y, s, θ, ṡ, θ̇], measured by
  h = (X, Y, s cos θ, s sin θ) or (X, Y), a negative speed made positive after each update;
- linear (`F`, `Q` (K, M, n, n) for the step's intervals, `H` (m, n)): seed 003 eqs. (4)-(10).

The equations, one comment each, are in `_kalman.c`:
    predict:  mix (§5 step 1, with J and mu), x' = f(x0), P' = F P0 Fᵀ + λQ, μ <- c̄
              (λ: each track's factor on its ground models' Q, `q_scale`, default 1)
    innovate: ν = z - h(x), S = H P Hᵀ + R, K = P Hᵀ S⁻¹, NIS = νᵀ S⁻¹ ν, ℓ = log N(ν; 0, S)
    correct:  x + K ν, P = (I - K H) P (I - K H)ᵀ + K R Kᵀ (Joseph form), μ ∝ μ exp(ℓ) (§5 step 3)
    forecast: each ground model ahead without mixing, its [X, Y, Ẋ, Ẏ], moments combined
(mixing, combination and the posterior on their own are in `imm`.)
An S that is not positive definite gives NIS = inf and ℓ = -inf (no gate accepts it).
`angle_index` names a state component that is an angle (the heading): mixed and combined as
one (DESIGN §10), wrapped to (-π, π] after an update.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gazed.estimation import _kalman

Index = slice | np.ndarray
NO_ANGLE = -1


def _selection(idx: Index, n_tracks: int) -> tuple[np.ndarray | None, int]:
    """The kernel's rows (None: every track) and their number."""
    if isinstance(idx, slice):
        if idx == slice(None):
            return None, n_tracks
        rows = np.arange(n_tracks)[idx]
        return rows, len(rows)
    if np.asarray(idx).dtype == bool:
        raise TypeError("select tracks by a slice or by their indices, not by a mask")
    rows = np.asarray(idx, dtype=np.int64)
    return rows, len(rows)


def angle_code(angle_index: int | None) -> int:
    """The kernel's angle argument: the index (>= 0; the kernel checks it is a state's), or -1
    for none."""
    if angle_index is None:
        return NO_ANGLE
    if angle_index < 0:
        raise ValueError(f"angle index {angle_index}: expected a state's index >= 0, or None")
    return angle_index


def floats(a: np.ndarray | None) -> np.ndarray | None:
    """a as C-contiguous float64 (no copy when it is already); None stays None."""
    return None if a is None else np.ascontiguousarray(a, dtype=float)


@dataclass
class Innovation:
    """Per selected track and model: ν (K, M, m), S (K, M, m, m), the gain K (K, M, n, m),
    NIS and log-likelihood (K, M); and the measurement covariance R (K, m, m)."""

    y: np.ndarray
    S: np.ndarray
    K: np.ndarray
    nis: np.ndarray
    log_likelihood: np.ndarray
    R: np.ndarray

    def rows(self, keep: np.ndarray) -> Innovation:
        """The tracks where `keep` (K,) is True."""
        return Innovation(*(a[keep] for a in vars(self).values()))


def predict(
    x: np.ndarray,
    P: np.ndarray,
    idx: Index,
    dt: np.ndarray,
    *,
    ground: np.ndarray | None = None,
    F: np.ndarray | None = None,
    Q: np.ndarray | None = None,
    mu: np.ndarray | None = None,
    J: np.ndarray | None = None,
    angle_index: int | None = None,
    q_scale: np.ndarray | None = None,
) -> None:
    """The selected tracks over dt (K,) seconds, in place: mixed first when J (M, M) is given
    (J[i, j] = P(model j next | model i now); mu becomes c̄). q_scale (K,) multiplies each
    selected track's ground-model Q (None: 1)."""
    N, M, n = x.shape
    rows, K = _selection(idx, N)
    _kalman.predict(
        N,
        M,
        n,
        K,
        x,
        P,
        mu,
        rows,
        floats(dt),
        floats(ground),
        floats(J),
        floats(F),
        floats(Q),
        angle_code(angle_index),
        floats(q_scale),
    )


def innovate(
    x: np.ndarray,
    P: np.ndarray,
    idx: Index,
    z: np.ndarray,
    R: np.ndarray,
    *,
    ground: np.ndarray | None = None,
    H: np.ndarray | None = None,
) -> Innovation:
    """The innovation of every model of the selected tracks for z (K, m), R (K, m, m)."""
    N, M, n = x.shape
    rows, K = _selection(idx, N)
    m = z.shape[-1]
    z, R = floats(z), floats(R)
    y = np.empty((K, M, m))
    S = np.empty((K, M, m, m))
    gain = np.empty((K, M, n, m))
    nis = np.empty((K, M))
    log_likelihood = np.empty((K, M))
    _kalman.innovate(
        N, M, n, K, m, x, P, rows, floats(ground), z, R, floats(H), y, S, gain, nis, log_likelihood
    )
    return Innovation(y, S, gain, nis, log_likelihood, R)


def correct(
    x: np.ndarray,
    P: np.ndarray,
    idx: Index,
    innovation: Innovation,
    *,
    ground: np.ndarray | None = None,
    H: np.ndarray | None = None,
    mu: np.ndarray | None = None,
    angle_index: int | None = None,
) -> int:
    """Update the selected tracks (the rows of `innovation`) in place; with mu, their model
    probabilities too. Returns how many ground states had their speed's sign turned."""
    N, M, n = x.shape
    rows, K = _selection(idx, N)
    i = innovation
    return _kalman.correct(
        N,
        M,
        n,
        K,
        i.y.shape[-1],
        x,
        P,
        mu,
        rows,
        floats(ground),
        i.y,
        i.K,
        i.R,
        floats(H),
        i.log_likelihood,
        angle_code(angle_index),
    )


def forecast(
    x: np.ndarray,
    P: np.ndarray,
    mu: np.ndarray,
    idx: Index,
    dt: np.ndarray,
    ground: np.ndarray,
    q_scale: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """A ground IMM's selected tracks dt (K,) >= 0 ahead, unchanged: the mixture's mean
    [X, Y, Ẋ, Ẏ] (K, 4) and covariance (K, 4, 4), with Q times q_scale (K,) (None: 1). A dt
    that is negative or not finite is a ValueError (as in `predict`)."""
    N, M, _ = x.shape
    rows, K = _selection(idx, N)
    mean = np.empty((K, 4))
    cov = np.empty((K, 4, 4))
    _kalman.forecast(
        N, M, K, x, P, mu, rows, floats(dt), floats(ground), mean, cov, floats(q_scale)
    )
    return mean, cov
