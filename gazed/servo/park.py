"""Driving the head to its park angles before the port is closed (the `servo` process's stop).

The set-points move to [head] park under the head's rate and acceleration limits, written every
command period, until they settle; a head that reports its position is then polled until it is
there too, since it follows its set-points late (its response lag) and the port should close on
a parked head. All of it within `PARK_TIMEOUT_S`: a stop never waits on a head that does not get
there.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

from gazed.config import HeadSection
from gazed.geometry.kinematics import device_from_joint
from gazed.servo.driver import ServoDriver
from gazed.servo.limits import Target
from gazed.servo.setpoints import SetpointGenerator

PARK_TIMEOUT_S = 2.5
ARRIVED_UNITS = 2  # a head within this many device units of the park angles is there
ARRIVED_MIN_RAD = math.radians(0.01)  # and within this, for a head with no unit (digital)


def park(
    driver: ServoDriver,
    setpoints: SetpointGenerator,
    head: HeadSection,
    period_s: float,
    timeout_s: float = PARK_TIMEOUT_S,
    mono_s: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], None] = time.sleep,
) -> None:
    """Write set-points towards the park angles every `period_s` until they are there, then
    wait for a head that reports its position to be there too; at most `timeout_s` in all
    (raises what the driver raises)."""
    park_pan, park_tilt = head.park_rad
    setpoints.track(Target("park", park_pan, park_tilt, 0.0, 0.0), mono_s())
    deadline_s = mono_s() + timeout_s
    while True:
        setpoint = setpoints.advance(mono_s())
        driver.set_position(*device_from_joint(head, *setpoint))
        if setpoints.settled or mono_s() > deadline_s:
            break
        sleep(period_s)
    if not setpoints.settled or not driver.codec.can_report_position:
        return
    goal_pan, goal_tilt = device_from_joint(head, park_pan, park_tilt)
    pan_unit, tilt_unit = driver.codec.resolution_rad
    while mono_s() <= deadline_s:
        position = driver.query_position()
        pan_off = abs(math.remainder(position.pan_rad - goal_pan, 2.0 * math.pi))
        tilt_off = abs(position.tilt_rad - goal_tilt)
        if pan_off <= max(ARRIVED_UNITS * pan_unit, ARRIVED_MIN_RAD) and tilt_off <= max(
            ARRIVED_UNITS * tilt_unit, ARRIVED_MIN_RAD
        ):
            return
        sleep(period_s)
