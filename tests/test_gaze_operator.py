"""An operator's park, search, hold and resume, through the gaze controller's `on_command`."""

from __future__ import annotations

import math

import pytest
from test_gaze_controller import (
    RIG_TEXT,
    Clock,
    detection,
    odometry,
    prediction,
    run_up,
)

from gazed.config import parse_rig
from gazed.gaze.controller import GazeController
from gazed.gaze.decision import Decision
from gazed.gaze.operator import order_for
from gazed.messages import GazeCommand

# a park pose away from straight ahead, so that parking is a move
RIG = parse_rig(RIG_TEXT.replace("[head]\n", "[head]\npark_pan_deg = 20\npark_tilt_deg = -5\n"))
PARK_RAD = (math.radians(20.0), math.radians(-5.0))


def send(c: GazeController, clock: Clock, name: str) -> Decision:
    """The command, then one tick: its decision."""
    request = GazeCommand(t_capture_ns=clock.wall_ns, command=name, request_id=f"test-{name}")
    c.on_command(request, clock.wall_ns, clock.mono_s)
    return c.tick(clock.wall_ns, clock.mono_s)


def pursuing(clock: Clock) -> GazeController:
    """A controller in pursuit with the head at the park pose (its search began there)."""
    c = GazeController(RIG, clock.mono_s)
    c.on_odometry(odometry(clock, 20.0, -5.0))
    assert c.tick(clock.wall_ns, clock.mono_s).transition.state == "search"
    clock.advance(0.02)
    run_up(c, clock, 330.0, 245.0, head_deg=(20.0, -5.0))
    c.on_detection(detection(clock, 330.0, 245.0, head_deg=(20.0, -5.0)))
    assert c.tick(clock.wall_ns, clock.mono_s).transition.state == "pursuit"
    return c


def test_park_goes_to_the_park_pose_and_stays_there_whatever_is_seen() -> None:
    clock = Clock()
    c = pursuing(clock)
    decision = send(c, clock, "park")
    t = decision.transition
    assert (t.previous, t.state, t.reason) == ("pursuit", "park", "operator: park")
    assert decision.demand.kind == "park"
    assert (decision.demand.pan_rad, decision.demand.tilt_rad) == pytest.approx(PARK_RAD)
    # parked, with a target in the fovea: the machine alone would search, then pursue it
    for _ in range(20):
        clock.advance(0.04)
        c.on_odometry(odometry(clock, 20.0, -5.0), clock.wall_ns)
        c.on_detection(detection(clock, 320.0, 240.0, head_deg=(20.0, -5.0)))
        c.on_prediction(prediction(clock, 22.0, -5.0, pan_rate_deg_s=10.0))
        decision = c.tick(clock.wall_ns, clock.mono_s)
        assert decision.transitions == ()
        assert decision.demand.kind == "park"
    assert c.state == "park"


def test_resume_after_park_searches_and_takes_up_the_target_in_view() -> None:
    clock = Clock()
    c = pursuing(clock)
    send(c, clock, "park")
    clock.advance(0.04)
    c.on_odometry(odometry(clock, 20.0, -5.0), clock.wall_ns)
    t = send(c, clock, "resume").transition
    assert (t.previous, t.state, t.reason) == ("park", "search", "operator: resume")
    clock.advance(0.5)  # the run of detections is seen after the search began
    run_up(c, clock, 330.0, 245.0, head_deg=(20.0, -5.0))
    c.on_detection(detection(clock, 330.0, 245.0, head_deg=(20.0, -5.0)))
    t = c.tick(clock.wall_ns, clock.mono_s).transition
    assert (t.state, t.reason) == ("pursuit", "target in the fovea")


def test_search_ends_a_park_and_searches_now() -> None:
    clock = Clock()
    c = pursuing(clock)
    send(c, clock, "park")
    clock.advance(0.04)
    decision = send(c, clock, "search")
    t = decision.transition
    assert (t.previous, t.state, t.reason) == ("park", "search", "operator: search")
    assert decision.demand.kind == "hold"  # search watches from a still head
    assert c.operator.override is None
    c2 = pursuing(Clock())  # from pursuit too
    t = send(c2, clock, "search").transition
    assert (t.previous, t.state, t.reason) == ("pursuit", "search", "operator: search")


def test_hold_keeps_the_head_still_and_the_estimates_coming_until_resume() -> None:
    clock = Clock()
    c = pursuing(clock)
    clock.advance(0.02)
    c.on_odometry(odometry(clock, 21.0, -4.0, rate_deg_s=10.0), clock.wall_ns)
    decision = send(c, clock, "hold")
    t = decision.transition
    assert (t.previous, t.state, t.reason) == ("pursuit", "hold", "operator: hold")
    assert decision.demand.kind == "hold"
    held_rad = (decision.demand.pan_rad, decision.demand.tilt_rad)
    assert held_rad == pytest.approx((math.radians(21.0), math.radians(-4.0)))
    # the target moves on and is lost from view for longer than lost_after_ms: still held
    for k in range(30):
        clock.advance(0.04)
        c.on_odometry(odometry(clock, 21.1, -4.0), clock.wall_ns)
        c.on_prediction(prediction(clock, 22.0 + 0.4 * k, -4.0, pan_rate_deg_s=10.0))
        decision = c.tick(clock.wall_ns, clock.mono_s)
        assert decision.transitions == ()
        assert decision.demand.kind == "hold"
        assert (decision.demand.pan_rad, decision.demand.tilt_rad) == pytest.approx(held_rad)
    assert c.state == "hold"
    # the estimates went on: the newest prediction is the one pursuit would follow
    assert c.pursuit.prediction.pan_rad == pytest.approx(math.radians(22.0 + 0.4 * 29))
    t = send(c, clock, "resume").transition
    assert (t.previous, t.state, t.reason) == ("hold", "search", "operator: resume")


def test_a_command_that_changes_nothing_is_answered_with_the_state_unchanged() -> None:
    clock = Clock()
    c = pursuing(clock)
    t = send(c, clock, "resume").transition  # already following
    assert (t.previous, t.state, t.reason) == ("pursuit", "pursuit", "operator: resume")
    assert c.state == "pursuit"
    send(c, clock, "park")
    clock.advance(0.02)
    decision = send(c, clock, "park")  # parked already
    assert [(s.previous, s.state, s.reason) for s in decision.transitions] == [
        ("park", "park", "operator: park")
    ]


def test_an_operators_command_ends_a_trace_and_a_trace_ends_the_override() -> None:
    clock = Clock()
    c = pursuing(clock)
    send(c, clock, "hold")
    clock.advance(0.02)
    trace = GazeCommand(t_capture_ns=clock.wall_ns, command="trace", request_id="line-1")
    c.on_command(trace, clock.wall_ns, clock.mono_s)
    assert c.state == "trace" and c.operator.override is None
    clock.advance(0.02)
    decision = send(c, clock, "park")
    assert [(s.previous, s.state) for s in decision.transitions] == [
        ("hold", "trace"),
        ("trace", "search"),
        ("search", "park"),
    ]
    assert decision.transitions[1].reason.startswith("trace ended: replaced by a new request")
    assert decision.trace is not None and decision.trace.request_id == "line-1"


@pytest.mark.parametrize(
    ("command", "state", "override", "expected"),
    [
        ("park", "pursuit", None, ("park", "park")),
        ("park", "hold", "hold", ("park", "park")),
        ("hold", "lost", None, ("hold", "hold")),
        ("hold", "park", "park", ("hold", "hold")),
        ("search", "park", "park", (None, "search")),
        ("search", "saccade", None, (None, "search")),
        ("resume", "hold", "hold", (None, "search")),
        ("resume", "park", "park", (None, "search")),
        ("resume", "park", None, (None, "park")),  # parking at start-up: nothing to end
        ("resume", "lost", None, (None, "lost")),
    ],
)
def test_orders(command: str, state: str, override: str | None, expected: tuple) -> None:
    order = order_for(command, state, override)
    assert (order.override, order.state) == expected
    assert order.reason == f"operator: {command}"


def test_an_unknown_command_is_refused_by_name() -> None:
    with pytest.raises(ValueError, match=r"'trace'.*park"):
        order_for("trace", "pursuit", None)
