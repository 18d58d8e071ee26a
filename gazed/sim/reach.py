"""The rig's field of regard on the ground: where the head can hold a target in its fovea.

A ground point is within reach when the joint angles that centre the target's middle on it
(`CameraPose.gaze_angles`) lie inside the `[head]` joint limits, each moved inwards by
`inset_rad`. The simulated walker keeps inside the limits less the fovea and the head's
stopping distance at full rate, rate² / (2 accel) per axis, so that the head can follow it
without braking against a stop. The loop's score counts a frame as reachable when the head can
put the target in the fovea at all: the limits widened by the fovea (a negative inset).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gazed.config import Rig
from gazed.geometry.pose import CameraPose


@dataclass(frozen=True)
class FieldOfRegard:
    """Ground points whose middle (at `middle_height_m`) the head centres within its limits
    less `inset_rad` (pan, tilt)."""

    pose: CameraPose
    pan_limits_rad: tuple[float, float]
    tilt_limits_rad: tuple[float, float]
    inset_rad: tuple[float, float]
    middle_height_m: float

    @classmethod
    def for_walker(cls, rig: Rig) -> FieldOfRegard:
        """Limits less the fovea and the head's stopping distance at full rate."""
        fovea = math.radians(rig.gaze.fovea_half_angle_deg)
        rates, accels = rig.head.rate_max_rad_s, rig.head.accel_max_rad_s2
        inset = tuple(
            fovea + rate * rate / (2.0 * accel) for rate, accel in zip(rates, accels, strict=True)
        )
        return cls._from_rig(rig, (inset[0], inset[1]))

    @classmethod
    def for_scoring(cls, rig: Rig) -> FieldOfRegard:
        """Limits widened by the fovea: where the target can be foveated at all."""
        fovea = math.radians(rig.gaze.fovea_half_angle_deg)
        return cls._from_rig(rig, (-fovea, -fovea))

    @classmethod
    def _from_rig(cls, rig: Rig, inset_rad: tuple[float, float]) -> FieldOfRegard:
        return cls(
            CameraPose.from_rig(rig),
            rig.head.pan_limits_rad,
            rig.head.tilt_limits_rad,
            inset_rad,
            rig.sim.target_height_m / 2.0,
        )

    def contains(self, xy_m: np.ndarray) -> np.ndarray:
        """Whether each ground point (..., 2) is within reach, (...) booleans."""
        xy = np.asarray(xy_m, dtype=float)
        points = np.concatenate([xy, np.full((*xy.shape[:-1], 1), self.middle_height_m)], -1)
        pan, tilt = self.pose.gaze_angles(points)
        return self.contains_angles(pan, tilt)

    def contains_angles(self, pan_rad: np.ndarray, tilt_rad: np.ndarray) -> np.ndarray:
        """Whether joint angles (pan, tilt) lie within the limits less the inset."""
        (pan_lo, pan_hi), (tilt_lo, tilt_hi) = self.pan_limits_rad, self.tilt_limits_rad
        pan_in, tilt_in = self.inset_rad
        return (
            (pan_rad >= pan_lo + pan_in)
            & (pan_rad <= pan_hi - pan_in)
            & (tilt_rad >= tilt_lo + tilt_in)
            & (tilt_rad <= tilt_hi - tilt_in)
        )
