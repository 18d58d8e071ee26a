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


# Plane vectors are handled as complex numbers where that saves work: (p, q) <-> p + iq, so a
# rotation by θ is a product with e^{iθ} = cos θ + i sin θ and a quarter turn a product with i.

_QUARTER_TURN = np.array([0.0, 0.5 * np.pi])  # (cos a, sin a) = cos(a - [0, π/2])
_POWERS = np.arange(4.0)
_FACTORIALS = np.array([1.0, 1.0, 2.0, 6.0])
# Series of A + iB and A' + iB' in powers u⁰..u³ (see `_a_b`):
# A = 1 - u²/6, B = u/2 - u³/24, A' = -u/3 + u³/30, B' = 1/2 - u²/8
_A_B_SERIES = np.array(
    [[1.0, 0.5j], [0.5j, -1.0 / 3.0], [-1.0 / 6.0, -0.125j], [-1.0j / 24.0, 1.0 / 30.0]]
)
# ∇h's constant part, transposed: ∂(X, Y)/∂(X, Y) = I (the velocity rows are set per state)
_HT_TEMPLATE = {m: np.eye(STATE_DIM, m) for m in (2, 4)}
_HT_TEMPLATE[4][2:, 2:] = 0.0
_SPEED_SIGN = np.array([1.0, 1.0, -1.0, 1.0, -1.0, 1.0])  # D of `canonicalise`
_SPEED_SIGN_FLIP = _SPEED_SIGN[:, None] * _SPEED_SIGN[None, :]


def cos_sin(angle: np.ndarray) -> np.ndarray:
    """(cos a, sin a) stacked on a new last axis: (...) -> (..., 2); `.view(complex)` of it
    is e^{ia} (..., 1)."""
    return np.cos(angle[..., None] - _QUARTER_TURN)


@dataclass(frozen=True)
class GroundModelBank:
    """Several ground models evaluated together on states of shape (..., M, 6).

    The Jacobian and the noise gain are built transposed (F = Ft.mT, G = Gt.mT, both views of
    contiguous arrays): a batched `@` is about three times faster on a transposed left operand
    than on a transposed right one, and F P Fᵀ = (Ft.mT @ P) @ Ft.
    """

    models: tuple[GroundModel, ...]

    def __post_init__(self) -> None:
        M = len(self.models)
        accel = np.array([float(m.accelerates) for m in self.models])
        turns = np.array([float(m.turns) for m in self.models])
        # the rates each model propagates: ṡ only in CD, θ̇ only in CS (the others predict 0)
        carry = np.ones((M, 4))  # on [s, θ, ṡ, θ̇]
        carry[:, 2], carry[:, 3] = accel, turns
        # ∇f's constant part (transposed): X, Y, s, θ carry over, the propagated rates too
        Ft_template = np.zeros((M, STATE_DIM, STATE_DIM))
        Ft_template[:, range(4), range(4)] = 1.0
        Ft_template[:, ISD, ISD], Ft_template[:, ITD, ITD] = accel, turns
        # Noise gains (§4.1.2, first order) are T^k/k! for k = 0..3: the speed channel enters
        # at ṡ (order 0) or at s̈ (CD, order 1), the heading channel at θ̇ (order 0) or at θ̈
        # (CS, order 1). Per model, the power k of each gain
        # [X,Y of the speed noise, s, ṡ, X,Y of the heading noise, θ, θ̇]:
        # order 0 -> (2, 1, 0), order 1 -> (3, 2, 1); as a 0/1 matrix from [T^k/k!]_k.
        gain_select = np.zeros((4, M, 6))
        for m, (a, t) in enumerate(zip(accel.astype(int), turns.astype(int), strict=True)):
            gain_select[[2 + a, 1 + a, a, 2 + t, 1 + t, t], m, range(6)] = 1.0
        q = np.array([[m.q_speed, m.q_heading] for m in self.models])
        object.__setattr__(self, "_carry", carry)
        object.__setattr__(self, "_rates", carry[:, 2:])
        object.__setattr__(self, "_turns", turns)
        object.__setattr__(self, "_Ft_template", Ft_template)
        object.__setattr__(self, "_gain_select", gain_select.reshape(4, M * 6))
        object.__setattr__(self, "_q", q[:, None, :])

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(m.name for m in self.models)

    def propagate(self, x: np.ndarray, dt: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """f(x), its Jacobian ∇f and Q over an interval dt.

        x: (..., M, 6); dt: (...) seconds, >= 0, one per state of the M models.
        Returns x' (..., M, 6), F (..., M, 6, 6) (a transposed view), Q (..., M, 6, 6).
        """
        T = np.asarray(dt, dtype=float)
        shape = x.shape
        if T.shape != shape[:-2]:
            raise ValueError(f"dt has shape {T.shape} for states of shape {shape}")
        M = shape[-2]
        x = x.reshape(-1, M, STATE_DIM)
        K = len(x)
        T = T.reshape(K, 1)  # over the M models
        q = x[..., IS:] * self._carry  # s, θ, and the (ṡ, θ̇) each model propagates, else 0
        s, rates = q[..., 0], q[..., 2:]
        powers = T[..., None] ** _POWERS / _FACTORIALS  # (K, 1, 4): T^k / k!
        d = s * T + rates[..., 0] * powers[..., 2]  # distance along the path: sT + ṡT²/2
        turn_T = self._turns * T
        ab = _a_b(rates[..., 1] * T)  # A + iB, A' + iB' (K, M, 2)
        heading = cos_sin(x[..., ITH])
        e_heading = heading.view(complex)[..., 0]  # e^{iθ}
        e = ab * e_heading[..., None]  # rotated by θ: (ex + i ey), the same of A', B'
        step = d * e[..., 0]  # (ΔX + iΔY)

        xn = np.empty((K, M, STATE_DIM))
        np.add(x[..., :2], step[..., None].view(float), out=xn[..., :2])
        np.add(q[..., :2], rates * T[..., None], out=xn[..., IS:ISD])  # s + ṡT, θ + θ̇T
        xn[..., ITH] = wrap_angle(xn[..., ITH])
        xn[..., ISD:] = rates

        Ft = np.empty((K, M, STATE_DIM, STATE_DIM))
        Ft[...] = self._Ft_template
        dxy = Ft.view(complex)[..., 0]  # row j of Ft: ∂(X + iY)/∂x_j
        np.multiply(e[..., 0], T, out=dxy[..., IS])  # ∂/∂s
        np.multiply(step, 1j, out=dxy[..., ITH])  # ∂/∂θ
        np.multiply(e[..., 0], self._rates[:, 0] * powers[..., 2], out=dxy[..., ISD])  # ∂/∂ṡ (CD)
        np.multiply(e[..., 1], d * turn_T, out=dxy[..., ITD])  # ∂/∂θ̇ (CS)
        Ft.reshape(K, M, STATE_DIM * STATE_DIM)[..., ISD * 6 + IS :: 7] = (
            self._rates * T[..., None]
        )  # ∂s/∂ṡ = T (CD), ∂θ/∂θ̇ = T (CS)

        # e = G [e_speed, e_heading]ᵀ with the gains T^k/k! of `gain_select`; Q = G diag(q) Gᵀ
        g = (powers[:, 0] @ self._gain_select).reshape(K, M, 6)
        Gt = np.zeros((K, M, 2, STATE_DIM))
        gxy = Gt.view(complex)[..., 0]  # ∂(X + iY)/∂(e_speed, e_heading)
        np.multiply(e_heading, g[..., 0], out=gxy[..., 0])  # along θ
        np.multiply(e_heading, 1j * s * g[..., 3], out=gxy[..., 1])  # across θ
        Gt[..., 0, IS::2] = g[..., 1:3]  # s, ṡ
        Gt[..., 1, ITH::2] = g[..., 4:]  # θ, θ̇
        Q = (Gt.mT * self._q) @ Gt
        return xn.reshape(shape), Ft.mT.reshape(*shape, STATE_DIM), Q.reshape(*shape, STATE_DIM)


def _a_b(u: np.ndarray) -> np.ndarray:
    """A + iB and A' + iB' (..., 2) of A = sin u / u, B = (1 - cos u)/u and their
    derivatives: A + iB = i(1 - e^{iu})/u, A' + iB' = (e^{iu} - (A + iB))/u, by their series
    below |u| = SERIES_LIMIT."""
    small = np.abs(u) < SERIES_LIMIT
    us = u + small  # nonzero where the series is used; those closed-form values are discarded
    e_iu = cos_sin(us).view(complex)[..., 0]
    ab = np.empty((*u.shape, 2), dtype=complex)
    np.multiply(1.0 - e_iu, 1j / us, out=ab[..., 0])
    np.divide(e_iu - ab[..., 0], us, out=ab[..., 1])
    np.copyto(ab, (u[..., None] ** _POWERS) @ _A_B_SERIES, where=small[..., None])
    return ab


def wrap_angle(angle: np.ndarray) -> np.ndarray:
    """Wrap to (-π, π]."""
    return np.pi - np.mod(np.pi - angle, 2.0 * np.pi)


def measure(x: np.ndarray, with_velocity: bool) -> tuple[np.ndarray, np.ndarray]:
    """h(x) = (X, Y, s cos θ, s sin θ) (errata of §4.1.1) or (X, Y), and its Jacobian ∇h.

    x: (..., 6). Returns h (..., m) and H (..., m, 6) (a transposed view), m = 4 or 2.
    """
    m = 4 if with_velocity else 2
    Ht = np.empty((*x.shape[:-1], STATE_DIM, m))
    Ht[...] = _HT_TEMPLATE[m]
    if not with_velocity:
        return x[..., :2].copy(), Ht.mT
    heading = cos_sin(x[..., ITH])
    h = np.empty((*x.shape[:-1], 4))
    h[..., :2] = x[..., :2]
    np.multiply(x[..., IS, None], heading, out=h[..., 2:])
    dv = Ht.view(complex)[..., 1]  # row j of Ht: ∂(Ẋ + iẎ)/∂x_j
    dv[..., IS] = heading.view(complex)[..., 0]  # e^{iθ}
    np.multiply(h[..., 2:].view(complex)[..., 0], 1j, out=dv[..., ITH])  # i s e^{iθ}
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
