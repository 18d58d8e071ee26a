"""What a filter takes: one timestamped observation of the target, with its covariance.

A measurement is a position and optionally a velocity, each with a 2x2 covariance, on the
ground plane (metres) or, for `image-cv`, in gaze angles (radians). `usable` is the check every
`TrackEstimator` makes before filtering one: finite values and covariances that are symmetric
and positive definite.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class Measurement:
    """One observation of the target at `t_s` (seconds, any consistent clock).

    In the filter's plane: ground modes take metres and m/s, `image-cv` takes (pan, tilt) in
    radians and rad/s. Covariances are 2x2. Use `ground(...)` or `gaze(...)` to build one.
    """

    t_s: float
    position: np.ndarray
    position_cov: np.ndarray
    velocity: np.ndarray | None = None
    velocity_cov: np.ndarray | None = None

    @classmethod
    def ground(
        cls,
        t_s: float,
        xy_m: Any,
        xy_cov_m2: Any,
        velocity_m_s: Any = None,
        velocity_cov_m2_s2: Any = None,
    ) -> Measurement:
        return cls._build(t_s, xy_m, xy_cov_m2, velocity_m_s, velocity_cov_m2_s2)

    @classmethod
    def gaze(
        cls,
        t_s: float,
        pan_tilt_rad: Any,
        pan_tilt_cov_rad2: Any,
        rates_rad_s: Any = None,
        rates_cov_rad2_s2: Any = None,
    ) -> Measurement:
        return cls._build(t_s, pan_tilt_rad, pan_tilt_cov_rad2, rates_rad_s, rates_cov_rad2_s2)

    @classmethod
    def _build(cls, t_s: float, p: Any, p_cov: Any, v: Any, v_cov: Any) -> Measurement:
        if (v is None) != (v_cov is None):
            raise ValueError("a velocity needs its covariance (and a covariance its velocity)")
        return cls(
            float(t_s),
            _array(p, (2,), "position"),
            _array(p_cov, (2, 2), "position covariance"),
            None if v is None else _array(v, (2,), "velocity"),
            None if v_cov is None else _array(v_cov, (2, 2), "velocity covariance"),
        )

    @property
    def z(self) -> np.ndarray:
        """[p, v] or [p]: (4,) or (2,)."""
        return (
            self.position
            if self.velocity is None
            else np.concatenate([self.position, self.velocity])
        )

    @property
    def R(self) -> np.ndarray:
        """Block-diagonal covariance of z: (4, 4) or (2, 2)."""
        if self.velocity_cov is None:
            return self.position_cov
        R = np.zeros((4, 4))
        R[:2, :2] = self.position_cov
        R[2:, 2:] = self.velocity_cov
        return R

    def moving(self, threshold_d2: float) -> Measurement:
        """This measurement where its velocity differs from zero (`vᵀ Σᵥ⁻¹ v` at least
        `threshold_d2`), else its position alone: a velocity within its noise of zero has no
        direction, and a filter whose state holds a speed and a heading, started from it, has
        its heading fixed at an arbitrary angle (at zero speed no measurement moves it)."""
        d2 = self.velocity_d2(np.zeros(2))
        return self if d2 is None or d2 >= threshold_d2 else self.position_only()

    def velocity_d2(
        self, reference: np.ndarray, reference_cov: np.ndarray | None = None
    ) -> float | None:
        """The velocity's squared Mahalanobis distance from `reference`, against the sum of its
        covariance and `reference_cov` (none: an exact reference); None without a velocity."""
        if self.velocity is None or self.velocity_cov is None:
            return None
        S = self.velocity_cov if reference_cov is None else self.velocity_cov + reference_cov
        innovation = self.velocity - reference
        return float(innovation @ np.linalg.solve(S, innovation))

    def position_only(self) -> Measurement:
        """This measurement without its velocity."""
        return Measurement(self.t_s, self.position, self.position_cov)

    @property
    def usable(self) -> bool:
        """Finite, with covariances symmetric (to 1e-9 relative) and positive definite: what
        `small_matrices.positive_definite` and the finiteness checks of `TrackEstimator.step`
        accept, evaluated on the 2x2 blocks in plain Python (R is block diagonal)."""
        values = [self.t_s, *self.position.tolist()]
        blocks = [self.position_cov.tolist()]
        if self.velocity is not None and self.velocity_cov is not None:
            values += self.velocity.tolist()
            blocks.append(self.velocity_cov.tolist())
        return all(map(math.isfinite, values)) and all(map(_usable_covariance, blocks))


def _usable_covariance(C: list[list[float]]) -> bool:
    """A 2x2 covariance (nested lists) is finite, symmetric and positive definite."""
    (a, b), (c, d) = C
    return (
        all(map(math.isfinite, (a, b, c, d)))
        and abs(b - c) <= 1e-9 * (1.0 + min(abs(b), abs(c)))
        and a > 0.0
        and a * d - b * c > 0.0
    )


def _array(value: Any, shape: tuple[int, ...], what: str) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.shape != shape:
        raise ValueError(f"{what}: expected shape {shape}, got {a.shape}")
    return a
