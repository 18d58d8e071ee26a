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

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from gazed.estimation.masks import some

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


# How the bank is evaluated. The update equation of one state is written once (`_motion`) in
# arithmetic that floats and NumPy arrays share. A bank of at most SCALAR_MAX_STATES states
# (a single track's three models) runs it per state in Python floats: NumPy costs about
# 0.3-1 µs per call however small its operands, three to ten times Python's float arithmetic
# on three-element rows. A larger bank runs it once on flat (L,) rows of all its states, with
# the per-model constants tiled to the same length (cached per length). Either way the terms
# come out as one (24, L) array, scattered into x', ∇f and G by one assignment each.
SCALAR_MAX_STATES = 16
_PI = np.array(np.pi)
_TWO_PI = np.array(2.0 * np.pi)
_QUARTER_TURN = np.array([0.0, 0.5 * np.pi])  # (cos a, sin a) = cos(a - this)
_PERPENDICULAR = np.array([-1.0, 1.0])  # (p, q)[::-1] * this = (-q, p), a quarter turn
# Where `_motion`'s terms go. x' is terms 0-5. Terms 6-15 are entries of ∇f transposed (row j
# holds ∂(X, Y, ...)/∂x_j), 16-23 entries of G transposed (row 0 the speed noise's gains,
# row 1 the heading noise's), as flat indices into one state's 6x6 and 2x6.
_JACOBIAN_PAIRS = ((IS, IX), (IS, IY), (ITH, IX), (ITH, IY), (ISD, IX), (ISD, IY), (ITD, IX))
_JACOBIAN_PAIRS += ((ITD, IY), (ISD, IS), (ITD, ITH))
_JACOBIAN_ENTRIES = np.array([row * STATE_DIM + column for row, column in _JACOBIAN_PAIRS])
_GAIN_ENTRIES = np.array([IX, IY, IS, ISD, *(STATE_DIM + i for i in (IX, IY, ITH, ITD))])
# ∇h's constant part, transposed: ∂(X, Y)/∂(X, Y) = I (the velocity rows are set per state)
_HT_TEMPLATE = {m: np.eye(STATE_DIM, m) for m in (2, 4)}
_HT_TEMPLATE[4][2:, 2:] = 0.0
_SPEED_SIGN = np.array([1.0, 1.0, -1.0, 1.0, -1.0, 1.0])  # D of `canonicalise`
_SPEED_SIGN_FLIP = _SPEED_SIGN[:, None] * _SPEED_SIGN[None, :]
_CACHED_LENGTHS = 8


def _motion(
    X: Any, Y: Any, s: Any, th: Any, s_dot: Any, theta_dot: Any, T: Any, accel: Any, turns: Any
) -> tuple[Any, ...]:
    """The update equation of the module docstring, its Jacobian and its noise gains.

    Every argument is a float (one state; `accel` and `turns` 0.0 or 1.0, the model's
    switches) or every one an array of the same length (rows of states). Returns the 24
    terms of x' (X, Y, s, θ, ṡ, θ̇), ∇f (see _JACOBIAN_ENTRIES) and G (_GAIN_ENTRIES).
    """
    xp = math if isinstance(T, float) else np
    a = s_dot * accel  # the ṡ the model propagates (CD)
    w = theta_dot * turns  # the θ̇ it propagates (CS)
    u = w * T
    half_T2 = 0.5 * T * T
    d = s * T + a * half_T2  # distance along the path: sT + ṡT²/2
    A, B, A1, B1 = _a_b(u) if xp is math else _a_b_rows(u)
    cos_th, sin_th = xp.cos(th), xp.sin(th)
    # (A, B) and (A', B') rotated by θ: the displacement's direction per unit of d, and its
    # derivative by u
    e0x, e0y = cos_th * A - sin_th * B, sin_th * A + cos_th * B
    e1x, e1y = cos_th * A1 - sin_th * B1, sin_th * A1 + cos_th * B1
    heading = th + u
    heading = heading + 2.0 * math.pi * xp.floor((math.pi - heading) / (2.0 * math.pi))
    # Noise gains T^k/k! (§4.1.2, first order): a channel of order 0 (ṡ, θ̇) enters X, Y, its
    # state and its rate with T²/2, T, 1; one of order 1 (s̈ for CD, θ̈ for CS) with T³/6,
    # T²/2, T: those of order 0 times T/3, T/2, T.
    speed = _gains(accel, T, half_T2)
    turn = _gains(turns, T, half_T2)
    s_turn = s * turn[0]
    return (
        X + d * e0x,
        Y + d * e0y,
        s + a * T,
        heading,
        a,
        w,
        e0x * T,  # ∂(X, Y)/∂s
        e0y * T,
        -d * e0y,  # ∂(X, Y)/∂θ
        d * e0x,
        accel * half_T2 * e0x,  # ∂(X, Y)/∂ṡ (CD)
        accel * half_T2 * e0y,
        turns * d * T * e1x,  # ∂(X, Y)/∂θ̇ (CS)
        turns * d * T * e1y,
        accel * T,  # ∂s/∂ṡ (CD)
        turns * T,  # ∂θ/∂θ̇ (CS)
        cos_th * speed[0],  # X, Y of the speed noise: along θ
        sin_th * speed[0],
        speed[1],  # s
        speed[2],  # ṡ
        -sin_th * s_turn,  # X, Y of the heading noise: across θ, times s
        cos_th * s_turn,
        turn[1],  # θ
        turn[2],  # θ̇
    )


def _gains(order: Any, T: Any, half_T2: Any) -> tuple[Any, Any, Any]:
    """T^k/k! for k = (2, 1, 0) + order, order 0.0 or 1.0 (exact for both)."""
    other = 1.0 - order
    return (
        half_T2 * (other + order * T / 3.0),
        T * (other + order * 0.5 * T),
        other + order * T,
    )


@dataclass(frozen=True)
class _Tiled:
    """A bank's per-model constants repeated for K states of every model (L = K·M rows)."""

    accel: np.ndarray  # (L,) 1 where the model propagates ṡ (CD)
    turns: np.ndarray  # (L,) 1 where the model propagates θ̇ (CS)
    Ft: np.ndarray  # (L, 6, 6) ∇f's constant part, transposed
    q: np.ndarray  # (L, 1, 2) noise variances (speed, heading channel)


@dataclass(frozen=True)
class GroundModelBank:
    """Several ground models evaluated together on states of shape (..., M, 6).

    The Jacobian and the noise gain are built transposed (F = Ft.mT, G = Gt.mT, both views of
    contiguous arrays): a batched `@` is about three times faster on a transposed left operand
    than on a transposed right one, and F P Fᵀ = (Ft.mT @ P) @ Ft.
    """

    models: tuple[GroundModel, ...]

    def __post_init__(self) -> None:
        accel = np.array([float(m.accelerates) for m in self.models])
        turns = np.array([float(m.turns) for m in self.models])
        # ∇f's constant part (transposed): X, Y, s, θ carry over, the propagated rates too
        Ft = np.zeros((len(self.models), STATE_DIM, STATE_DIM))
        Ft[:, range(4), range(4)] = 1.0
        Ft[:, ISD, ISD], Ft[:, ITD, ITD] = accel, turns
        q = np.array([[m.q_speed, m.q_heading] for m in self.models])
        object.__setattr__(self, "_per_model", (accel, turns, Ft, q[:, None, :]))
        object.__setattr__(
            self, "_switches", list(zip(accel.tolist(), turns.tolist(), strict=True))
        )
        object.__setattr__(self, "_tiles", {})

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(m.name for m in self.models)

    def _tiled(self, K: int) -> _Tiled:
        tiles: dict[int, _Tiled] = self._tiles  # type: ignore[attr-defined]
        if K not in tiles:
            if len(tiles) >= _CACHED_LENGTHS:
                tiles.pop(next(iter(tiles)))
            accel, turns, Ft, q = self._per_model  # type: ignore[attr-defined]
            tiles[K] = _Tiled(
                np.tile(accel, K), np.tile(turns, K), np.tile(Ft, (K, 1, 1)), np.tile(q, (K, 1, 1))
            )
        return tiles[K]

    def propagate(self, x: np.ndarray, dt: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """f(x), its Jacobian ∇f and Q over an interval dt.

        x: (..., M, 6); dt: (...) seconds, >= 0, one per state of the M models.
        Returns x' (..., M, 6), F (..., M, 6, 6) (a transposed view), Q (..., M, 6, 6).
        """
        dt = np.asarray(dt, dtype=float)
        shape = x.shape
        if dt.shape != shape[:-2]:
            raise ValueError(f"dt has shape {dt.shape} for states of shape {shape}")
        c = self._tiled(dt.size)
        M = shape[-2]
        L = dt.size * M
        if L <= SCALAR_MAX_STATES:
            switches = self._switches  # type: ignore[attr-defined]
            states = x.reshape(L, STATE_DIM).tolist()
            terms = np.array(
                [
                    _motion(*state, T, *switches[i % M])
                    for i, (state, T) in enumerate(
                        zip(states, dt.ravel().repeat(M).tolist(), strict=True)
                    )
                ]
            ).T
        else:
            T = dt.ravel().repeat(M)
            terms = np.array(_motion(*x.reshape(L, STATE_DIM).T, T, c.accel, c.turns))
        Ft = c.Ft.copy()  # row j: ∂(X, Y, ...)/∂x_j
        Ft.reshape(L, STATE_DIM * STATE_DIM)[:, _JACOBIAN_ENTRIES] = terms[6:16].T
        Gt = np.zeros((L, 2, STATE_DIM))
        Gt.reshape(L, 2 * STATE_DIM)[:, _GAIN_ENTRIES] = terms[16:].T
        Q = (Gt.mT * c.q) @ Gt  # G diag(q) Gᵀ
        square = (*shape, STATE_DIM)
        return terms[:6].T.reshape(shape), Ft.mT.reshape(square), Q.reshape(square)


def _a_b(u: float) -> tuple[float, float, float, float]:
    """A = sin u / u, B = (1 - cos u)/u and their derivatives A' = (cos u - A)/u,
    B' = (sin u - B)/u of one u, by their series below |u| = SERIES_LIMIT."""
    if abs(u) < SERIES_LIMIT:
        return _a_b_series(u)
    return _a_b_closed(u, math.sin(u), math.cos(u))


def _a_b_rows(u: np.ndarray) -> np.ndarray:
    """`_a_b` of every element of u (L,): rows A, B, A', B' (4, L)."""
    small = np.abs(u) < SERIES_LIMIT
    us = np.where(small, 1.0, u)  # those closed-form values are discarded
    ab = np.array(_a_b_closed(us, np.sin(us), np.cos(us)))
    if np.count_nonzero(small):
        ab[:, small] = _a_b_series(u[small])
    return ab


def _a_b_closed(u: Any, sin_u: Any, cos_u: Any) -> tuple[Any, Any, Any, Any]:
    A, B = sin_u / u, (1.0 - cos_u) / u
    return A, B, (cos_u - A) / u, (sin_u - B) / u


def _a_b_series(u: Any) -> tuple[Any, Any, Any, Any]:
    """A = 1 - u²/6, B = u/2 - u³/24, A' = -u/3 + u³/30, B' = 1/2 - u²/8 (the next terms are
    below 1e-14 for |u| < SERIES_LIMIT)."""
    u2 = u * u
    return 1.0 - u2 / 6.0, u * (0.5 - u2 / 24.0), u * (u2 / 30.0 - 1.0 / 3.0), 0.5 - u2 / 8.0


def cos_sin(angle: np.ndarray) -> np.ndarray:
    """(cos a, sin a) stacked on a new last axis: (...) -> (..., 2)."""
    return np.cos(angle[..., None] - _QUARTER_TURN)


def wrap_angle(angle: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """Wrap to (-π, π]: a + 2π ⌊(π - a) / 2π⌋ (a floor is several times cheaper than np.mod
    on long arrays; the division keeps -π -> π exact)."""
    turns = np.floor(np.divide(np.subtract(_PI, angle), _TWO_PI))
    return np.add(angle, turns * _TWO_PI, out=out)


def measure(x: np.ndarray, with_velocity: bool) -> tuple[np.ndarray, np.ndarray]:
    """h(x) = (X, Y, s cos θ, s sin θ) (errata of §4.1.1) or (X, Y), and its Jacobian ∇h.

    x: (..., 6). Returns h (..., m) and H (..., m, 6) (a transposed view), m = 4 or 2.
    """
    m = 4 if with_velocity else 2
    Ht = np.empty((*x.shape[:-1], STATE_DIM, m))
    Ht[...] = _HT_TEMPLATE[m]
    if not with_velocity:
        return x[..., :2].copy(), Ht.mT
    heading = cos_sin(x[..., ITH])  # (cos θ, sin θ)
    h = np.empty((*x.shape[:-1], 4))
    h[..., :2] = x[..., :2]
    np.multiply(x[..., IS, None], heading, out=h[..., 2:])
    Ht[..., IS, 2:] = heading  # ∂(Ẋ, Ẏ)/∂s
    np.multiply(h[..., :1:-1], _PERPENDICULAR, out=Ht[..., ITH, 2:])  # ∂(Ẋ, Ẏ)/∂θ = (-Ẏ, Ẋ)
    return h, Ht.mT


def canonicalise(x: np.ndarray, P: np.ndarray) -> bool:
    """In place: a negative speed becomes a positive one with the heading turned by π.

    (s, θ, ṡ) -> (-s, θ + π, -ṡ) describes the same motion; P becomes D P D, D = diag(1, 1, -1, 1, -1, 1).
    Returns whether any state changed.
    """
    neg = x[..., IS] < 0
    if not some(neg):
        return False
    x[neg, IS] *= -1.0
    x[neg, ISD] *= -1.0
    x[neg, ITH] = wrap_angle(x[neg, ITH] + np.pi)
    P[neg] *= _SPEED_SIGN_FLIP
    return True
