"""The zoom lens as the `servo` process drives it: the latest demand's zoom position, moved no
faster than `[head] zoom_rate_max_s`, written when it has changed, and read back with each
odometry poll.

A zoom is slow (seconds across its range) beside pan and tilt, and each write is a command the
line has to carry, so the set-point is written at most every `ZOOM_COMMAND_PERIOD_S`, and only
when it has moved by at least `ZOOM_STEP`. The set-point slews towards the demand at the rate
limit, so the lens never receives a jump it would take faster than the rig allows.

A zoom command never waits for the head to take it: while the head has no room for a command
(both VISCA sockets hold commands) the write is left for a later step, which writes the newest
set-point then (counted as `held_for_a_socket`). Held for the driver's read timeout, the
completion that would have freed a socket is taken as lost (`RoomWait`, as the set-point writer
takes it): the set-point goes to the driver. Without that, a socket the codec still
counts busy after its completion went astray keeps the lens where it is for good: the pan-tilt
takes the one socket left, and cancels any zoom that gets into it. The link writes the
pan-tilt set-point before the zoom in each step, so a socket that frees goes to the pan-tilt
first. A fresh demand never waits behind the zoom either: pursuit keeps a move in one socket,
so a zoom in the other leaves a new set-point no room until the zoom ends, which a camera may
report only once the lens has arrived. A set-point with a fresh demand that finds no room
cancels the move it supersedes first (`SetpointWriter`), and only when that frees no socket
asks the zoom to yield (`yield_socket`): the zoom's command, if it still holds its socket, is
cancelled (VISCA Cancel, which needs no socket; the lens stops where it is, counted as
`cancelled`), and the newest zoom set-point goes out again in the link's next step, after the
pan-tilt's.
"""

from __future__ import annotations

from collections.abc import Hashable
from typing import Protocol

from gazed.servo.driver import RoomWait, cancel_acked, last_acked, takes_now

ZOOM_COMMAND_PERIOD_S = 0.1
ZOOM_STEP = 1.0 / 1024  # below any lens's repeatability, above a VISCA unit at 0x4000


class ZoomDevice(Protocol):
    """A head that drives and reads a zoom (`ServoDriver` on a codec that zooms, the digital
    head)."""

    def set_zoom(self, zoom: float) -> int: ...

    def query_zoom(self) -> float: ...


class ZoomDrive:
    """One head's zoom lens behind `driver`."""

    def __init__(self, driver: ZoomDevice, rate_max_s: float) -> None:
        self.driver = driver
        self.rate_max_s = rate_max_s
        self.target: float | None = None
        self.setpoint: float | None = None
        self.position: float | None = None
        self.writes = 0
        self.held_for_a_socket = 0
        self.cancelled = 0
        self._executing: Hashable | None = None  # the acknowledgement of the last zoom command
        self._written: float | None = None
        self._t_s: float | None = None
        self._next_write_s = 0.0
        self._room = RoomWait(driver)  # the due set-point waits for a socket

    def demand(self, zoom: float | None) -> None:
        """A demand's zoom (None leaves the zoom where it is going)."""
        if zoom is not None:
            self.target = min(max(zoom, 0.0), 1.0)

    def reset(self, position: float) -> None:
        """The link is (re)opened with the lens at `position`: the set-point starts there."""
        self.position = self.setpoint = self._written = position
        self._t_s = None
        self._executing = None
        self._room.end()

    def write(self, mono_s: float) -> None:
        """Slew the set-point towards the demand and write it when due (raises what the driver
        raises)."""
        if self.target is None or self.setpoint is None:
            return
        dt_s = 0.0 if self._t_s is None else mono_s - self._t_s
        self._t_s = mono_s
        step = self.rate_max_s * dt_s
        self.setpoint += min(max(self.target - self.setpoint, -step), step)
        moved = self._written is None or abs(self.setpoint - self._written) >= ZOOM_STEP
        landing = self.setpoint == self.target and self.setpoint != self._written
        if mono_s < self._next_write_s or not (moved or landing):
            self._room.end()  # nothing is due: nothing waits
            return
        if not takes_now(self.driver) and not self._room.expired(mono_s):
            self.held_for_a_socket += 1
            self._room.hold(mono_s)
            return
        self._room.end()
        self.driver.set_zoom(self.setpoint)
        self._executing = last_acked(self.driver)
        self._written = self.setpoint
        self.writes += 1
        self._next_write_s = mono_s + ZOOM_COMMAND_PERIOD_S

    def yield_socket(self) -> bool:
        """Cancel the zoom's command if it still holds a socket (a pan-tilt set-point waits for
        one); True when it was cancelled. The newest set-point is written again when due."""
        if self._executing is None:
            return False
        executing, self._executing = self._executing, None
        if not cancel_acked(self.driver, executing):
            return False
        self.cancelled += 1
        self._written = None  # the lens stopped short: the newest set-point goes out again
        self._next_write_s = 0.0
        return True

    def read(self) -> float:
        """The lens's present position (raises what the driver raises)."""
        self.position = self.driver.query_zoom()
        return self.position
