"""The head link (`gazed.servo.head_link.HeadLink`) without a bus: on an emulated head at the far
end of a virtual line, on the line's own clock, and on a real pty. It connects, follows demands
and reports odometry; a step in the bus's receive thread only writes demands; a demand that
comes during a poll goes out between the poll's frames; no demand -> hold; a head without
position feedback gets dead-reckoned odometry; status on every change and once a second;
unanswered polls take the link down and it is reopened with backoff; close parks the head."""

from __future__ import annotations

import itertools
import math
import time
from pathlib import Path

import pytest
from conftest import poll_until
from servo_link_support import Demands, demand, link_rig, pan_setpoints_deg
from test_servo_line import VirtualLine

from gazed.messages import GazeDemand
from gazed.servo.head_link import BACKOFF_INITIAL_S, STATUS_PERIOD_S, HeadLink, LinkStep
from gazed.servo.pelco_d import EXTENDED
from gazed.servo.transport import LinkError
from gazed.sim.head_emulator import HeadEmulator
from services.runtime import Now

UNIT_RAD = math.radians(0.01)  # Pelco-D


class PluggableLine(VirtualLine):
    """A virtual line whose port can be pulled (`unplugged`: opening it fails) or whose head
    can fall silent; it notes when it was opened."""

    def __init__(self, rig) -> None:
        super().__init__(rig)
        self.unplugged = False
        self.silent = False
        self.opened_at: list[float] = []

    def connect(self) -> None:
        self.opened_at.append(self.now_s)
        if self.unplugged:
            raise LinkError("no such port")
        super().connect()

    def read(self, timeout_s: float) -> tuple[bytes, int]:
        if self.silent:  # the port blocks for the whole timeout
            self.now_s += max(0.0, timeout_s)
            return b"", self.wall_ns()
        return super().read(timeout_s)


class Link:
    """A head link on a `PluggableLine`, stepped on the line's clock."""

    def __init__(self, baud: int = 9600, demands: Demands | None = None, **servo: object) -> None:
        self.rig = link_rig(baud=baud, **servo)  # type: ignore[arg-type]
        self.line = PluggableLine(self.rig)
        self.demands = demands or Demands()
        self.commands: list[tuple[GazeDemand, int]] = []
        self.link = HeadLink(
            self.rig,
            self.demands.take,
            lambda command, t_ns: self.commands.append((command, t_ns)),
            transport=self.line,  # type: ignore[arg-type]
            mono_s=lambda: self.line.now_s,
            wall_ns=self.line.wall_ns,
            sleep=lambda s: self.line.run_until(self.line.now_s + s),
        )

    def step(self, after_s: float = 0.0, *demands: GazeDemand, immediate: bool = False) -> LinkStep:
        self.line.run_until(self.line.now_s + after_s)
        self.demands.put(*demands)
        return self.link.step(Now(self.line.wall_ns(), self.line.now_s, immediate))

    def run(self, seconds: float, keep_demanding: GazeDemand | None = None) -> list[LinkStep]:
        """Step when the link asks to, for `seconds`; a demand every step if given."""
        end_s = self.line.now_s + seconds
        steps = [self.step(0.0, *[keep_demanding] if keep_demanding else [])]
        while self.line.now_s < end_s:
            wait_s = min(max(steps[-1].wait_s, 1e-3), end_s - self.line.now_s)
            steps.append(self.step(wait_s, *[keep_demanding] if keep_demanding else []))
        return steps


def odometry(steps: list[LinkStep]):
    return [s.odometry for s in steps if s.odometry is not None]


def statuses(steps: list[LinkStep]):
    return [s.status for s in steps if s.status is not None]


def test_it_connects_follows_a_demand_and_reports_odometry_dated_by_the_head() -> None:
    link = Link(baud=115200)
    first = link.step()
    assert first.status is not None and first.status.link == "connected"
    assert first.status.holding
    assert first.odometry is not None  # polled as soon as connected
    assert math.degrees(first.odometry.pan_rad) == pytest.approx(5.0)  # the head, at park
    steps = link.run(1.0, keep_demanding=demand(20.0, -10.0))
    last = odometry(steps)[-1]
    assert abs(last.pan_rad - math.radians(20.0)) <= UNIT_RAD / 2 + 1e-9
    assert abs(last.tilt_rad - math.radians(-10.0)) <= UNIT_RAD / 2 + 1e-9
    assert not last.dead_reckoned
    assert last.t_ns <= link.line.wall_ns()  # when the head read it, before its reply came
    assert len(odometry(steps)) == pytest.approx(50, abs=3)  # 50 polls a second
    command, _ = link.commands[-1]
    assert (math.degrees(command.pan_rad), math.degrees(command.tilt_rad)) == pytest.approx(
        (20.0, -10.0)
    )
    assert link.link.counters()["commands"] > 1 and link.link.counters()["odometry"] > 1


def test_reply_deadlines_run_on_the_links_clock_not_the_machines(monkeypatch) -> None:
    """A loaded machine (here: its monotonic clock jumps a second per reading) does not time out
    replies that come in time on the link's own clock."""
    idle = Link()
    idle_steps = idle.run(0.5, keep_demanding=demand(20.0, -10.0))
    machine_s = itertools.count(start=1000.0, step=1.0)
    monkeypatch.setattr(time, "monotonic", lambda: next(machine_s))
    loaded = Link()
    steps = loaded.run(0.5, keep_demanding=demand(20.0, -10.0))
    assert loaded.link.counters()["timeouts"] == 0 and loaded.link.last_error is None
    assert [r.pan_rad for r in odometry(steps)] == [r.pan_rad for r in odometry(idle_steps)]
    assert len(odometry(steps)) > 10


def test_an_immediate_step_writes_the_demand_and_nothing_slow() -> None:
    link = Link()
    result = link.step(0.0, demand(10.0, 0.0), immediate=True)
    assert link.line.opened_at == []  # no connecting in the receive thread
    assert result.odometry is None and link.commands == []
    assert link.link.counters()["demands"] == 1  # counted, dropped: no link yet
    link.step()  # the loop's own step connects
    assert link.line.opened_at != []
    result = link.step(0.05, demand(10.0, 0.0), immediate=True)  # a poll is due by now
    assert result.odometry is None  # not polled
    assert len(link.commands) == 1  # but the demand is written
    assert link.step().odometry is not None  # the loop's own step polls


class DuringPoll(Demands):
    """Yields its demands only once the pan query has been written to `written`: as if they
    arrived while the head was answering it."""

    def __init__(self) -> None:
        super().__init__()
        self.written: list[bytes] = []

    def take(self) -> list[GazeDemand]:
        asked = self.written and self.written[-1][3] == EXTENDED["query_pan"]
        return super().take() if asked else []


def test_a_demand_during_a_poll_goes_out_between_its_frames() -> None:
    demands = DuringPoll()
    link = Link(demands=demands)
    demands.written = link.line.written
    link.step()
    link.demands.put(demand(15.0, 0.0))
    written_before = len(link.line.written)
    link.step(0.05)  # a poll is due
    commands = [frame[3] for frame in link.line.written[written_before:]]
    assert commands == [
        EXTENDED["query_pan"],
        EXTENDED["set_pan"],
        EXTENDED["set_tilt"],
        EXTENDED["query_tilt"],
    ]
    assert len(link.commands) == 1


def test_no_fresh_demand_within_the_timeout_holds_and_says_so() -> None:
    link = Link()
    link.step()
    moving = link.step(0.01, demand(0.0, 0.0, "pursuit", 30.0))
    assert moving.status is not None and not moving.status.holding  # a change: said at once
    steps = link.run(0.5)
    held = [s for s in statuses(steps) if s.holding]
    assert held and held[0].t_ns - moving.status.t_ns == pytest.approx(0.3e9, abs=0.03e9)
    assert link.link.setpoints.settled
    # at rest soon after the timeout, not following the stale rate (which is at 20° by now)
    assert pan_setpoints_deg(link.line.written)[-1] < 5.0 + 30.0 * 0.31 + 1.0


def test_status_on_every_change_and_once_a_second() -> None:
    link = Link()
    assert link.step().status is not None
    assert link.step(0.1).status is None
    assert link.step(STATUS_PERIOD_S - 0.1).status is not None
    assert link.step(0.1).status is None


def test_dead_reckoned_odometry_without_position_feedback() -> None:
    link = Link(position_feedback=False)
    first = link.step()
    assert first.status is not None and first.status.dead_reckoned
    assert pan_setpoints_deg(link.line.written) == [5.0]  # sent to park on connecting
    steps = link.run(0.5, keep_demanding=demand(20.0, -10.0))
    last = odometry(steps)[-1]
    assert last.dead_reckoned
    assert (last.pan_rad, last.tilt_rad) == link.link.setpoints.advance(link.line.now_s)
    assert math.degrees(last.pan_rad) == pytest.approx(20.0)


def test_unanswered_polls_take_the_link_down_and_backoff_paces_the_reopening() -> None:
    link = Link()
    link.step()
    link.line.silent = True
    for _ in range(3):
        result = link.step(0.02)
    assert result.status is not None and result.status.link == "down"
    assert link.link.counters()["timeouts"] == 3
    lost_s = link.line.now_s
    link.line.silent = False
    link.line.unplugged = True
    while len(link.line.opened_at) < 7:
        link.step(max(link.step().wait_s, 1e-3))
    attempts = [lost_s, *link.line.opened_at[1:]]
    delays = [round(b - a, 6) for a, b in itertools.pairwise(attempts)]
    assert delays == [0.25, 0.5, 1.0, 2.0, 2.0, 2.0]  # doubling up to reconnect_max_s
    link.line.unplugged = False
    steps = link.run(2.5)
    assert statuses(steps)[-1].link == "connected"
    assert statuses(steps)[-1].reconnects == 1
    # connected again: the next loss waits the initial delay again
    link.line.silent = True
    for _ in range(3):
        link.step(0.02)
    lost_s, opened = link.line.now_s, len(link.line.opened_at)
    link.line.silent = False
    while len(link.line.opened_at) == opened:
        link.step(max(link.step().wait_s, 1e-3))
    assert link.line.opened_at[-1] - lost_s == pytest.approx(BACKOFF_INITIAL_S)


def test_immediate_steps_never_reopen_the_link() -> None:
    link = Link()
    link.line.unplugged = True
    link.step()
    for _ in range(20):
        link.step(0.1, demand(0.0, 0.0), immediate=True)
    assert len(link.line.opened_at) == 1


def test_close_parks_the_head_and_reports_the_link_down() -> None:
    link = Link()
    link.run(0.5, keep_demanding=demand(30.0, 10.0))
    status = link.link.close()
    assert status.link == "down" and not link.line.is_connected
    assert pan_setpoints_deg(link.line.written)[-1] == pytest.approx(5.0)
    link.line.run_until(link.line.now_s + 1.0)
    pose = link.line.line.mechanics.pose_at(link.line.now_s)
    assert math.degrees(pose.pan_rad) == pytest.approx(5.0, abs=0.01)


def run_real(link: HeadLink, demands: Demands, until, keep_demanding=None, timeout_s=5.0):
    """Step the link on real time as the process loop would, until `until(step)`."""

    def step():
        if keep_demanding is not None:
            demands.put(keep_demanding)
        result = link.step(Now.read())
        time.sleep(min(result.wait_s, 0.005))
        return result if until(result) else None

    return poll_until(step, timeout_s, interval_s=0.0)


def test_on_a_real_pty_it_follows_loses_the_port_reconnects_and_parks(tmp_path: Path) -> None:
    rig = link_rig(port=str(tmp_path / "head"), protocol="dynamixel", baud=1000000)
    demands = Demands()
    link = HeadLink(rig, demands.take, lambda *_: None)
    with HeadEmulator(rig) as head:
        run_real(link, demands, lambda s: link.link == "connected")
        run_real(
            link,
            demands,
            lambda s: s.odometry is not None and abs(s.odometry.pan_rad - math.radians(-25)) < 0.01,
            keep_demanding=demand(-25.0, 5.0),
        )
    run_real(link, demands, lambda s: s.status is not None and s.status.link == "down")
    with HeadEmulator(rig) as head:
        run_real(link, demands, lambda s: s.status is not None and s.status.reconnects == 1)
        status = link.close()
        assert status.link == "down"
        poll_until(lambda: head.settled, timeout_s=5.0)
        parked = head.pose_at(time.monotonic())
        assert math.degrees(parked.pan_rad) == pytest.approx(5.0, abs=0.1)
        assert math.degrees(parked.tilt_rad) == pytest.approx(-5.0, abs=0.1)
