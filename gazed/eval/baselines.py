"""Honest baselines for the pedestrian evaluation: what a filter has to beat.

Each predictor takes a batch of N tracks a step at a time, as the estimators do, and forecasts
each track's position at any later time from what it has seen so far:

- `ConstantPosition`: the last measured position.
- `TwoPoint`: the last velocity carried forward, `z_k + (z_k - z_{k-1}) / (t_k - t_{k-1}) · h`
  (seed 004 eq. 8's linear predictor).
- `ConstantVelocity`: a Kalman filter on each axis with white-noise acceleration of spectral
  density `q` and measurement variance `r`; `fit_constant_velocity` chooses both by maximum
  likelihood of the file's own innovations (the best a tuned constant-velocity filter can do,
  and one no single set of defaults can beat on every file).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

GRID_POINTS = 13  # log-spaced values of q and of r per round of the likelihood search
SEARCH_ROUNDS = 3  # each round narrows the grid around the best pair
Q_RANGE = (1e-4, 1e2)  # m²/s³: from a walker gliding to one stopping and turning sharply
R_RANGE = (1e-6, 1.0)  # m²: from millimetre annotations to a metre of detector noise


@dataclass(frozen=True)
class Positions:
    """Forecast positions (N, 2) and which rows hold one."""

    position: np.ndarray
    valid: np.ndarray


class ConstantPosition:
    """The last measured position, held."""

    def __init__(self, n_tracks: int) -> None:
        self.t_s = np.full(n_tracks, np.nan)
        self._z = np.full((n_tracks, 2), np.nan)

    def step(self, t_s: np.ndarray, z: np.ndarray, present: np.ndarray) -> None:
        self.t_s = np.where(present, t_s, self.t_s)
        self._z = np.where(present[:, None], z, self._z)

    def forecast(self, t_s: np.ndarray) -> Positions:
        del t_s
        return Positions(self._z.copy(), np.isfinite(self.t_s))


class TwoPoint:
    """The last two measurements' velocity, carried forward."""

    def __init__(self, n_tracks: int) -> None:
        self.t_s = np.full(n_tracks, np.nan)
        self._z = np.full((n_tracks, 2), np.nan)
        self._v = np.full((n_tracks, 2), np.nan)

    def step(self, t_s: np.ndarray, z: np.ndarray, present: np.ndarray) -> None:
        with np.errstate(invalid="ignore", divide="ignore"):
            v = (z - self._z) / (t_s - self.t_s)[:, None]
        self._v = np.where(present[:, None], v, self._v)
        self.t_s = np.where(present, t_s, self.t_s)
        self._z = np.where(present[:, None], z, self._z)

    def forecast(self, t_s: np.ndarray) -> Positions:
        h = (t_s - self.t_s)[:, None]
        position = self._z + self._v * h
        return Positions(position, np.all(np.isfinite(position), axis=1))


class ConstantVelocity:
    """Per axis, state `[p, v]`, `F = [[1, dt], [0, 1]]`, `Q = q [[dt³/3, dt²/2], [dt²/2, dt]]`,
    `H = [1, 0]`, `R = r` (Bar-Shalom, Li & Kirubarajan 2001, §6.2.2, the continuous white-noise
    acceleration model). Started from the first two measurements. `q` and `r` may be arrays that
    broadcast against the tracks, so that many noise pairs run in one batch.

    `log_likelihood` accumulates each track's `-½ (ln 2πS + y²/S)` from its third measurement
    on, the innovations' Gaussian log-likelihood that `fit_constant_velocity` maximises."""

    def __init__(self, n_tracks: int, q: np.ndarray | float, r: np.ndarray | float) -> None:
        self.q = np.broadcast_to(np.asarray(q, dtype=float), (n_tracks,))[:, None]
        self.r = np.broadcast_to(np.asarray(r, dtype=float), (n_tracks,))[:, None]
        self.t_s = np.full(n_tracks, np.nan)
        self.count = np.zeros(n_tracks, dtype=int)
        shape = (n_tracks, 2)  # per track, per axis
        self.p, self.v = np.full(shape, np.nan), np.full(shape, np.nan)
        self.Ppp, self.Ppv, self.Pvv = np.zeros(shape), np.zeros(shape), np.zeros(shape)
        self.log_likelihood = np.zeros(n_tracks)

    def step(self, t_s: np.ndarray, z: np.ndarray, present: np.ndarray) -> None:
        first = present & (self.count == 0)
        second = present & (self.count == 1)
        running = present & (self.count >= 2)
        dt = (t_s - self.t_s)[:, None]
        if second.any():
            rows = second[:, None]
            v = (z - self.p) / np.where(rows, dt, 1.0)
            self.v = np.where(rows, v, self.v)
            self.p = np.where(rows, z, self.p)
            dt2 = np.where(rows, dt, 1.0) ** 2
            self.Ppp = np.where(rows, self.r, self.Ppp)
            self.Ppv = np.where(rows, self.r / np.sqrt(dt2), self.Ppv)
            self.Pvv = np.where(rows, 2.0 * self.r / dt2, self.Pvv)
        if running.any():
            self._update(z, np.where(running[:, None], dt, 0.0), running)
        if first.any():
            self.p = np.where(first[:, None], z, self.p)
        self.t_s = np.where(present, t_s, self.t_s)
        self.count += present

    def _update(self, z: np.ndarray, dt: np.ndarray, running: np.ndarray) -> None:
        q, r = self.q, self.r
        # predict: x = F x, P = F P F^T + Q
        p = self.p + self.v * dt
        Ppp = self.Ppp + 2 * dt * self.Ppv + dt**2 * self.Pvv + q * dt**3 / 3
        Ppv = self.Ppv + dt * self.Pvv + q * dt**2 / 2
        Pvv = self.Pvv + q * dt
        # innovation y = z - H x, S = H P H^T + R; gain K = P H^T / S
        y = z - p
        S = Ppp + r
        Kp, Kv = Ppp / S, Ppv / S
        rows = running[:, None]
        self.p = np.where(rows, p + Kp * y, self.p)
        self.v = np.where(rows, self.v + Kv * y, self.v)
        # P = (I - K H) P
        self.Ppp = np.where(rows, (1 - Kp) * Ppp, self.Ppp)
        self.Ppv = np.where(rows, (1 - Kp) * Ppv, self.Ppv)
        self.Pvv = np.where(rows, Pvv - Kv * Ppv, self.Pvv)
        terms = -0.5 * (np.log(2 * np.pi * S) + y**2 / S)
        self.log_likelihood += np.where(running, terms.sum(axis=1), 0.0)

    def forecast(self, t_s: np.ndarray) -> Positions:
        position = self.p + self.v * (t_s - self.t_s)[:, None]
        ready = (self.count >= 2) & np.all(np.isfinite(position), axis=1)
        return Positions(position, ready)


def fit_constant_velocity(t: np.ndarray, z: np.ndarray, length: np.ndarray) -> tuple[float, float]:
    """(q, r) maximising the innovations' likelihood over every track of a file: a log-spaced
    grid over `Q_RANGE` x `R_RANGE`, narrowed `SEARCH_ROUNDS` times around its best pair, all
    pairs filtered in one batch.

    `t` (N, K) and `z` (N, K, 2) hold the tracks aligned by step index, NaN-padded after
    `length` (N,) samples."""
    log_q = np.log10(Q_RANGE)
    log_r = np.log10(R_RANGE)
    best = (0.0, 0.0)
    for _ in range(SEARCH_ROUNDS):
        qs = np.logspace(*log_q, GRID_POINTS)
        rs = np.logspace(*log_r, GRID_POINTS)
        qq, rr = (a.ravel() for a in np.meshgrid(qs, rs, indexing="ij"))
        total = _log_likelihood(t, z, length, qq, rr)
        i = int(np.argmax(total))
        best = (float(qq[i]), float(rr[i]))
        span_q = (log_q[1] - log_q[0]) / (GRID_POINTS - 1) * 2
        span_r = (log_r[1] - log_r[0]) / (GRID_POINTS - 1) * 2
        log_q = np.log10(best[0]) + np.array([-span_q, span_q])
        log_r = np.log10(best[1]) + np.array([-span_r, span_r])
    return best


def _log_likelihood(
    t: np.ndarray, z: np.ndarray, length: np.ndarray, q: np.ndarray, r: np.ndarray
) -> np.ndarray:
    """The summed log-likelihood of every (q, r) pair: tracks x pairs in one batch."""
    n, steps = t.shape
    pairs = len(q)
    filters = ConstantVelocity(n * pairs, np.repeat(q, n), np.repeat(r, n))
    for k in range(steps):
        present = np.tile(k < length, pairs)
        filters.step(np.tile(t[:, k], pairs), np.tile(np.nan_to_num(z[:, k]), (pairs, 1)), present)
    return filters.log_likelihood.reshape(pairs, n).sum(axis=1)
