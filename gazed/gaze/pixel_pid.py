"""The peers' pursuit law: a PID on the target's pixel error with a deadband, no prediction
(the streaming plug-ins' PTZ trackers, roboflow's ONVIF block), kept to compare gazed with.

Each new detection gives the error: the angle between the optical axis and the ray through the
target's pixel, from the head pose at its capture (the pixel error through the camera model).
Inside the deadband the error counts as zero. Per axis the law is

    rate = kp e + ki ∫e dt + kd de/dt

evaluated at each detection and held until the next; the demand is a pursuit demand at that
rate from a commanded position that integrates it (a PTZ driven in velocity). The integral is
clamped so that its share alone never exceeds the head's rate limit (anti-windup), the rate to
that limit, the commanded position to the joint limits; no new detection for `stale_s` (the
time between arrivals, the visual latency apart) stops the head.
"""

from __future__ import annotations

import math

from gazed.gaze.aim import detection_aim
from gazed.gaze.demand import make_demand
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.zoom import ZoomLens
from gazed.messages import Detection, GazeDemand, Odometry


class PixelPid:
    """The law's state: the commanded position, the integral and the last error, per axis."""

    def __init__(
        self,
        gains: tuple[float, float, float],
        deadband_px: float,
        rate_max_rad_s: tuple[float, float],
        limits_rad: tuple[tuple[float, float], tuple[float, float]],
        stale_s: float,
    ) -> None:
        self.kp, self.ki, self.kd = gains
        self.deadband_px = deadband_px
        self.rate_max_rad_s = rate_max_rad_s
        self.limits_rad = limits_rad
        self.stale_s = stale_s
        self.restart()

    def restart(self) -> None:
        """Pursuit begins: start from where the head is, at rest, with no history."""
        self.command_rad: list[float] | None = None
        self.rate_rad_s = [0.0, 0.0]
        self.integral = [0.0, 0.0]
        self.last_error: list[float] | None = None
        self.last_capture_ns: int | None = None
        self.last_tick_ns: int | None = None
        self.updated = False  # a detection came since the last tick
        self.last_update_ns: int | None = None  # the tick that first saw the latest detection

    def update(self, error_rad: tuple[float, float], error_px: float, t_capture_ns: int) -> None:
        """A new error measurement (a detection captured at `t_capture_ns`): the new rate."""
        if t_capture_ns == self.last_capture_ns:
            return
        dt_s = (
            (t_capture_ns - self.last_capture_ns) / 1e9 if self.last_capture_ns is not None else 0.0
        )
        inside = error_px <= self.deadband_px
        for axis in (0, 1):
            e = 0.0 if inside else error_rad[axis]
            limit = self.rate_max_rad_s[axis]
            if self.ki > 0:
                bound = limit / self.ki
                self.integral[axis] = max(-bound, min(bound, self.integral[axis] + e * dt_s))
            derivative = (
                (e - self.last_error[axis]) / dt_s
                if self.last_error is not None and dt_s > 0
                else 0.0
            )
            rate = self.kp * e + self.ki * self.integral[axis] + self.kd * derivative
            self.rate_rad_s[axis] = max(-limit, min(limit, rate))
        self.last_error = [0.0 if inside else e for e in error_rad]
        self.last_capture_ns = t_capture_ns
        self.updated = True

    def demand(
        self, odometry: Odometry | None, wall_ns: int, found: Detection | None = None
    ) -> GazeDemand | None:
        """This tick's demand: the commanded position moved on at the held rate; None before
        any odometry. The first demand after a new detection carries `found`'s stamps (the
        detection it acts on), so that the loop's latency can be read from it."""
        if self.command_rad is None:
            if odometry is None:
                return None
            self.command_rad = [odometry.pan_rad, odometry.tilt_rad]
            self.last_tick_ns = wall_ns
        source = found if self.updated else None
        if self.updated:
            self.last_update_ns, self.updated = wall_ns, False
        if self.last_update_ns is None or (wall_ns - self.last_update_ns) / 1e9 > self.stale_s:
            self.rate_rad_s = [0.0, 0.0]
        dt_s = max(0.0, (wall_ns - (self.last_tick_ns or wall_ns)) / 1e9)
        self.last_tick_ns = wall_ns
        for axis in (0, 1):
            low, high = self.limits_rad[axis]
            moved = self.command_rad[axis] + self.rate_rad_s[axis] * dt_s
            self.command_rad[axis] = max(low, min(high, moved))
            if self.command_rad[axis] in (low, high):
                self.rate_rad_s[axis] = 0.0
        return make_demand(
            "pursuit",
            self.command_rad[0],
            self.command_rad[1],
            wall_ns,
            source,
            rates_rad_s=(self.rate_rad_s[0], self.rate_rad_s[1]),
        )


def pixel_error(
    lens: ZoomLens, kinematics: HeadKinematics, detection: Detection
) -> tuple[tuple[float, float], float]:
    """The target's error as joint angles from the head pose at capture, and its pixel distance
    from the principal point, through the lens at the frame's zoom."""
    assert detection.head is not None
    aim = detection_aim(lens, kinematics, detection)
    camera = lens.at_pose(detection.head)
    error_rad = (aim.pan_rad - detection.head.pan_rad, aim.tilt_rad - detection.head.tilt_rad)
    cx, cy = float(camera.K[0, 2]), float(camera.K[1, 2])
    return error_rad, math.hypot(detection.u_px - cx, detection.v_px - cy)
