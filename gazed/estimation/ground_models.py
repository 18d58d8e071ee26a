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

from gazed.estimation import _kalman

STATE_DIM = 6
IX, IY, IS, ITH, ISD, ITD = range(STATE_DIM)
HEADING_INDEX = ITH

# Below this |u| = |ωT| the series of A, B and their derivatives replace the closed forms
# (the compiled kernel's, which computes them).
SERIES_LIMIT: float = _kalman.SERIES_LIMIT


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
    """Several ground models evaluated together on states of shape (..., M, 6).

    The update equation, its Jacobian and Q are computed by the compiled kernel
    (`_kalman.c`, `ground_motion`); `parameters` (M, 4) is what it reads of each model:
    accelerates (0 or 1), turns (0 or 1), q_speed, q_heading.
    """

    models: tuple[GroundModel, ...]

    def __post_init__(self) -> None:
        parameters = np.array(
            [[float(m.accelerates), float(m.turns), m.q_speed, m.q_heading] for m in self.models]
        )
        parameters.flags.writeable = False
        object.__setattr__(self, "parameters", parameters)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(m.name for m in self.models)

    def propagate(self, x: np.ndarray, dt: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """f(x), its Jacobian ∇f and Q over an interval dt: the kernel's own motion step (the
        filters call it inside their fused steps), on its own for the tests and for analysis.

        x: (..., M, 6); dt: (...) seconds, >= 0, one per state of the M models.
        Returns x' (..., M, 6), F (..., M, 6, 6), Q (..., M, 6, 6).
        """
        dt = np.ascontiguousarray(dt, dtype=float)
        shape = x.shape
        if dt.shape != shape[:-2] or shape[-2:] != (len(self.models), STATE_DIM):
            raise ValueError(f"dt has shape {dt.shape} for states of shape {shape}")
        xn = np.empty(shape)
        F = np.empty((*shape, STATE_DIM))
        Q = np.empty((*shape, STATE_DIM))
        L = xn.size // STATE_DIM
        x = np.ascontiguousarray(x, dtype=float)
        _kalman.ground_motion(L, len(self.models), x, dt, self.parameters, xn, F, Q)
        return xn, F, Q


def measure(x: np.ndarray, with_velocity: bool) -> tuple[np.ndarray, np.ndarray]:
    """h(x) = (X, Y, s cos θ, s sin θ) (errata of §4.1.1) or (X, Y), and its Jacobian ∇h: the
    kernel's measurement, on its own for the tests and for analysis.

    x: (..., 6). Returns h (..., m) and H (..., m, 6), m = 4 or 2.
    """
    m = 4 if with_velocity else 2
    x = np.ascontiguousarray(x, dtype=float)
    h = np.empty((*x.shape[:-1], m))
    H = np.empty((*x.shape[:-1], m, STATE_DIM))
    _kalman.ground_measure(x.size // STATE_DIM, m, x, h, H)
    return h, H


def canonicalise(x: np.ndarray, P: np.ndarray) -> bool:
    """In place: a negative speed becomes a positive one with the heading turned by π.

    (s, θ, ṡ) -> (-s, θ + π, -ṡ) describes the same motion; P becomes D P D,
    D = diag(1, 1, -1, 1, -1, 1). x (..., 6) and P (..., 6, 6) C-contiguous float64.
    Returns whether any state changed. (The filter's update does this itself.)
    """
    return _kalman.canonicalise(x.size // STATE_DIM, x, P) > 0
