"""Ground-plane motion models CSD, CS and CD of seed 000 §4.1 (with the DESIGN §10 errata).

State x = [X, Y, s, θ, ṡ, θ̇]: position (m), speed (m/s), heading (rad, from +X towards +Y,
wrapped to (-π, π]), speed rate (m/s²), turn rate (rad/s). Measurement z = [X, Y, Ẋ, Ẏ] with
h(x) = (X, Y, s cos θ, s sin θ) (errata: the text prints sin for both), or [X, Y] alone.

The three models are one update equation with two switches, `turns` and `accelerates`:

- CSD (§4.1.2): X + s cos θ T, Y + s sin θ T, s, θ; ṡ and θ̇ are not modelled.
- CS  (§4.1.3): X + (s/ω)[sin(θ+ωT) - sin θ], Y + (s/ω)[cos θ - cos(θ+ωT)], θ + ωT, ω = θ̇.
- CD  (§4.1.4): X + cos θ (sT + ṡT²/2), Y + sin θ (sT + ṡT²/2), s + ṡT.

Written with d = sT + ṡT²/2 (CD) or sT, and u = ωT (CS) or 0:
X' = X + d (cos θ A(u) - sin θ B(u)),  Y' = Y + d (sin θ A(u) + cos θ B(u)),
A(u) = sin(u)/u, B(u) = (1 - cos u)/u, with their series near u = 0 (the ω -> 0 limit).

A rate the model does not estimate (ṡ for CSD and CS, θ̇ for CSD and CD) is, as §4.1.2 says,
"strictly a noise term drawn from a zero-mean sequence": its prediction is 0 and its variance
comes from Q. Process noise (§4.1.2): two noise inputs held constant over T, one on the speed
channel (ṡ, or s̈ for CD) and one on the heading channel (θ̇, or θ̈ for CS), entering to first
order through e = G [e_speed, e_heading]ᵀ, so Q = G diag(q_speed, q_heading) Gᵀ.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

STATE_DIM = 6
IX, IY, IS, ITH, ISD, ITD = range(STATE_DIM)
HEADING_INDEX = ITH

# Below this |u| = |ωT| the series of A, B and their derivatives replace the closed forms.
SERIES_LIMIT = 1e-3


@dataclass(frozen=True)
class GroundModel:
    """One of CSD / CS / CD: which rates it propagates and its process-noise variances.

    q_speed: variance of the speed-channel noise, (m/s²)² when it is ṡ, (m/s³)² when it is s̈ (CD).
    q_heading: variance of the heading-channel noise, (rad/s)² when it is θ̇, (rad/s²)² when θ̈ (CS).
    """

    name: str
    turns: bool
    accelerates: bool
    q_speed: float
    q_heading: float


def csd(q_speed_m2_s4: float, q_turn_rate_rad2_s2: float) -> GroundModel:
    """Constant speed and direction (§4.1.2); noise on ṡ and θ̇."""
    return GroundModel("CSD", False, False, q_speed_m2_s4, q_turn_rate_rad2_s2)


def cs(q_speed_m2_s4: float, q_turn_accel_rad2_s4: float) -> GroundModel:
    """Constant speed, turning (§4.1.3); noise on ṡ and θ̈."""
    return GroundModel("CS", True, False, q_speed_m2_s4, q_turn_accel_rad2_s4)


def cd(q_jerk_m2_s6: float, q_turn_rate_rad2_s2: float) -> GroundModel:
    """Constant direction, accelerating (§4.1.4); noise on s̈ and θ̇."""
    return GroundModel("CD", False, True, q_jerk_m2_s6, q_turn_rate_rad2_s2)


@dataclass(frozen=True)
class GroundModelBank:
    """Several ground models evaluated together on states of shape (..., M, 6)."""

    models: tuple[GroundModel, ...]

    def __post_init__(self) -> None:
        turns = np.array([float(m.turns) for m in self.models])
        accel = np.array([float(m.accelerates) for m in self.models])
        # ∇f's diagonal: X, Y, s, θ carry over; ṡ only in CD, θ̇ only in CS
        F_diagonal = np.ones((len(self.models), STATE_DIM))
        F_diagonal[:, ISD] = accel
        F_diagonal[:, ITD] = turns
        # noise gains as polynomials in T (columns: 1, T, T², T³) for the entries
        # [X|Y per cos/sin, s, ṡ] of the speed channel and [X|Y per s·sin/cos, θ, θ̇] of the
        # heading channel: order 0 -> (T²/2, T, 1), order 1 -> (T³/6, T²/2, T)
        G_poly = np.zeros((len(self.models), 4, 6))
        for m, (order_s, order_h) in enumerate(zip(accel, turns, strict=True)):
            for channel, order in ((0, int(order_s)), (3, int(order_h))):
                G_poly[m, 2 + order, channel] = 1.0 / (2.0 + 4.0 * order)
                G_poly[m, 1 + order, channel + 1] = 1.0 / (1.0 + order)
                G_poly[m, order, channel + 2] = 1.0
        q = np.array([[m.q_speed, m.q_heading] for m in self.models])
        object.__setattr__(self, "_turns", turns)
        object.__setattr__(self, "_accel", accel)
        object.__setattr__(self, "_F_diagonal", F_diagonal)
        object.__setattr__(self, "_G_poly", G_poly)
        object.__setattr__(self, "_q", q)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(m.name for m in self.models)

    def _tiled(self, K: int) -> tuple[np.ndarray, ...]:
        """The per-model constants repeated for K states of every model (cached per K)."""
        cache = self.__dict__.setdefault("_tiles", {})
        if K not in cache:
            cache[K] = (
                np.tile(self._turns, K),
                np.tile(self._accel, K),
                np.tile(self._F_diagonal, (K, 1)),
                np.tile(self._G_poly, (K, 1, 1)),
                np.tile(self._q, (K, 1)),
            )
        return cache[K]

    def propagate(self, x: np.ndarray, dt: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """f(x), its Jacobian ∇f and Q over an interval dt.

        x: (..., M, 6); dt: (...) seconds, >= 0, one per state of the M models.
        Returns x' (..., M, 6), F (..., M, 6, 6), Q (..., M, 6, 6).
        """
        M = len(self.models)
        shape = x.shape
        K = x.size // (M * STATE_DIM)
        # flat (K·M,) arrays: basic indexing on them is several times cheaper than on (..., M)
        T = np.repeat(np.asarray(dt, dtype=float).ravel(), M)
        if T.size != K * M:
            raise ValueError(f"dt has {T.size // M} intervals for {K} states")
        turns, accel, F_diagonal, G_poly, q = self._tiled(K)
        x = x.reshape(-1, STATE_DIM)
        s, th = x[:, IS], x[:, ITH]
        a = accel * x[:, ISD]  # the ṡ the model propagates (CD), else 0
        w = turns * x[:, ITD]  # the θ̇ the model propagates (CS), else 0
        T2 = T * T
        d = s * T + a * T2 / 2.0
        A, B, dA, dB = _a_b(w * T)
        c, sn = np.cos(th), np.sin(th)
        ex = c * A - sn * B  # displacement direction per unit of d
        ey = sn * A + c * B

        xn = np.empty_like(x)
        xn[:, IX] = x[:, IX] + d * ex
        xn[:, IY] = x[:, IY] + d * ey
        xn[:, IS] = s + a * T
        xn[:, ITH] = wrap_angle(th + w * T)
        xn[:, ISD] = a
        xn[:, ITD] = w

        F = np.zeros((K * M, STATE_DIM * STATE_DIM))
        F[:, ::7] = F_diagonal  # the diagonal
        F = F.reshape(K * M, STATE_DIM, STATE_DIM)
        F[:, IX, IS] = T * ex  # ∂X/∂s
        F[:, IY, IS] = T * ey
        F[:, IX, ITH] = -d * ey  # ∂X/∂θ
        F[:, IY, ITH] = d * ex
        half_T2 = accel * T2 / 2.0  # CD only
        F[:, IX, ISD] = half_T2 * ex  # ∂X/∂ṡ
        F[:, IY, ISD] = half_T2 * ey
        dT = turns * d * T  # CS only
        F[:, IX, ITD] = dT * (c * dA - sn * dB)  # ∂X/∂θ̇
        F[:, IY, ITD] = dT * (sn * dA + c * dB)
        F[:, IS, ISD] = accel * T  # ∂s/∂ṡ
        F[:, ITH, ITD] = turns * T  # ∂θ/∂θ̇

        # Noise gains (§4.1.2, first order): the speed channel enters at ṡ (order 0) or at s̈
        # (CD, order 1), the heading channel at θ̇ (order 0) or at θ̈ (CS, order 1); _G_poly
        # holds per model the coefficients of 1, T, T², T³ of the gains
        # [X,Y of the speed noise, s, ṡ, X,Y of the heading noise, θ, θ̇].
        powers = np.empty((K * M, 1, 4))
        powers[:, 0, 0] = 1.0
        powers[:, 0, 1] = T
        powers[:, 0, 2] = T2
        powers[:, 0, 3] = T2 * T
        g = (powers @ G_poly)[:, 0, :]
        G = np.zeros((K * M, STATE_DIM, 2))
        G[:, IX, 0] = c * g[:, 0]
        G[:, IY, 0] = sn * g[:, 0]
        G[:, IS, 0] = g[:, 1]
        G[:, ISD, 0] = g[:, 2]
        G[:, IX, 1] = -sn * s * g[:, 3]
        G[:, IY, 1] = c * s * g[:, 3]
        G[:, ITH, 1] = g[:, 4]
        G[:, ITD, 1] = g[:, 5]
        Q = (G * q[:, None, :]) @ G.mT
        square = (*shape, STATE_DIM)
        return xn.reshape(shape), F.reshape(square), Q.reshape(square)


def _a_b(u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A = sin u / u, B = (1 - cos u)/u and their derivatives A', B' (series near u = 0)."""
    small = np.abs(u) < SERIES_LIMIT
    us = u + small  # nonzero where the series is used; those closed-form values are discarded
    sin_u, cos_u = np.sin(us), np.cos(us)
    inv = 1.0 / us
    u2 = u * u
    closed = np.empty((4, *u.shape))
    series = np.empty((4, *u.shape))
    closed[0] = A = sin_u * inv
    closed[1] = B = (1.0 - cos_u) * inv
    closed[2] = (cos_u - A) * inv
    closed[3] = (sin_u - B) * inv
    series[0] = 1.0 - u2 / 6.0
    series[1] = u * (0.5 - u2 / 24.0)
    series[2] = u * (u2 / 30.0 - 1.0 / 3.0)
    series[3] = 0.5 - u2 / 8.0
    A, B, dA, dB = np.where(small, series, closed)
    return A, B, dA, dB


def wrap_angle(angle: np.ndarray) -> np.ndarray:
    """Wrap to (-π, π]."""
    return np.pi - np.mod(np.pi - angle, 2.0 * np.pi)


def measure(x: np.ndarray, with_velocity: bool) -> tuple[np.ndarray, np.ndarray]:
    """h(x) = (X, Y, s cos θ, s sin θ) (errata of §4.1.1) or (X, Y), and its Jacobian ∇h.

    x: (..., 6). Returns h (..., m) and H (..., m, 6), m = 4 or 2.
    """
    m = 4 if with_velocity else 2
    h = np.empty((*x.shape[:-1], m))
    H = np.zeros((*x.shape[:-1], m, STATE_DIM))
    h[..., 0] = x[..., IX]
    h[..., 1] = x[..., IY]
    H[..., 0, IX] = 1.0
    H[..., 1, IY] = 1.0
    if with_velocity:
        s, c, sn = x[..., IS], np.cos(x[..., ITH]), np.sin(x[..., ITH])
        h[..., 2] = s * c
        h[..., 3] = s * sn
        H[..., 2, IS] = c
        H[..., 2, ITH] = -s * sn
        H[..., 3, IS] = sn
        H[..., 3, ITH] = s * c
    return h, H


def canonicalise(x: np.ndarray, P: np.ndarray) -> None:
    """In place: a negative speed becomes a positive one with the heading turned by π.

    (s, θ, ṡ) -> (-s, θ + π, -ṡ) describes the same motion; P becomes D P D, D = diag(1, 1, -1, 1, -1, 1).
    """
    neg = x[..., IS] < 0
    if not np.any(neg):
        return
    x[neg, IS] *= -1.0
    x[neg, ISD] *= -1.0
    x[neg, ITH] = wrap_angle(x[neg, ITH] + np.pi)
    sign = np.ones(STATE_DIM)
    sign[[IS, ISD]] = -1.0
    P[neg] *= sign[:, None] * sign[None, :]
