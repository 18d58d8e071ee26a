"""A serial head's drive commands as speed steps, for speed mode: VISCA Pan-tiltDrive and
Pelco-D's pan/tilt drive, through the driver's `set_velocity`.

Speed step k of N is k/N of the fastest drive (`pan_speed_max_deg_s`, `tilt_speed_max_deg_s`),
which the codec turns into the speed byte nearest k/N of its highest (`pan_speed_max_code`,
Pelco-D's 0x3F); with N the number of speed bytes, step k is byte k. Serial drives have no
timeout of their own: a drive runs until the next command or Stop.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from gazed.config import ServoLink
from gazed.servo.driver import DevicePosition, ServoDriver


def drive_rates_rad_s(servo: ServoLink) -> tuple[float, float]:
    """The rates of a serial head's fastest pan and tilt drives (its `*_speed_max_deg_s`)."""
    pan_deg_s = getattr(servo, "pan_speed_max_deg_s", 0.0)
    tilt_deg_s = getattr(servo, "tilt_speed_max_deg_s", 0.0)
    return math.radians(pan_deg_s), math.radians(tilt_deg_s)


class DriveSpeeds:
    """`driver` seen as a device that takes speed fractions; `rate_max_rad_s` are the rates of
    its fastest pan and tilt drives."""

    def __init__(self, driver: ServoDriver, rate_max_rad_s: tuple[float, float]) -> None:
        self.driver = driver
        self.codec = driver.codec
        self.transport = driver.transport
        self.counters = driver.counters
        self.rate_max_rad_s = rate_max_rad_s

    @property
    def is_connected(self) -> bool:
        return self.driver.is_connected

    def connect(self) -> None:
        self.driver.connect()

    def disconnect(self) -> None:
        self.driver.disconnect()

    def set_speed(self, pan_fraction: float, tilt_fraction: float, timeout_s: float) -> int:
        """Drive at fractions (-1..1) of the fastest drives; `timeout_s` is not the device's."""
        pan_max, tilt_max = self.rate_max_rad_s
        return self.driver.set_velocity(pan_fraction * pan_max, tilt_fraction * tilt_max)

    def set_position(self, pan_rad: float, tilt_rad: float) -> int:
        return self.driver.set_position(pan_rad, tilt_rad)

    def stop(self) -> int:
        return self.driver.stop()

    def query_position(self, between: Callable[[], None] | None = None) -> DevicePosition:
        return self.driver.query_position(between)
