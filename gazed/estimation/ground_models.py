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


# Per-call costs on a single track's few states are dominated by NumPy's dispatch, which is
# cheapest for operands of one shape; so the bank works on flat (K·M,) rows with its per-model
# constants tiled to the same length (cached per length), and avoids Python-float operands.
_PI = np.array(np.pi)
_TWO_PI = np.array(2.0 * np.pi)
_HALF = np.array(0.5)
_THIRD = np.array(1.0 / 3.0)
_POWERS = np.arange(4.0)
_QUARTER_TURN = np.array([0.0, 0.5 * np.pi])  # (cos a, sin a) = cos(a - this)
_PERPENDICULAR = np.array([-1.0, 1.0])  # (p, q)[::-1] * this = (-q, p), a quarter turn
# Series of [[A, A'], [B, B']] (see `_a_b`) in powers u⁰..u³, as rows of the flattened 2x2:
# A = 1 - u²/6, A' = -u/3 + u³/30, B = u/2 - u³/24, B' = 1/2 - u²/8
_A_B_SERIES = np.array(
    [
        [1.0, 0.0, 0.0, 0.5],
        [0.0, -1.0 / 3.0, 0.5, 0.0],
        [-1.0 / 6.0, 0.0, 0.0, -1.0 / 8.0],
        [0.0, 1.0 / 30.0, -1.0 / 24.0, 0.0],
    ]
)
# ∇h's constant part, transposed: ∂(X, Y)/∂(X, Y) = I (the velocity rows are set per state)
_HT_TEMPLATE = {m: np.eye(STATE_DIM, m) for m in (2, 4)}
_HT_TEMPLATE[4][2:, 2:] = 0.0
_SPEED_SIGN = np.array([1.0, 1.0, -1.0, 1.0, -1.0, 1.0])  # D of `canonicalise`
_SPEED_SIGN_FLIP = _SPEED_SIGN[:, None] * _SPEED_SIGN[None, :]
_CACHED_LENGTHS = 8
# [[A, A'], [B, B']] at u = 0 (a model that does not turn)
_A_B_STRAIGHT = np.array([[1.0, 0.0], [0.0, 0.5]])


@dataclass(frozen=True)
class _Tiled:
    """A bank's per-model constants repeated for K states of every model (L = K·M rows)."""

    accel: np.ndarray  # (L,) 1 where the model propagates ṡ (CD)
    turns: np.ndarray  # (L,) 1 where the model propagates θ̇ (CS)
    turning: np.ndarray  # (L_turn,) the rows of turning models
    a_b: np.ndarray  # (L, 2, 2) `_a_b` of a straight path
    Ft: np.ndarray  # (L, 6, 6) ∇f's constant part, transposed
    gain_index: np.ndarray  # (L, 6) flat indices into the (L, 4) powers T^k/k!
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
        # Noise gains (§4.1.2, first order) are T^k/k! for k = 0..3: the speed channel enters
        # at ṡ (order 0) or at s̈ (CD, order 1), the heading channel at θ̇ (order 0) or at θ̈
        # (CS, order 1). Per model, the power k of each gain
        # [X,Y of the speed noise, s, ṡ, X,Y of the heading noise, θ, θ̇]:
        # order 0 -> (2, 1, 0), order 1 -> (3, 2, 1).
        gain_power = np.array(
            [[2 + a, 1 + a, a, 2 + t, 1 + t, t] for a, t in zip(accel, turns, strict=True)],
            dtype=np.intp,
        )
        q = np.array([[m.q_speed, m.q_heading] for m in self.models])
        object.__setattr__(self, "_per_model", (accel, turns, Ft, gain_power, q[:, None, :]))
        object.__setattr__(self, "_tiles", {})

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(m.name for m in self.models)

    def _tiled(self, K: int) -> _Tiled:
        tiles: dict[int, _Tiled] = self._tiles  # type: ignore[attr-defined]
        if K not in tiles:
            if len(tiles) >= _CACHED_LENGTHS:
                tiles.pop(next(iter(tiles)))
            accel, turns, Ft, gain_power, q = self._per_model  # type: ignore[attr-defined]
            L = K * len(self.models)
            tiles[K] = _Tiled(
                np.tile(accel, K),
                np.tile(turns, K),
                np.flatnonzero(np.tile(turns, K)),
                np.tile(_A_B_STRAIGHT, (L, 1, 1)),
                np.tile(Ft, (K, 1, 1)),
                np.tile(gain_power, (K, 1)) + 4 * np.arange(L)[:, None],
                np.tile(q, (K, 1, 1)),
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
        T = np.repeat(dt.ravel(), shape[-2])  # (L,) one interval per state
        x = x.reshape(-1, STATE_DIM)
        _, _, s, th, s_dot, theta_dot = x.T
        L = len(T)

        xn = np.empty((L, STATE_DIM))
        a = np.multiply(s_dot, c.accel, out=xn[:, ISD])  # the ṡ the model propagates (CD)
        w = np.multiply(theta_dot, c.turns, out=xn[:, ITD])  # the θ̇ it propagates (CS)
        powers = np.empty((L, 4))  # T^k / k!
        powers[:, 0] = 1.0
        powers[:, 1] = T
        half_T2 = np.multiply(np.multiply(T, T, out=powers[:, 2]), _HALF, out=powers[:, 2])
        np.multiply(np.multiply(half_T2, T, out=powers[:, 3]), _THIRD, out=powers[:, 3])
        d = s * T + a * half_T2  # distance along the path: sT + ṡT²/2
        u = w * T
        R = np.empty((L, 2, 2))  # rotation by θ
        np.cos(th, out=R[:, 0, 0])
        np.sin(th, out=R[:, 1, 0])
        R[:, 1, 1] = R[:, 0, 0]
        np.negative(R[:, 1, 0], out=R[:, 0, 1])
        ab = c.a_b.copy()
        if len(c.turning):
            ab[c.turning] = _a_b(u[c.turning])
        e = R @ ab  # [[ex, ex'], [ey, ey']]: (A, B) and (A', B') rotated by θ
        e0 = e[:, :, 0]  # direction of the displacement per unit of d

        np.add(x[:, :2], d[:, None] * e0, out=xn[:, :2])  # X + d ex, Y + d ey
        np.add(s, a * T, out=xn[:, IS])  # s + ṡT
        wrap_angle(np.add(th, u, out=xn[:, ITH]), out=xn[:, ITH])  # θ + θ̇T, wrapped

        Ft = c.Ft.copy()  # row j: ∂(X, Y, ...)/∂x_j
        np.multiply(e0, T[:, None], out=Ft[:, IS, :2])
        np.multiply(e0[:, ::-1] * _PERPENDICULAR, d[:, None], out=Ft[:, ITH, :2])
        np.multiply(e0, (c.accel * half_T2)[:, None], out=Ft[:, ISD, :2])  # CD
        np.multiply(e[:, :, 1], (c.turns * d * T)[:, None], out=Ft[:, ITD, :2])  # CS
        np.multiply(c.accel, T, out=Ft[:, ISD, IS])  # ∂s/∂ṡ (CD)
        np.multiply(c.turns, T, out=Ft[:, ITD, ITH])  # ∂θ/∂θ̇ (CS)

        # e = G [e_speed, e_heading]ᵀ with the gains T^k/k! of `gain_power`; Q = G diag(q) Gᵀ
        g = powers.take(c.gain_index)  # (L, 6)
        Gt = np.zeros((L, 2, STATE_DIM))
        np.multiply(R[:, :, 0], g[:, :1], out=Gt[:, 0, :2])  # X, Y of the speed noise: along θ
        np.multiply(R[:, :, 1], (s * g[:, 3])[:, None], out=Gt[:, 1, :2])  # heading noise: across
        Gt[:, 0, IS::2] = g[:, 1:3]  # s, ṡ
        Gt[:, 1, ITH::2] = g[:, 4:]  # θ, θ̇
        Q = (Gt.mT * c.q) @ Gt
        square = (*shape, STATE_DIM)
        return xn.reshape(shape), Ft.mT.reshape(square), Q.reshape(square)


def _a_b(u: np.ndarray) -> np.ndarray:
    """[[A, A'], [B, B']] (L, 2, 2) of A = sin u / u, B = (1 - cos u)/u and their
    derivatives A' = (cos u - A)/u, B' = (sin u - B)/u, by their series below |u| =
    SERIES_LIMIT."""
    small = np.abs(u) < SERIES_LIMIT
    us = np.where(small, 1.0, u)  # those closed-form values are discarded
    sin_u, cos_u = np.sin(us), np.cos(us)
    inv = 1.0 / us
    ab = np.empty((len(u), 2, 2))
    A = np.multiply(sin_u, inv, out=ab[:, 0, 0])
    B = np.multiply(1.0 - cos_u, inv, out=ab[:, 1, 0])
    np.multiply(cos_u - A, inv, out=ab[:, 0, 1])
    np.multiply(sin_u - B, inv, out=ab[:, 1, 1])
    if small.any():
        series = (u[:, None] ** _POWERS @ _A_B_SERIES).reshape(-1, 2, 2)
        np.copyto(ab, series, where=small[:, None, None])
    return ab


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
    if not neg.any():
        return False
    x[neg, IS] *= -1.0
    x[neg, ISD] *= -1.0
    x[neg, ITH] = wrap_angle(x[neg, ITH] + np.pi)
    P[neg] *= _SPEED_SIGN_FLIP
    return True
