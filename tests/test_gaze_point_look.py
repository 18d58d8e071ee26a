"""The gaze turns to an operator's held ground point outside the head's view (`point_look`)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from test_gaze_controller import Clock, odometry

from gazed.config import load_rig
from gazed.gaze.controller import GazeController
from gazed.geometry.ground import GroundGeometry
from gazed.messages import GazeSelect

SIM = load_rig(Path(__file__).resolve().parents[1] / "configs" / "sim.toml")
GEOMETRY = GroundGeometry.from_rig(SIM)


def held(point: tuple[float, float]) -> tuple[GazeController, Clock]:
    """A controller searching from the park pose, asked for a ground point no track explains."""
    clock = Clock()
    c = GazeController(SIM, clock.mono_s)
    c.on_odometry(odometry(clock, 0.0, 0.0))
    c.tick(clock.wall_ns, clock.mono_s)  # parked: search
    assert c.state == "search"
    c.on_select(GazeSelect(t_capture_ns=clock.wall_ns, ground_xy_m=point), clock.wall_ns)
    assert c.choice.pending is not None  # held: no track explains it
    clock.advance(0.02)
    return c, clock


def test_a_held_point_outside_the_view_draws_a_saccade_to_it() -> None:
    point = (8.0, 0.0)  # about 58° to the side of a 60° view
    pan, tilt = GEOMETRY.gaze_from_ground(*point)
    assert abs(pan) > math.radians(SIM.camera.hfov_deg / 2.0)
    c, clock = held(point)
    decision = c.tick(clock.wall_ns, clock.mono_s)
    assert c.state == "saccade" and c.counts["saccades"] == 1
    assert decision.demand is not None and decision.demand.kind == "position"
    assert (decision.demand.pan_rad, decision.demand.tilt_rad) == pytest.approx((pan, tilt))
    assert any("operator's point outside the view" in s.reason for s in decision.transitions)
    assert c.choice.pending is not None  # the point stays held for the person's track
    # one look per request: back in search, the same point draws no second saccade
    c.enter("search", "test", clock.wall_ns, clock.mono_s)
    c.on_odometry(odometry(clock, 0.0, 0.0))
    c.tick(clock.wall_ns, clock.mono_s)
    assert c.state == "search" and c.counts["saccades"] == 1


def test_a_held_point_in_view_draws_no_move() -> None:
    c, clock = held((0.5, 2.0))
    c.tick(clock.wall_ns, clock.mono_s)
    assert c.state == "search" and c.counts["saccades"] == 0
