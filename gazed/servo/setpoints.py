"""Set-points the head can follow: the servo process never writes a jump.

A demand sets a target (joint angles, and for pursuit the target's rates, seed 000 §2: position
and velocity demands); the set-point moves towards it under the [head] rate and acceleration
limits (`AxisMotion`), inside the joint limits, and is what gets written to the device. So a
saccade demand becomes a move at the head's limits even on a device that would jump at full
speed (a Dynamixel with Profile Velocity 0), a pursuit demand is extrapolated with its rate
between demands, and a hold decelerates to rest instead of stopping dead.
"""

from __future__ import annotations

from gazed.config import HeadSection
from gazed.servo.axis_motion import AxisMotion
from gazed.servo.limits import Target, joint_limits_rad


class SetpointGenerator:
    """Two axes of set-points in joint angles, advanced on the caller's monotonic clock."""

    def __init__(
        self, head: HeadSection, t_s: float, inset_rad: tuple[float, float] = (0.0, 0.0)
    ) -> None:
        (pan_lo, pan_hi), (tilt_lo, tilt_hi) = joint_limits_rad(head, inset_rad)
        pan_rate, tilt_rate = head.rate_max_rad_s
        pan_accel, tilt_accel = head.accel_max_rad_s2
        park_pan, park_tilt = head.park_rad
        self.pan = AxisMotion(pan_rate, pan_accel, park_pan, pan_lo, pan_hi)
        self.tilt = AxisMotion(tilt_rate, tilt_accel, park_tilt, tilt_lo, tilt_hi)
        self.t_s = t_s

    @property
    def clamps(self) -> int:
        """Extrapolated pursuit targets that ran into a joint limit."""
        return self.pan.clamps + self.tilt.clamps

    def reset(self, pan_rad: float, tilt_rad: float, t_s: float) -> None:
        """At rest at a measured position (after connecting)."""
        self.t_s = t_s
        self.pan.reset(pan_rad)
        self.tilt.reset(tilt_rad)

    def advance(self, t_s: float) -> tuple[float, float]:
        """The set-point at `t_s` (joint angles)."""
        if t_s > self.t_s:
            self.pan.advance(t_s - self.t_s)
            self.tilt.advance(t_s - self.t_s)
            self.t_s = t_s
        return self.pan.position_rad, self.tilt.position_rad

    def track(self, target: Target, t_s: float) -> None:
        """Head for `target` (already limited) from `t_s` on."""
        self.advance(t_s)
        self.pan.move_to(target.pan_rad, target.pan_rate_rad_s)
        self.tilt.move_to(target.tilt_rad, target.tilt_rate_rad_s)

    def hold(self, t_s: float) -> None:
        """Come to rest as soon as the limits allow."""
        self.advance(t_s)
        self.pan.hold()
        self.tilt.hold()

    @property
    def rates_rad_s(self) -> tuple[float, float]:
        return self.pan.velocity_rad_s, self.tilt.velocity_rad_s

    @property
    def settled(self) -> bool:
        return self.pan.settled and self.tilt.settled
