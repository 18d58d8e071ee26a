"""Helpers of speed mode's tests and bench (`tests/test_servo_speed_mode.py`,
`tests/bench/speed_tracking.py`): speed devices on a virtual clock, and a pursuit followed on
the emulated head's mechanism."""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable

from gazed.servo.driver import DevicePosition
from gazed.servo.speed_mode import SpeedHead
from gazed.sim.head_mechanics import HeadMechanics

Pair = tuple[float, float]
VISCA_UNIT_RAD = math.radians(0.075)


class StubSpeedDevice:
    """The lifecycle and counters of a speed device (`speed_mode.SpeedDevice`) on a virtual
    clock `now` (seconds, in a one-item list); it takes speeds only, no positions."""

    codec = object()
    transport = object()

    def __init__(self, now: list[float]) -> None:
        self.counters: Counter[str] = Counter()
        self.now = now
        self.is_connected = False

    def connect(self) -> None:
        self.is_connected = True

    def disconnect(self) -> None:
        self.is_connected = False

    def set_position(self, pan_rad: float, tilt_rad: float) -> int:
        raise AssertionError("a speed head sends no positions")

    @property
    def now_ns(self) -> int:
        return round(self.now[0] * 1e9)


class Mechanism(StubSpeedDevice):
    """A speed device on the emulated head's mechanism, `rate_max_rad_s` at velocity 1 on each
    axis: each command acts `head_latency_ms` later, at the head's acceleration limit; readings
    in 0.075 deg units (VISCA's)."""

    def __init__(self, mechanics: HeadMechanics, rate_max_rad_s: Pair, now: list[float]) -> None:
        super().__init__(now)
        self.mechanics, self.rate_max_rad_s = mechanics, rate_max_rad_s

    def set_speed(self, pan_fraction: float, tilt_fraction: float, timeout_s: float) -> int:
        pan = pan_fraction * self.rate_max_rad_s[0]
        tilt = tilt_fraction * self.rate_max_rad_s[1]
        self.mechanics.schedule(self.now[0], lambda m: (m.pan.move_at(pan), m.tilt.move_at(tilt)))
        self.counters["commands"] += 1
        return self.now_ns

    def stop(self) -> int:
        self.mechanics.schedule(self.now[0], lambda m: (m.pan.hold(), m.tilt.hold()))
        self.counters["commands"] += 1
        return self.now_ns

    def query_position(self, between: Callable[[], None] | None = None) -> DevicePosition:
        self.mechanics.advance(self.now[0])
        pan, tilt = (round(a / VISCA_UNIT_RAD) * VISCA_UNIT_RAD for a in self.mechanics.encoder())
        return DevicePosition(pan, tilt, self.now_ns, self.now_ns)


def follow(
    head: SpeedHead,
    mechanics: HeadMechanics,
    now: list[float],
    setpoint: Callable[[float], Pair],
    seconds: float,
    from_s: float,
) -> list[tuple[float, Pair, Pair]]:
    """`head` driving `mechanics` after `setpoint(t)` for `seconds` on the virtual clock `now`:
    set-points and polls at 50 Hz, 10 ms apart. From `from_s` on, each 10 ms: the time, the
    head's true angles and the set-point then."""
    samples = []
    for i in range(round(seconds * 100)):
        now[0] = i * 0.01
        if i % 2:
            head.query_position()
        else:
            head.set_position(*setpoint(now[0]))
        mechanics.advance(now[0])
        if now[0] >= from_s:
            samples.append((now[0], mechanics.encoder(), setpoint(now[0])))
    return samples
