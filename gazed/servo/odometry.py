"""The head's position replies as odometry: joint angles dated when the head read them, both axes
at one instant, with rates.

Pelco-D and the PTU report pan and tilt in two replies, each read by the head at its own instant
(`DevicePosition`). A reading puts both axes at the later of the two, moving the earlier one on
by its rate; rates come from successive readings of each axis over its own instants. A pan that
wraps (Pelco-D's circle) is taken into (-π, π], and its change between readings the short way
round.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from gazed.config import HeadSection
from gazed.geometry.kinematics import joint_from_device
from gazed.servo.driver import DevicePosition


def wrap_angle(angle_rad: float) -> float:
    """Into (-π, π]."""
    wrapped = math.remainder(angle_rad, 2.0 * math.pi)
    return math.pi if wrapped == -math.pi else wrapped


def rate_rad_s(change_rad: float, dt_ns: int) -> float:
    """A change over `dt_ns`; 0 where no time passed."""
    return change_rad / (dt_ns / 1e9) if dt_ns > 0 else 0.0


@dataclass(frozen=True)
class JointReading:
    """The head's joint angles and rates at `t_ns` (wall clock). `dead_reckoned`: taken from the
    set-points, the head cannot report its position. `zoom`: the zoom lens's position read with
    it (0 widest, 1 longest); None for a fixed lens."""

    t_ns: int
    pan_rad: float
    tilt_rad: float
    pan_rate_rad_s: float
    tilt_rate_rad_s: float
    dead_reckoned: bool = False
    zoom: float | None = None


class OdometryDating:
    """Position replies of one head to joint readings; `reset()` when the link is reopened."""

    def __init__(self, head: HeadSection, pan_wraps: bool) -> None:
        self.head = head
        self.pan_wraps = pan_wraps
        self._last: tuple[float, float, int, int] | None = None  # pan, tilt, their instants

    def joint(self, position: DevicePosition) -> tuple[float, float]:
        """Device angles to joint angles (pan wrapped where the protocol's pan is a circle)."""
        pan, tilt = joint_from_device(self.head, position.pan_rad, position.tilt_rad)
        return (wrap_angle(pan) if self.pan_wraps else pan), tilt

    def reset(self) -> None:
        self._last = None

    def reading(self, position: DevicePosition) -> JointReading:
        """Both axes at the later of their instants, with rates since the previous reading."""
        pan, tilt = self.joint(position)
        pan_rate = tilt_rate = 0.0
        if self._last is not None:
            last_pan, last_tilt, last_pan_ns, last_tilt_ns = self._last
            pan_rate = rate_rad_s(wrap_angle(pan - last_pan), position.t_pan_ns - last_pan_ns)
            tilt_rate = rate_rad_s(tilt - last_tilt, position.t_tilt_ns - last_tilt_ns)
        self._last = (pan, tilt, position.t_pan_ns, position.t_tilt_ns)
        t_ns = max(position.t_pan_ns, position.t_tilt_ns)
        pan += pan_rate * (t_ns - position.t_pan_ns) / 1e9
        tilt += tilt_rate * (t_ns - position.t_tilt_ns) / 1e9
        return JointReading(t_ns, pan, tilt, pan_rate, tilt_rate)
