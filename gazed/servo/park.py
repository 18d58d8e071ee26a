"""Driving the head to its park angles before the port is closed (the `servo` process's stop).

The set-points move to [head] park under the head's rate and acceleration limits, written every
command period, until they settle or `PARK_TIMEOUT_S` has passed: a stop never waits on a head
that does not get there.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from gazed.config import HeadSection
from gazed.geometry.kinematics import device_from_joint
from gazed.servo.driver import ServoDriver
from gazed.servo.limits import Target
from gazed.servo.setpoints import SetpointGenerator

PARK_TIMEOUT_S = 2.5


def park(
    driver: ServoDriver,
    setpoints: SetpointGenerator,
    head: HeadSection,
    period_s: float,
    timeout_s: float = PARK_TIMEOUT_S,
    mono_s: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], None] = time.sleep,
) -> None:
    """Write set-points towards the park angles every `period_s` until they are there or
    `timeout_s` has passed (raises what the driver raises)."""
    park_pan, park_tilt = head.park_rad
    setpoints.track(Target("park", park_pan, park_tilt, 0.0, 0.0), mono_s())
    deadline_s = mono_s() + timeout_s
    while True:
        setpoint = setpoints.advance(mono_s())
        driver.set_position(*device_from_joint(head, *setpoint))
        if setpoints.settled or mono_s() > deadline_s:
            break
        sleep(period_s)
