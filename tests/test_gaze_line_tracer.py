"""The line tracer (gazed.gaze.trace) on its own: a head that is wherever the tracer last sent
it, scripted edge observations, and the samples, steps and leg endings they give."""

from __future__ import annotations

import math

import pytest
from test_gaze_trace import edge

from gazed.config import parse_rig
from gazed.gaze.trace import LineTracer
from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.zoom import ZoomLens
from gazed.messages import GazeCommand, Odometry

RIG = parse_rig('[rig]\nname = "t"\n[gaze]\nsettle_ms = 40\ntrace_misses = 2\n')
CAMERA = CameraModel.from_section(RIG.camera)
KINEMATICS = HeadKinematics.from_section(RIG.head)
CX, CY = CAMERA.K[0, 2], CAMERA.K[1, 2]
F = CAMERA.K[0, 0]
STEP_RAD = math.atan(12.0 / F)  # the edge's next point is 12 px ahead of the centre
PAN_MAX_RAD = 0.5


class Bench:
    """A tracer, a clock, and an instant head at the tracer's goal."""

    def __init__(self, pan_rad: float = 0.1, tilt_rad: float = 0.0) -> None:
        self.wall_ns = 10**18
        self.mono_s = 20.0
        limits = ((-PAN_MAX_RAD, PAN_MAX_RAD), (-1.0, 0.5))
        self.tracer = LineTracer(RIG.gaze, ZoomLens.fixed(CAMERA), KINEMATICS, limits)
        command = GazeCommand(
            t_capture_ns=self.wall_ns,
            command="trace",
            request_id="r",
            pan_rad=pan_rad,
            tilt_rad=tilt_rad,
            max_samples=8,
        )
        self.tracer.begin(command)

    @property
    def job(self):
        assert self.tracer.job is not None
        return self.tracer.job

    def odometry(self) -> Odometry:
        pan, tilt = self.job.goal_rad
        return Odometry(t_capture_ns=self.wall_ns, pan_rad=pan, tilt_rad=tilt)

    def step(self, odometry: Odometry | None = None, dt_s: float = 0.02) -> str | None:
        self.wall_ns += round(dt_s * 1e9)
        self.mono_s += dt_s
        return self.tracer.step(odometry, self.wall_ns, self.mono_s)

    def settle(self) -> None:
        """At the goal for the settling time: the next edge is looked at."""
        for _ in range(4):
            assert self.step(self.odometry()) is None
        assert not self.job.moving

    def look(self, dv_px: float = 0.0, found: bool = True, turn_deg: float = 0.0) -> str | None:
        """An edge running left-right through the image, dv_px below the centre."""
        self.tracer.on_edge(edge(self.wall_ns + 1, self.job.goal_rad, dv_px, found, turn_deg))
        return self.step(self.odometry())


def test_it_settles_on_the_start_before_it_looks() -> None:
    bench = Bench(pan_rad=0.1, tilt_rad=-0.2)
    assert bench.job.goal_rad == (0.1, -0.2) and bench.job.moving
    assert bench.step(None) is None  # no odometry: still on the way
    bench.look()  # an edge seen on the way there is not a look
    assert bench.job.moving and bench.job.samples == []
    assert bench.step(bench.odometry()) is None
    arrived_ns = bench.wall_ns
    assert bench.job.moving  # at the goal, not yet for 40 ms
    bench.settle()
    assert 40_000_000 <= bench.job.look_since_ns - arrived_ns <= 60_000_000


def test_a_head_that_does_not_settle_ends_the_trace() -> None:
    bench = Bench()
    away = Odometry(t_capture_ns=bench.wall_ns, pan_rad=-0.3, tilt_rad=0.0)
    assert bench.step(away, dt_s=0.0) is None
    assert bench.step(away, dt_s=RIG.gaze.saccade_timeout_ms / 1000.0) is None  # not over it
    assert bench.step(away, dt_s=0.01) == "the head did not settle on the line"


def test_each_look_samples_the_edge_and_steps_ahead_along_it() -> None:
    bench = Bench(pan_rad=0.1)
    bench.settle()
    assert bench.look() is None
    assert bench.job.samples == [pytest.approx((0.1, 0.0))]
    assert bench.job.goal_rad == pytest.approx((0.1 + STEP_RAD, 0.0), abs=1e-9)
    assert bench.job.moving  # on to the next point, settling again
    bench.settle()
    bench.look()
    assert bench.job.goal_rad == pytest.approx((0.1 + 2 * STEP_RAD, 0.0), abs=1e-9)
    assert bench.job.start_rad == pytest.approx((0.1, 0.0))


def test_two_samples_off_the_line_end_the_leg_and_the_trace_turns_back() -> None:
    """After three samples on tilt 0, a point 30 px below the centre is 30/F off the line in
    the frontal plane, far past tan(0.3°)."""
    bench = Bench(pan_rad=0.1)
    for _ in range(3):
        bench.settle()
        bench.look()
    assert len(bench.job.samples) == 3
    bench.settle()
    assert bench.look(dv_px=30.0) is None  # one may be a bad look: stepped over, not sampled
    assert len(bench.job.samples) == 3 and bench.job.off_line == 1
    bench.settle()
    assert bench.look(dv_px=30.0) is None  # two: the leg ends, back to the first sample
    assert bench.job.first_leg == "the edge turned"
    assert bench.job.goal_rad == pytest.approx((0.1, 0.0))
    assert bench.job.step_rad == pytest.approx((-STEP_RAD, 0.0), abs=1e-9)
    bench.settle()
    bench.look()  # the other way now
    assert bench.job.goal_rad == pytest.approx((0.1 - STEP_RAD, 0.0), abs=1e-9)
    bench.settle()
    assert bench.look(found=False) is None  # one miss of two allowed
    assert bench.look(found=False) == "the edge turned; then the edge was lost"


def test_a_corner_needs_two_looks_that_agree() -> None:
    bench = Bench()
    bench.settle()
    bench.look()
    bench.settle()
    assert bench.look(turn_deg=50.0) is None and bench.job.corner_looks == 1
    assert bench.look() is None and bench.job.corner_looks == 0  # straight after all
    bench.settle()
    bench.look(turn_deg=50.0)
    assert bench.look(turn_deg=50.0) is None  # the first leg ends at the corner...
    assert bench.job.first_leg == "a corner"


def test_the_joint_limit_ends_a_leg() -> None:
    bench = Bench(pan_rad=PAN_MAX_RAD - 0.5 * STEP_RAD)
    bench.settle()
    assert bench.look() is None  # the next point is past the limit: back, the other way
    assert bench.job.first_leg == "the joint limits"
    assert bench.job.goal_rad == pytest.approx((PAN_MAX_RAD - 0.5 * STEP_RAD, 0.0))


def test_enough_samples_ends_the_trace_and_end_reports_them() -> None:
    bench = Bench(pan_rad=0.0)
    reason = None
    for _ in range(8):
        bench.settle()
        reason = bench.look()
    assert reason == "enough samples"
    result = bench.tracer.end(reason, bench.wall_ns)
    assert bench.tracer.job is None
    assert result.request_id == "r" and result.reason == "enough samples"
    pans = [pan for pan, _ in result.samples_rad]
    assert pans == pytest.approx([k * STEP_RAD for k in range(8)], abs=1e-9)
    assert result.stamps == (("gaze", bench.wall_ns),)


def test_enough_samples_on_the_second_leg_reports_why_the_first_ended() -> None:
    bench = Bench(pan_rad=0.0)
    bench.settle()
    bench.look()
    bench.settle()
    bench.look(found=False)
    assert bench.look(found=False) is None  # the first leg ends; back to the start
    assert bench.job.first_leg == "the edge was lost"
    reason = None
    while reason is None:
        bench.settle()
        reason = bench.look()
    assert reason == "the edge was lost"
    assert len(bench.job.samples) == 8
