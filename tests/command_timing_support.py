"""The benches' timing of a head's commands (`tests/bench/onvif_io.py`, `visca_io.py`): how many
a second it sustains back to back, and how long from a command to the first position reading
that shows it."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Protocol

from gazed.servo.driver import DevicePosition


class Head(Protocol):
    """A head that reports its position and stops (a `ServoDriver`, an `OnvifHead`)."""

    def query_position(self) -> DevicePosition: ...

    def stop(self) -> int: ...


def rate_hz(call: Callable[[int], object], count: int) -> float:
    """`call(i)` for i in 0..count-1, back to back: calls per second."""
    started = time.perf_counter()
    for i in range(count):
        call(i)
    return count / (time.perf_counter() - started)


def command_to_reading_ms(
    head: Head, send: Callable[[int], object], count: int, wait_s: float = 2.0
) -> tuple[list[float], int]:
    """For each of `count` commands `send(i)`: from sending it to the first reading that differs
    from the last before it; the head is stopped after each. Also how many commands no reading
    showed within `wait_s` (they are left out of the times).

    The head is stopped as soon as it moves, so it stays between the targets of moves that
    alternate between two far apart; a move to where it already rests (within the device's
    step) shows no change, and is what `wait_s` counts."""
    times, unseen = [], 0
    for i in range(count):
        before = head.query_position().pan_rad
        started = time.perf_counter()
        send(i)
        while abs(head.query_position().pan_rad - before) < 1e-9:
            if time.perf_counter() - started > wait_s:
                unseen += 1
                break
        else:
            times.append((time.perf_counter() - started) * 1e3)
        head.stop()
    return times, unseen
