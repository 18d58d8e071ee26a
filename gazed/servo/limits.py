"""The last line of defence (DESIGN §3, STYLE 15): every demand is checked against the rig's
[head] joint and rate limits in the servo process, whatever `gaze` already did.

A demand with a non-finite number is refused; a position outside the joint limits is clamped to
them and a feed-forward rate above the rate limit is clamped to it. Every refusal and every
clamp (per axis) is counted, so `servo/status` shows how often the rest of the loop asked for
the impossible.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from gazed.config import HeadSection
from gazed.messages import GazeDemand


@dataclass(frozen=True)
class Target:
    """A demand made safe: joint angles inside the limits, rates inside the rate limits."""

    kind: str
    pan_rad: float
    tilt_rad: float
    pan_rate_rad_s: float
    tilt_rate_rad_s: float


def clamp(value: float, lower: float, upper: float) -> float:
    return min(max(value, lower), upper)


def joint_limits_rad(
    head: HeadSection, inset_rad: tuple[float, float] = (0.0, 0.0)
) -> tuple[tuple[float, float], tuple[float, float]]:
    """[head]'s pan and tilt limits, each brought in by `inset_rad` (one device unit, so that
    rounding a set-point to the protocol's unit never lands it beyond the limit)."""
    (pan_lo, pan_hi), (tilt_lo, tilt_hi) = head.pan_limits_rad, head.tilt_limits_rad
    pan_in, tilt_in = inset_rad
    return (pan_lo + pan_in, pan_hi - pan_in), (tilt_lo + tilt_in, tilt_hi - tilt_in)


class DemandLimiter:
    """Clamps demands to [head] (limits brought in by `inset_rad`); `joint_clamps`,
    `rate_clamps` and `refused` count what it did."""

    def __init__(self, head: HeadSection, inset_rad: tuple[float, float] = (0.0, 0.0)) -> None:
        self.pan_limits_rad, self.tilt_limits_rad = joint_limits_rad(head, inset_rad)
        self.rate_max_rad_s = head.rate_max_rad_s
        self.park_rad = head.park_rad
        self.joint_clamps = 0
        self.rate_clamps = 0
        self.refused = 0

    @property
    def clamps(self) -> int:
        return self.joint_clamps + self.rate_clamps

    def limit(self, demand: GazeDemand) -> Target | None:
        """The demand inside the limits, or None (counted) if it carries a non-finite number.
        `park` goes to the rig's park angles; `hold` keeps its position and drops its rates."""
        numbers = (demand.pan_rad, demand.tilt_rad, demand.pan_rate_rad_s, demand.tilt_rate_rad_s)
        if not all(math.isfinite(x) for x in numbers):
            self.refused += 1
            return None
        pan, tilt = self.park_rad if demand.kind == "park" else (demand.pan_rad, demand.tilt_rad)
        moving = demand.kind in ("pursuit", "position")
        pan_rate = demand.pan_rate_rad_s if moving else 0.0
        tilt_rate = demand.tilt_rate_rad_s if moving else 0.0
        return Target(
            demand.kind,
            self._joint(pan, self.pan_limits_rad),
            self._joint(tilt, self.tilt_limits_rad),
            self._rate(pan_rate, self.rate_max_rad_s[0]),
            self._rate(tilt_rate, self.rate_max_rad_s[1]),
        )

    def _joint(self, angle_rad: float, limits: tuple[float, float]) -> float:
        clamped = clamp(angle_rad, *limits)
        if clamped != angle_rad:
            self.joint_clamps += 1
        return clamped

    def _rate(self, rate_rad_s: float, rate_max_rad_s: float) -> float:
        clamped = clamp(rate_rad_s, -rate_max_rad_s, rate_max_rad_s)
        if clamped != rate_rad_s:
            self.rate_clamps += 1
        return clamped
