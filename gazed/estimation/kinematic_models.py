"""CP / CV / CA linear motion models of seed 003 Tables 1-2, on two independent axes.

All three share the state of Table 2, per axis [p, ṗ, p̈], so x = [x, ẋ, ẍ, y, ẏ, ÿ]; a model
that does not estimate a derivative has a zero row for it in Ã (CP zeroes ṗ and p̈, CV zeroes p̈),
exactly as Table 2 writes them. Process noise is Q = σ_v² C̃ C̃ᵀ per axis with the gains of
Table 1: CP C̃ = [T], CV C̃ = [T²/2, T], CA C̃ = [T³/6, T²/2, T]; v is a velocity (CP, m/s),
an acceleration (CV, m/s²) or a jerk (CA, m/s³). The CV block equals filterpy's
`Q_discrete_white_noise(2, T, σ_v²)` (checked in the tests).

The same models serve the gaze plane (image-cv): x and y are then pan and tilt in radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

STATE_DIM = 6
AXIS_DIM = 3
POSITION_INDEX = (0, 3)
VELOCITY_INDEX = (1, 4)
ACCELERATION_INDEX = (2, 5)

ORDERS = {"CP": 0, "CV": 1, "CA": 2}


@dataclass(frozen=True)
class KinematicModel:
    """A polynomial model of `order` 0 (CP), 1 (CV) or 2 (CA) with noise variance q."""

    name: str
    order: int
    q: float


def kinematic_model(name: str, q: float) -> KinematicModel:
    if name not in ORDERS:
        raise ValueError(f"unknown kinematic model {name!r} (expected one of {', '.join(ORDERS)})")
    return KinematicModel(name, ORDERS[name], q)


@dataclass(frozen=True)
class KinematicModelBank:
    """Several kinematic models evaluated together on states of shape (..., M, 6).

    Ã and Q̃ are polynomials in T; their coefficients are computed once, so building the
    matrices for any batch of intervals is one product each.
    """

    models: tuple[KinematicModel, ...]

    def __post_init__(self) -> None:
        orders = np.array([m.order for m in self.models])
        q = np.array([m.q for m in self.models])
        # Ã = Σ_d T^d F_d (d <= 2);  C̃ = Σ_d T^d C_d (d <= 3);  Q̃ = q Σ_d,e T^(d+e) C_d C_eᵀ
        F_axis = np.zeros((3, len(orders), AXIS_DIM, AXIS_DIM))
        C_axis = np.zeros((4, len(orders), AXIS_DIM))
        for m, order in enumerate(orders):
            F_axis[0, m, 0, 0] = 1.0
            if order >= 1:
                F_axis[0, m, 1, 1] = 1.0
                F_axis[1, m, 0, 1] = 1.0
            if order >= 2:
                F_axis[0, m, 2, 2] = 1.0
                F_axis[1, m, 1, 2] = 1.0
                F_axis[2, m, 0, 2] = 0.5
            # Table 1: the noise enters at the derivative after the highest one modelled
            for row in range(order + 1):
                power = order + 1 - row
                C_axis[power, m, row] = 1.0 / math.factorial(power)
        Q_axis = np.zeros((7, len(orders), AXIS_DIM, AXIS_DIM))
        for d in range(4):
            for e in range(4):
                Q_axis[d + e] += q[:, None, None] * C_axis[d][:, :, None] * C_axis[e][:, None, :]
        M = len(orders)
        object.__setattr__(self, "_F_coefficients", _two_axes(F_axis).reshape(3, M * 36))
        object.__setattr__(self, "_Q_coefficients", _two_axes(Q_axis).reshape(7, M * 36))

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(m.name for m in self.models)

    def matrices(self, dt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Ã and Q̃ for every model: dt (...) -> F, Q of shape (..., M, 6, 6)."""
        dt = np.asarray(dt, dtype=float)
        powers = dt[..., None] ** np.arange(7)
        shape = (*dt.shape, len(self.models), STATE_DIM, STATE_DIM)
        F = (powers[..., :3] @ self._F_coefficients).reshape(shape)
        Q = (powers @ self._Q_coefficients).reshape(shape)
        return F, Q

    def propagate(self, x: np.ndarray, dt: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """x' = Ã x, Ã, Q̃: x (..., M, 6), dt broadcastable to (...)."""
        F, Q = self.matrices(np.broadcast_to(dt, x.shape[:-2]))
        return (F @ x[..., None])[..., 0], F, Q


def _two_axes(per_axis: np.ndarray) -> np.ndarray:
    """Block-diagonal (x axis, y axis) copies of per-axis matrices (..., 3, 3) -> (..., 6, 6)."""
    out = np.zeros((*per_axis.shape[:-2], STATE_DIM, STATE_DIM))
    out[..., :3, :3] = per_axis
    out[..., 3:, 3:] = per_axis
    return out


def measurement_matrix(with_velocity: bool) -> np.ndarray:
    """H observing (x, y) or (x, y, ẋ, ẏ): (m, 6)."""
    rows = POSITION_INDEX + (VELOCITY_INDEX if with_velocity else ())
    H = np.zeros((len(rows), STATE_DIM))
    H[np.arange(len(rows)), rows] = 1.0
    return H
