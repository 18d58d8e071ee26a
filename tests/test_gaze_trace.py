"""The gaze controller's trace state, on scripted edge observations: it samples the edge point,
steps along the edge, turns back at a bend to trace the other way, and reports the samples."""

from __future__ import annotations

import itertools
import math

import pytest

from gazed.config import parse_rig
from gazed.gaze.controller import GazeController
from gazed.geometry.camera import CameraModel
from gazed.messages import EdgeObservation, GazeCommand, HeadPose, Odometry

RIG = parse_rig('[rig]\nname = "t"\n[gaze]\nsettle_ms = 0\n')
CAMERA = CameraModel.from_section(RIG.camera)
CX, CY = CAMERA.K[0, 2], CAMERA.K[1, 2]
F = CAMERA.K[0, 0]


def edge(
    t_ns: int, head_rad: tuple[float, float], dv_px: float, found: bool, turn_deg: float
) -> EdgeObservation:
    """An edge through the image centre (offset dv_px down), running left-right, its next
    points 12 px either way."""
    return EdgeObservation(
        t_capture_ns=t_ns,
        seq=0,
        found=found,
        u_px=CX,
        v_px=CY + dv_px,
        ahead_px=(CX + 12.0, CY + dv_px),
        behind_px=(CX - 12.0, CY + dv_px),
        turn_rad=math.radians(turn_deg),
        head=HeadPose(pan_rad=head_rad[0], tilt_rad=head_rad[1]),
    )


class Loop:
    """The controller with a head that is wherever it was last sent, and a clock."""

    def __init__(self) -> None:
        self.wall_ns = 10**18
        self.mono_s = 50.0
        self.c = GazeController(RIG, self.mono_s)
        self.head = (0.0, 0.0)
        self.c.on_odometry(self._odometry())
        self.tick()

    def _odometry(self) -> Odometry:
        return Odometry(t_capture_ns=self.wall_ns, pan_rad=self.head[0], tilt_rad=self.head[1])

    def tick(self):
        self.wall_ns += 20_000_000
        self.mono_s += 0.02
        decision = self.c.tick(self.wall_ns, self.mono_s)
        if decision.demand is not None and decision.demand.kind == "position":
            self.head = (decision.demand.pan_rad, decision.demand.tilt_rad)  # an instant head
        self.c.on_odometry(self._odometry())
        return decision

    def look(self, dv_px: float = 0.0, found: bool = True, turn_deg: float = 0.0):
        self.c.on_edge(edge(self.wall_ns + 1, self.head, dv_px, found, turn_deg))
        return self.tick()


def settle(loop: Loop) -> None:
    for _ in range(3):
        loop.tick()


def test_traces_both_ways_and_reports_the_samples() -> None:
    loop = Loop()
    command = GazeCommand(
        t_capture_ns=loop.wall_ns, command="trace", request_id="r1", pan_rad=0.1, tilt_rad=-0.2
    )
    loop.c.on_command(command, loop.wall_ns, loop.mono_s)
    first = loop.tick()
    assert first.transition.state == "trace"
    assert (first.demand.pan_rad, first.demand.tilt_rad) == pytest.approx((0.1, -0.2))
    settle(loop)
    pans = []
    for _ in range(4):  # four looks along a straight edge: each steps "ahead" (pan grows)
        pans.append(loop.head[0])
        loop.look()
        settle(loop)
    assert all(b > a for a, b in itertools.pairwise(pans))
    step = pans[1] - pans[0]
    assert step == pytest.approx(math.atan(12.0 / F), rel=0.05)
    loop.look(dv_px=30.0)  # off the line: one bad look is stepped over...
    settle(loop)
    decision = loop.look(dv_px=60.0)  # ...two in a row: the edge turned; back to the start
    assert (loop.head[0], loop.head[1]) == pytest.approx((pans[0], -0.2), abs=1e-9)
    assert decision.trace is None
    settle(loop)
    start = loop.head[0]
    loop.look()
    settle(loop)
    assert loop.head[0] < start  # now the other way
    for _ in range(RIG.gaze.trace_misses):
        decision = loop.look(found=False)
    assert decision.trace is not None
    result = decision.trace
    assert result.request_id == "r1"
    assert result.reason == "the edge turned; then the edge was lost"
    assert len(result.samples_rad) == 4 + 1  # 4 the first way, the start again on the way back
    assert decision.transition.state == "search"


def test_a_corner_ends_a_leg_only_when_two_looks_agree() -> None:
    loop = Loop()
    loop.c.on_command(
        GazeCommand(
            t_capture_ns=loop.wall_ns,
            command="trace",
            request_id="r2",
            pan_rad=0.0,
            tilt_rad=0.0,
            max_samples=3,
        ),
        loop.wall_ns,
        loop.mono_s,
    )
    loop.tick()
    settle(loop)
    loop.look()
    settle(loop)
    loop.look(turn_deg=50.0)
    assert loop.c.tracer.job is not None and loop.c.tracer.job.corner_looks == 1
    loop.look()  # the second look sees a straight edge: not a corner
    settle(loop)
    decision = loop.look()
    assert decision.trace is not None and decision.trace.reason == "enough samples"
    assert len(decision.trace.samples_rad) == 3


def test_stop_ends_a_trace() -> None:
    loop = Loop()
    loop.c.on_command(
        GazeCommand(
            t_capture_ns=loop.wall_ns, command="trace", request_id="r3", pan_rad=0.0, tilt_rad=0.0
        ),
        loop.wall_ns,
        loop.mono_s,
    )
    loop.tick()
    loop.c.on_command(
        GazeCommand(t_capture_ns=loop.wall_ns, command="stop", request_id="r3"),
        loop.wall_ns,
        loop.mono_s,
    )
    decision = loop.tick()
    assert decision.trace.reason == "stopped by request" and decision.trace.samples_rad == ()
    assert loop.c.state == "search"
