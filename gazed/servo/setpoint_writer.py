"""Demands to set-points written to the head: the `servo` process's command path.

Every demand is limited (`DemandLimiter`: non-finite refused, joint limits — brought in by one
device unit, so rounding never crosses them — and rate limits clamped, all counted) and
becomes the target of the set-point generator, whose set-points — never a jump — are written at
once for a fresh demand and every command period while a move is under way — but not behind a
whole set-point still waiting for the serial line (the newest then replaces it, counted as
`held_for_the_line`). No fresh demand within the command timeout -> hold (decelerate to
rest). Each fresh demand, as limited, goes to `on_command` the moment its bytes are written.

A set-point never waits for the head to take it. While the head has no room for a command (both
VISCA sockets hold commands, a move and a zoom), one that carries a fresh demand first cancels
the move it supersedes, if that still holds its socket (counted as `superseded`: the new
set-point replaces its target, and makes that refuse a new move while one runs need the cancel
anyway), and only then asks `make_room()` (the link's zoom cancels its command): new
information does not wait, and the zoom is not cut short for a move already out of date. A
set-point of the generator alone, or one still without room, is held, counted once as
`held_for_a_socket`, and the writer looks again every `ROOM_RETRY_S`; the set-point then written
is the one due at that moment, with the newest demand. Held for the driver's read timeout, the
completions that would have freed a socket are taken as lost (`RoomWait`): the set-point goes to
the driver, which forgets the sockets and lets the head answer for itself.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Hashable, Iterable

from gazed.config import HeadSection
from gazed.geometry.kinematics import device_from_joint
from gazed.messages import GazeDemand
from gazed.servo.driver import RoomWait, ServoDriver, cancel_acked, last_acked, takes_now
from gazed.servo.limits import DemandLimiter, Target
from gazed.servo.setpoints import SetpointGenerator

# A socket frees when a command ends, which the host cannot see coming; a look costs one read
# that does not wait. Looking every millisecond, well inside a set-point period and the head's
# response time, uses a freed socket before the delay matters.
ROOM_RETRY_S = 0.001


class SetpointWriter:
    """Demands pulled from `demands()`, set-points written through `driver`, on the caller's
    monotonic clock (seconds)."""

    def __init__(
        self,
        head: HeadSection,
        driver: ServoDriver,
        demands: Callable[[], Iterable[GazeDemand]],
        on_command: Callable[[GazeDemand, int], None],
        command_period_s: float,
        command_timeout_s: float,
        t_s: float,
    ) -> None:
        self.head = head
        self.driver = driver
        self._demands = demands
        self._on_command = on_command
        self.command_period_s = command_period_s
        self.command_timeout_s = command_timeout_s
        inset_rad = driver.codec.resolution_rad
        self.limiter = DemandLimiter(head, inset_rad)
        self.setpoints = SetpointGenerator(head, t_s, inset_rad)
        self.holding = True
        self.counts = {
            "commands": 0,
            "demands": 0,
            "held_for_the_line": 0,
            "held_for_a_socket": 0,
            "superseded": 0,
        }
        self.write_ms = 0.0
        self._next_command_s = 0.0
        self._last_demand_s: float | None = None
        self._written: tuple[float, float] | None = None
        self._fresh: GazeDemand | None = None  # the newest demand, as limited, not yet written
        self._setpoint_line_s = 0.0  # how long the last set-point's bytes took on the line
        self._room = RoomWait(driver)  # the due set-point waits for the head to have room
        self._executing: Hashable | None = None  # the acknowledgement of the last set-point
        self.make_room: Callable[[], bool] = lambda: False  # True when it freed a socket

    def start_point(self, t_s: float) -> tuple[float, float]:
        """Where a head that cannot report its position is sent when the link opens: the
        set-point if one was written before, else park."""
        return self.setpoints.advance(t_s) if self._written else self.head.park_rad

    def reset(self, pan_rad: float, tilt_rad: float, t_s: float) -> None:
        """At rest where the head is (the link was just opened), holding."""
        self.setpoints.reset(pan_rad, tilt_rad, t_s)
        self._written = (pan_rad, tilt_rad)
        self._executing = None
        self.holding = True
        self._last_demand_s = None
        self._fresh = None

    def wake_times_s(self) -> list[float]:
        """When a set-point is next due and when the demands time out, where either applies."""
        times = []
        if not self.setpoints.settled or self._fresh is not None or self._room.holding:
            times.append(self._next_command_s)
        if not self.holding and self._last_demand_s is not None:
            times.append(self._last_demand_s + self.command_timeout_s)
        return times

    def take_demands(self, t_s: float, executable: bool) -> None:
        """Limit and count every demand waiting; track the newest unless not `executable`
        (no link: it is dropped)."""
        latest: tuple[GazeDemand, Target] | None = None
        for demand in self._demands():
            self.counts["demands"] += 1
            target = self.limiter.limit(demand)
            if target is not None:
                latest = (demand, target)
        if latest is None or not executable:
            return
        demand, target = latest
        self.setpoints.track(target, t_s)
        self._last_demand_s = t_s
        self._fresh = demand.model_copy(
            update={
                "pan_rad": target.pan_rad,
                "tilt_rad": target.tilt_rad,
                "pan_rate_rad_s": target.pan_rate_rad_s,
                "tilt_rate_rad_s": target.tilt_rate_rad_s,
            }
        )
        self._next_command_s = t_s
        self.holding = False

    def check_hold(self, t_s: float) -> None:
        """Hold once no fresh demand came within the command timeout."""
        if self.holding or self._last_demand_s is None:
            return
        if t_s - self._last_demand_s > self.command_timeout_s:
            self.setpoints.hold(t_s)
            self.holding = True
            self._next_command_s = t_s

    def write(self, t_s: float) -> None:
        """The set-point at `t_s`, if one is due and the line has room for it."""
        if t_s < self._next_command_s:
            return
        # a set-point may queue behind the one on the line, not behind a whole one more: on a
        # line that cannot carry them all, the newest replaces those not yet sent
        transport = self.driver.transport
        waiting_s = transport.line_busy_s() - self._setpoint_line_s
        if waiting_s > 0:
            self._next_command_s = t_s + waiting_s
            self.counts["held_for_the_line"] += 1
            return
        setpoint = self.setpoints.advance(t_s)
        if setpoint == self._written and self._fresh is None:
            self._next_command_s = t_s + self.command_period_s
            return
        device_rad = device_from_joint(self.head, *setpoint)
        if self._must_hold(t_s):
            if self._room.hold(t_s):
                self.counts["held_for_a_socket"] += 1
            self._next_command_s = t_s + ROOM_RETRY_S
            return
        self._room.end()
        started = time.perf_counter()
        busy_before_s = transport.line_busy_s()
        t_ns = self.driver.set_position(*device_rad)
        self.write_ms = (time.perf_counter() - started) * 1000.0
        self._setpoint_line_s = max(0.0, transport.line_busy_s() - busy_before_s)
        self._executing = last_acked(self.driver)
        self._written = setpoint
        self.counts["commands"] += 1
        if self._fresh is not None:
            self._on_command(self._fresh, t_ns)
            self._fresh = None
        self._next_command_s = t_s + self.command_period_s

    def _must_hold(self, t_s: float) -> bool:
        """No room for the set-point, none made for a fresh demand, and not held past the
        driver's read timeout. The generator's own set-points wait for the zoom to end rather
        than cut it short: they come every command period, and cancelling the zoom for each
        would cost the line two more exchanges a period and keep the lens stopping."""
        if takes_now(self.driver):
            return False
        if self._fresh is not None and self._cancel_superseded() and takes_now(self.driver):
            return False
        if self._fresh is not None and self.make_room() and takes_now(self.driver):
            return False
        return not self._room.expired(t_s)

    def _cancel_superseded(self) -> bool:
        """Cancel the last set-point's move if it still holds its socket; True when it was."""
        if self._executing is None:
            return False
        executing, self._executing = self._executing, None
        if not cancel_acked(self.driver, executing):
            return False
        self.counts["superseded"] += 1
        return True

    def write_fresh(self, t_s: float) -> None:
        """A demand that came while the head was answering a poll goes out now, not after the
        whole poll (Pelco-D asks pan and tilt in two exchanges)."""
        self.take_demands(t_s, executable=True)
        if self._fresh is not None:
            self.write(t_s)
