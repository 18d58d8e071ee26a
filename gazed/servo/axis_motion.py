"""One axis moving under rate and acceleration limits: to a position, after a moving target, or
at a velocity.

Used twice: the `servo` process generates its set-points with it (so a saccade demand becomes a
move the head can follow, DESIGN §3 "limits enforced again in servo"), and the head emulator
moves its simulated axes with it.

Position mode is the time-optimal bang-bang law with braking: the relative speed towards the
target is at most `sqrt(2·a·|e|)` (the speed from which the axis can still stop in `|e|` at
deceleration `a`), at most the rate cap, and at most `|e|/h` so a step never overshoots; the
velocity moves towards that speed by at most `a·h` per step. A target that moves (feed-forward
rate, as in pursuit, seed 000 §2) is followed with its rate added, so a constant-rate target is
tracked without lag. Integration is semi-implicit Euler in fixed steps of `STEP_S`, with the
braking speed in its exact discrete form, so a move ends on its target without overshoot.
"""

from __future__ import annotations

import math
from typing import Literal

STEP_S = 0.001
SNAP_RAD = 1e-9


def _braking_speed(distance_rad: float, accel_rad_s2: float, h: float) -> float:
    """The largest speed from which steps of `h`, each slowing by `a·h`, stop within
    `distance_rad` (the discrete form of sqrt(2·a·d): v = a·h·(sqrt(2d/(a·h²) + 1/4) - 1/2))."""
    ah = accel_rad_s2 * h
    return ah * (math.sqrt(2.0 * distance_rad / (ah * h) + 0.25) - 0.5)


class AxisMotion:
    """One axis. Angles in radians, rates in rad/s, accelerations in rad/s². `lower_rad` and
    `upper_rad` are hard bounds: a target beyond them is clamped (and counted in `clamps`), a
    velocity move stops at them (and sets `limit_hit`)."""

    def __init__(
        self,
        rate_max_rad_s: float,
        accel_max_rad_s2: float,
        position_rad: float = 0.0,
        lower_rad: float = -math.inf,
        upper_rad: float = math.inf,
    ) -> None:
        if rate_max_rad_s <= 0 or accel_max_rad_s2 <= 0:
            raise ValueError("rate and acceleration limits must be positive")
        if lower_rad > upper_rad:
            raise ValueError("lower bound above upper bound")
        self.rate_max_rad_s = rate_max_rad_s
        self.accel_max_rad_s2 = accel_max_rad_s2
        self.lower_rad = lower_rad
        self.upper_rad = upper_rad
        self.position_rad = min(max(position_rad, lower_rad), upper_rad)
        self.velocity_rad_s = 0.0
        self.mode: Literal["position", "velocity"] = "position"
        self.target_rad = self.position_rad
        self.target_rate_rad_s = 0.0
        self.rate_cap_rad_s = rate_max_rad_s
        self.velocity_command_rad_s = 0.0
        self.clamps = 0
        self.limit_hit = False

    def reset(self, position_rad: float) -> None:
        """At rest at `position_rad`, holding it."""
        self.position_rad = min(max(position_rad, self.lower_rad), self.upper_rad)
        self.velocity_rad_s = 0.0
        self.move_to(self.position_rad)

    def move_to(
        self, target_rad: float, target_rate_rad_s: float = 0.0, rate_rad_s: float | None = None
    ) -> None:
        """Go to `target_rad`, which itself moves at `target_rate_rad_s`; `rate_rad_s` caps the
        speed of this move below the axis's limit (a VISCA speed byte, a PTU `PS`)."""
        self.mode = "position"
        self.target_rad = self._clamp_target(target_rad)
        self.target_rate_rad_s = target_rate_rad_s
        cap = (
            self.rate_max_rad_s if rate_rad_s is None else min(abs(rate_rad_s), self.rate_max_rad_s)
        )
        self.rate_cap_rad_s = cap

    def move_at(self, rate_rad_s: float) -> None:
        """Run at `rate_rad_s` (clamped to the rate limit) until told otherwise or a bound."""
        self.mode = "velocity"
        self.velocity_command_rad_s = max(
            -self.rate_max_rad_s, min(self.rate_max_rad_s, rate_rad_s)
        )

    def hold(self) -> None:
        """Come to rest as soon as the acceleration limit allows, and stay there."""
        v = self.velocity_rad_s
        stopping_rad = self.position_rad + v * abs(v) / (2.0 * self.accel_max_rad_s2)
        self.move_to(stopping_rad)

    @property
    def settled(self) -> bool:
        """At rest where it was told to be."""
        if self.mode == "velocity":
            return self.velocity_command_rad_s == 0.0 and self.velocity_rad_s == 0.0
        return (
            self.target_rate_rad_s == 0.0
            and self.velocity_rad_s == 0.0
            and self.position_rad == self.target_rad
        )

    def advance(self, dt_s: float) -> None:
        """Integrate `dt_s` seconds (in steps of at most 1 ms)."""
        while dt_s > 0.0:
            if self.settled:
                return
            h = min(STEP_S, dt_s)
            self._step(h)
            dt_s -= h

    def _clamp_target(self, target_rad: float) -> float:
        clamped = min(max(target_rad, self.lower_rad), self.upper_rad)
        if clamped != target_rad:
            self.clamps += 1
        return clamped

    def _step(self, h: float) -> None:
        a_max = self.accel_max_rad_s2
        e = 0.0
        if self.mode == "velocity":
            v_des = self.velocity_command_rad_s
        else:
            # close the gap as if the target stood still, and move with it on top
            e = self.target_rad - self.position_rad
            cap = self.rate_cap_rad_s
            towards = min(cap, _braking_speed(abs(e), a_max, h), abs(e) / h)
            v_des = self.target_rate_rad_s + math.copysign(towards, e)
            v_des = max(-cap, min(cap, v_des))
            if self.target_rate_rad_s:
                moved = self.target_rad + self.target_rate_rad_s * h
                self.target_rad = min(max(moved, self.lower_rad), self.upper_rad)
                if self.target_rad != moved:
                    self.target_rate_rad_s = 0.0
                    self.clamps += 1
        v0 = self.velocity_rad_s
        v1 = v0 + max(-a_max * h, min(a_max * h, v_des - v0))
        x = self.position_rad + v1 * h
        if x <= self.lower_rad or x >= self.upper_rad:
            x = min(max(x, self.lower_rad), self.upper_rad)
            if self.mode == "velocity" and v1 != 0.0:
                self.limit_hit = True
            v1 = 0.0
        self.position_rad, self.velocity_rad_s = x, v1
        if self.mode != "position":
            return
        # arrived: within a hair of the target, or about to step past it at the end of braking
        # (a speed between grid multiples of a·h can leave the last step a fraction too fast)
        e_after = self.target_rad - x
        arrived = abs(e_after) < SNAP_RAD or (e != 0.0 and e_after * e < 0.0)
        if arrived and abs(v1 - self.target_rate_rad_s) <= 2.0 * a_max * h:
            self.position_rad = self.target_rad
            self.velocity_rad_s = self.target_rate_rad_s
