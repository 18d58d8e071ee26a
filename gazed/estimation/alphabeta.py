"""The `alphabeta` mode: the adaptive estimator / predictor of seed 004 §4, eqs. (2)-(10).

Per axis, with θ̂ the estimates and θ_m the measurements:

- estimate  θ̂(k) = α1 θ̂_p(k|k-1) + α2 θ_m(k)                        (eq. 2, α1 + α2 = 1)
  α1 = σ_m² / (σ_p² + σ_m²), α2 = σ_p² / (σ_p² + σ_m²)               (eq. 5)
- predict   θ̂_p(k+1|k) = β1 θ̂_l(k+1|k) + β2 θ̂_q(k+1|k)              (eq. 7)
  β1 = σ_q² / (σ_l² + σ_q²), β2 = σ_l² / (σ_l² + σ_q²)               (eq. 9)
  σ_l² ≈ [θ̂(k) - θ̂_l(k|k-1)]², σ_q² ≈ [θ̂(k) - θ̂_q(k|k-1)]²          (eq. 10)

θ̂_l is the 2-point linear predictor (eq. 8) and θ̂_q, per the DESIGN §10 erratum, the
least-squares quadratic through the last five estimates (the printed 5-point formula is exact
for lines only). Both are fitted on the estimates' own timestamps, so they extrapolate to any
time — the next measurement or any horizon — and take variable intervals.

The variances of eq. 6 are estimated differently from the print, on purpose. Its instantaneous
approximations σ_p² ≈ [θ̂(k-1) - θ̂_p(k-1|k-2)]² and σ_m² ≈ [θ̂(k-1) - θ_m(k-1)]² are, by eq. 2,
(α2 e)² and (α1 e)² for the same e = θ_m - θ̂_p, so the next α2 = α2²/(α1² + α2²) depends on the
previous α only: it runs to 0 or 1, and from the 0/0 start (1/2) it never moves. Here σ_m² is
the measurement's own variance (every measurement carries its covariance) and σ_p² is the
running mean of (θ_m - θ̂_p)² less σ_m² (floored at 0), both from before step k as in eq. 6.
σ_l², σ_q² are running means of eq. 10's squares. `smoothing` is the weight of the newest
square (1 gives eq. 10's instantaneous values).
Guards: a weight whose two variances are both 0 (0/0) is 1/2; with fewer than three estimates
the quadratic is the line; a track starts from two measurements as its first two estimates.
The mode has no model covariance; `forecast` reports an empirical one (see `_forecast`).
"""

from __future__ import annotations

import numpy as np

from gazed.estimation.estimator import TrackEstimator

HISTORY = 5


def weight(numerator_var: np.ndarray, other_var: np.ndarray) -> np.ndarray:
    """numerator / (numerator + other), 1/2 where both are 0 (eqs. 5 and 9)."""
    total = numerator_var + other_var
    return np.where(total > 0, numerator_var / np.where(total > 0, total, 1.0), 0.5)


def polynomial_fit(t: np.ndarray, y: np.ndarray, valid: np.ndarray, degree: int) -> np.ndarray:
    """Least-squares polynomial coefficients (lowest power first) per track and axis.

    t (K, H) times relative to the newest estimate, y (K, H, 2), valid (K, H) bool -> (K, deg+1, 2).
    """
    V = t[..., None] ** np.arange(degree + 1) * valid[..., None]  # (K, H, d+1)
    A = V.mT @ V
    b = V.mT @ (y * valid[..., None])
    return np.linalg.solve(A, b)


def polynomial_value(c: np.ndarray, t: np.ndarray, derivative: int = 0) -> np.ndarray:
    """Value (or first derivative) of coefficients c (K, d+1, 2) at t (K,) -> (K, 2)."""
    powers = np.arange(c.shape[1])
    if derivative == 0:
        basis = t[:, None] ** powers
    else:
        basis = powers * t[:, None] ** np.maximum(powers - 1, 0)
    return (basis[:, :, None] * c).sum(axis=1)


class AlphaBetaEstimator(TrackEstimator):
    """Adaptive α-β estimation and linear/quadratic prediction, per axis (x, y)."""

    filter_name = "alphabeta"

    def __init__(
        self, n_tracks: int = 1, *, smoothing: float = 0.2, **track_options: float
    ) -> None:
        if not 0 < smoothing <= 1:
            raise ValueError(f"smoothing must be in (0, 1], got {smoothing}")
        super().__init__(("alpha-beta",), n_tracks, **track_options)
        self.smoothing = smoothing
        self.history = np.zeros((n_tracks, HISTORY, 2))  # θ̂, newest last
        self.history_t = np.zeros((n_tracks, HISTORY))
        self.count = np.zeros(n_tracks, dtype=np.int64)
        self.since_s = np.zeros(n_tracks)  # time from the newest estimate to the track's time
        self.var_l = np.zeros((n_tracks, 2))  # σ_l², σ_q² of eq. 10 (running means)
        self.var_q = np.zeros((n_tracks, 2))
        self.spread = np.zeros((n_tracks, 2))  # running mean of (θ_m - θ̂_p)²
        self.speed_var = np.zeros((n_tracks, 2))  # ... divided by the interval²
        self._predicted: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    # The predictors ---------------------------------------------------------------------------

    def _predictors(
        self, idx: slice | np.ndarray, dt: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """θ̂_l and θ̂_q dt after the newest estimate, and their velocities: 4 x (K, 2)."""
        h, ht, n = self.history[idx], self.history_t[idx], self.count[idx]
        t_rel = ht - ht[:, -1:]
        valid = np.arange(HISTORY)[None, :] >= HISTORY - np.minimum(n, HISTORY)[:, None]
        # 2-point line through the last two estimates (eq. 8); one estimate: constant
        span = np.where(n >= 2, -t_rel[:, -2], 1.0)[:, None]
        slope = np.where(n[:, None] >= 2, (h[:, -1] - h[:, -2]) / span, 0.0)
        line = h[:, -1] + slope * dt[:, None]
        # least-squares quadratic over the last five (erratum of eq. 8); < 3 estimates: the line
        enough = n >= 3
        quad, quad_v = line.copy(), slope.copy()
        if enough.any():
            # rows without three estimates get a well-posed stand-in fit (their result is unused)
            t_fit = np.where(enough[:, None], t_rel, np.arange(1 - HISTORY, 1.0))
            c = polynomial_fit(t_fit, h, np.where(enough[:, None], valid, True), 2)
            quad = np.where(enough[:, None], polynomial_value(c, dt), line)
            quad_v = np.where(enough[:, None], polynomial_value(c, dt, 1), slope)
        return line, quad, slope, quad_v

    def _beta(self, idx: slice | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        beta1 = weight(self.var_q[idx], self.var_l[idx])  # eq. 9
        return beta1, 1.0 - beta1

    # TrackEstimator --------------------------------------------------------------------------

    def _initialise(
        self, idx: np.ndarray, zv: np.ndarray, Rv: np.ndarray, interval_s: np.ndarray
    ) -> None:
        """The first two estimates are the two measurements that started the track (a
        measured velocity stands in for the earlier one, 1 s before)."""
        dt = np.where(np.isfinite(interval_s), interval_s, 1.0)
        self.history[idx] = 0.0
        self.history_t[idx] = 0.0
        self.history[idx, -2] = zv[:, :2] - zv[:, 2:] * dt[:, None]
        self.history[idx, -1] = zv[:, :2]
        self.history_t[idx, -2] = -dt
        self.count[idx] = 2
        self.since_s[idx] = 0.0
        self.var_l[idx] = 0.0
        self.var_q[idx] = 0.0
        # the spreads start wide (the initial speed uncertainty over one interval) and learn
        self.speed_var[idx] = self.initial_speed_std**2
        self.spread[idx] = (
            np.diagonal(Rv[:, :2, :2], axis1=1, axis2=2)
            + (self.initial_speed_std * dt[:, None]) ** 2
        )

    def _predict(self, idx: slice | np.ndarray, dt: np.ndarray) -> None:
        """θ̂_p at the track's new time (eq. 7), kept for the update. A predict-only step adds
        no estimate: the history holds estimates from measurements only."""
        self.since_s[idx] += dt
        line, quad, _, _ = self._predictors(idx, self.since_s[idx])
        beta1, beta2 = self._beta(idx)
        self._predicted = (beta1 * line + beta2 * quad, line, quad)

    def _innovate(
        self, idx: slice | np.ndarray, z: np.ndarray, R: np.ndarray
    ) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray]]:
        """NIS of the position against θ̂_p with S = diag(spread) (which includes R), widened
        by the velocity spread over the time since the last estimate."""
        assert self._predicted is not None
        y = z[:, :2] - self._predicted[0]
        since = self.since_s[idx][:, None]
        spread = np.maximum(self.spread[idx], np.diagonal(R[:, :2, :2], axis1=1, axis2=2))
        spread = spread + self.speed_var[idx] * since * since
        nis = (y * y / spread).sum(axis=-1)
        return nis, (z[:, :2], np.diagonal(R[:, :2, :2], axis1=1, axis2=2))

    def _correct(
        self,
        idx: slice | np.ndarray,
        handle: tuple[np.ndarray, np.ndarray],
        inside: np.ndarray | None,
    ) -> None:
        """Eqs. 2, 5, 10 (and the variances of eq. 6, see above) for the tracks idx[inside]
        (all of idx: None); the others keep the prediction as their estimate."""
        assert self._predicted is not None
        keep = slice(None) if inside is None else inside
        predicted, line, quad = (a[keep] for a in self._predicted)
        measured, var_m = (a[keep] for a in handle)
        rows = np.arange(self.n_tracks)[idx][keep]
        var_p = np.maximum(self.spread[rows] - var_m, 0.0)  # σ_p², σ_m² from before step k
        alpha1 = weight(var_m, var_p)  # eq. 5
        estimate = alpha1 * predicted + (1.0 - alpha1) * measured  # eq. 2
        dt = self.since_s[rows]
        self.history[rows] = np.concatenate([self.history[rows, 1:], estimate[:, None]], axis=1)
        t_new = self.history_t[rows, -1] + dt
        self.history_t[rows] = np.concatenate([self.history_t[rows, 1:], t_new[:, None]], axis=1)
        self.count[rows] += 1
        self.since_s[rows] = 0.0
        g = self.smoothing
        self.var_l[rows] += g * ((estimate - line) ** 2 - self.var_l[rows])  # eq. 10
        self.var_q[rows] += g * ((estimate - quad) ** 2 - self.var_q[rows])
        error2 = (measured - predicted) ** 2
        self.spread[rows] += g * (error2 - self.spread[rows])
        self.speed_var[rows] += g * (error2 / (dt * dt)[:, None] - self.speed_var[rows])

    def _forecast(self, idx: slice | np.ndarray, dt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """β1 θ̂_l + β2 θ̂_q at dt after the newest estimate, its velocity, and an empirical
        covariance: the running mean of squared one-step errors, grown with the horizon
        as the position error of a velocity error (no cross terms)."""
        ahead = self.since_s[idx] + dt
        line, quad, v_line, v_quad = self._predictors(idx, ahead)
        beta1, beta2 = self._beta(idx)
        mean = np.concatenate(
            [beta1 * line + beta2 * quad, beta1 * v_line + beta2 * v_quad], axis=-1
        )
        var = np.concatenate(
            [
                self.spread[idx] + self.speed_var[idx] * (ahead * ahead)[:, None],
                self.speed_var[idx],
            ],
            axis=-1,
        )
        cov = np.zeros((len(var), 4, 4))
        cov[:, np.arange(4), np.arange(4)] = var
        return mean, cov

    def _probabilities(self, idx: slice | np.ndarray) -> np.ndarray:
        return np.ones((len(np.arange(self.n_tracks)[idx]), 1))
