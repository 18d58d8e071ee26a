"""Demands to set-points written to the head (`gazed.servo.setpoint_writer`), on an emulated
Pelco-D line at 9600 baud and the line's own clock: a fresh demand written at once, limited,
and handed on with the moment its bytes were written; set-points every command period, never a
jump; never one queued behind more than the set-point on the line; hold when the demands stop;
demands without a link counted and dropped."""

from __future__ import annotations

import math

import pytest
from servo_link_support import Demands, demand, link_rig, pan_setpoints_deg, pan_steps_deg
from test_servo_line import VirtualLine

from gazed.messages import GazeDemand
from gazed.servo import make_codec
from gazed.servo.driver import ServoDriver
from gazed.servo.setpoint_writer import SetpointWriter

SETPOINT_LINE_S = 14 * 10 / 9600  # a Pelco-D set-point: two 7-byte frames
UNIT_DEG = 0.01


class Writer:
    """A writer on a virtual line, connected, at rest at park."""

    def __init__(self, command_rate_hz: float = 50.0) -> None:
        rig = link_rig()
        self.line = VirtualLine(rig)
        self.driver = ServoDriver(
            make_codec("pelco-d", **rig.servo_params()), self.line, 0.05, lambda: self.line.now_s
        )
        self.driver.connect()
        self.demands = Demands()
        self.commands: list[tuple[GazeDemand, int]] = []
        self.writer = SetpointWriter(
            rig.head,
            self.driver,
            self.demands.take,
            lambda command, t_ns: self.commands.append((command, t_ns)),
            command_period_s=1.0 / command_rate_hz,
            command_timeout_s=0.3,
            t_s=self.line.now_s,
        )
        self.writer.reset(*rig.head.park_rad, self.line.now_s)

    def step(self, t_s: float, *demands: GazeDemand) -> None:
        """As the head link steps: take the demands, check the timeout, write what is due."""
        self.line.run_until(t_s)
        self.demands.put(*demands)
        self.writer.take_demands(t_s, executable=True)
        self.writer.check_hold(t_s)
        self.writer.write(t_s)


def test_a_fresh_demand_is_written_at_once_limited_and_handed_on() -> None:
    w = Writer()
    t0 = w.line.now_s
    w.step(t0, demand(75.0, 0.0))  # beyond the 60° limit
    assert len(w.commands) == 1
    command, t_ns = w.commands[0]
    assert t_ns == w.line.wall_ns()  # the moment its bytes were written
    assert math.degrees(command.pan_rad) == pytest.approx(60.0 - UNIT_DEG)  # one unit inside
    assert [stage for stage, _ in command.stamps] == ["test"]
    assert pan_setpoints_deg(w.line.written) == [5.0]  # the set-point, at park yet: no jump
    assert w.writer.counts == {
        "commands": 1,
        "demands": 1,
        "held_for_the_line": 0,
        "held_for_a_socket": 0,
        "superseded": 0,
    }
    assert w.writer.limiter.joint_clamps == 1
    assert not w.writer.holding


def test_set_points_every_period_never_a_jump_and_none_once_there() -> None:
    w = Writer(command_rate_hz=50.0)
    t0 = w.line.now_s
    w.step(t0, demand(40.0, 0.0))
    for k in range(1, 40):
        w.step(t0 + 0.02 * k)
    pans = pan_setpoints_deg(w.line.written)
    steps = pan_steps_deg(w.line.written)
    assert all(0 <= step <= 300.0 * 0.02 + UNIT_DEG for step in steps), steps
    assert pans[-1] == pytest.approx(40.0)
    written = len(pans)
    for k in range(40, 45):  # there and settled: nothing more to write
        w.step(t0 + 0.02 * k)
    assert len(pan_setpoints_deg(w.line.written)) == written
    assert len(w.commands) == 1  # one fresh demand, one command handed on


def test_no_set_point_queues_behind_more_than_the_one_on_the_line() -> None:
    """A fresh pursuit demand every ms at 1000 set-points a second, where one takes 15 ms on
    the line: set-points wait, counted, and the line never holds more than two of them."""
    w = Writer(command_rate_hz=1000.0)
    t0 = w.line.now_s
    busiest_s = 0.0
    for k in range(500):
        t = t0 + 0.001 * k
        w.step(t, demand(-30.0 + 10.0 * k * 0.001, 0.0, "pursuit", 10.0))
        busiest_s = max(busiest_s, w.line.line_busy_s())
    assert w.writer.counts["held_for_the_line"] > 0
    assert busiest_s <= 2 * SETPOINT_LINE_S + 1e-9
    assert w.writer.counts["commands"] < 500 * 0.001 / SETPOINT_LINE_S + 2


def test_no_fresh_demand_within_the_timeout_holds() -> None:
    w = Writer()
    t0 = w.line.now_s
    w.step(t0, demand(0.0, 0.0, "pursuit", 30.0))
    assert w.writer.wake_times_s()[-1] == pytest.approx(t0 + 0.3)  # the timeout is a wake-up
    w.step(t0 + 0.29)
    assert not w.writer.holding
    w.step(t0 + 0.31)
    assert w.writer.holding
    for k in range(1, 30):  # braking to rest, then nothing more to write
        w.step(t0 + 0.31 + 0.02 * k)
    assert w.writer.setpoints.settled
    assert w.writer.wake_times_s() == []
    pans = pan_setpoints_deg(w.line.written)
    assert pans[-1] < 5.0 + 30.0 * 0.31 + 1.0  # stopped soon after the timeout


def test_demands_without_a_link_are_counted_and_dropped() -> None:
    w = Writer()
    t0 = w.line.now_s
    w.demands.put(demand(30.0, 0.0))
    w.writer.take_demands(t0, executable=False)
    w.writer.write(t0)
    assert w.writer.counts["demands"] == 1
    assert w.line.written == [] and w.commands == []
    assert w.writer.holding


def test_a_demand_between_a_polls_frames_goes_out_at_once_and_nothing_else_does() -> None:
    w = Writer()
    t0 = w.line.now_s
    w.writer.write_fresh(t0)
    assert w.line.written == []
    w.demands.put(demand(10.0, 0.0))
    w.writer.write_fresh(t0)
    assert len(w.commands) == 1 and len(pan_setpoints_deg(w.line.written)) == 1


def test_where_a_head_without_feedback_is_sent_when_the_link_opens() -> None:
    rig = link_rig()
    line = VirtualLine(rig)
    driver = ServoDriver(
        make_codec("pelco-d", **rig.servo_params()), line, 0.05, lambda: line.now_s
    )
    writer = SetpointWriter(rig.head, driver, list, lambda *_: None, 0.02, 0.3, line.now_s)
    assert writer.start_point(line.now_s) == rig.head.park_rad  # nothing written yet
    writer.reset(0.1, -0.1, line.now_s)
    assert writer.start_point(line.now_s + 1.0) == (0.1, -0.1)  # where it was last sent
