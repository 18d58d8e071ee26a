"""Tracing a ground line's image edge for the line calibration (seed 000 §3.2.1; DESIGN §7, state
`trace`).

A trace moves the head to the line's start gaze and settles; then, on each look (a
`vision/edge` observation captured after settling), it takes the edge point nearest the
fovea's centre as a sample (its joint angles) and steps along the edge to the next point,
keeping the direction it went. The first leg ends at a corner (two looks in a row agree), a
lost edge (`trace_misses` looks without one), a bend (two samples in a row off the line
through the earlier ones) or a joint limit; the trace then returns to its first sample and
follows the edge the other way, until the second leg ends the same way or there are enough
samples.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from gazed.config import GazeSection
from gazed.gaze import STAGE
from gazed.gaze.move import Settling
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.target_angles import target_angles
from gazed.geometry.zoom import ZoomLens
from gazed.messages import EdgeObservation, GazeCommand, Odometry, TraceResult

CORNER_LOOKS = 2  # looks in a row that see a corner before a leg ends (texture can fake one)
OFF_LINE_SAMPLES = 2  # samples in a row off the line before a leg ends (one may be a bad look)
MIN_LINE_SAMPLES = 3  # samples needed before the line through them judges the next one

Angles = tuple[float, float]  # (pan, tilt), radians


@dataclass
class TraceJob:
    """One ground line being traced: where the head goes next, what it has collected, and how
    the legs went."""

    request_id: str
    max_samples: int
    goal_rad: Angles
    samples: list[Angles] = field(default_factory=list)
    moving: bool = True
    moved_s: float | None = None  # when the current move began (monotonic)
    look_since_ns: int = 0  # a look needs an edge captured from here on
    misses: int = 0
    corner_looks: int = 0
    off_line: int = 0  # samples in a row off the line through the earlier ones
    step_rad: Angles | None = None  # the last step's direction in joint angles
    start_rad: Angles | None = None  # the first sample: the second leg starts here
    first_step_rad: Angles | None = None
    first_leg: str | None = None  # why the first leg ended, once it has: then the other way


class LineTracer:
    """Runs one `TraceJob` at a time: `begin` it, feed it edges (`on_edge`), `step` it each
    tick (the head goes to `job.goal_rad`) until `step` returns why it ended, then `end` it."""

    def __init__(
        self,
        gaze: GazeSection,
        lens: ZoomLens,
        kinematics: HeadKinematics,
        joint_limits_rad: tuple[Angles, Angles],
    ) -> None:
        self.lens = lens
        self.kinematics = kinematics
        self.joint_limits_rad = joint_limits_rad
        self.settling = Settling(
            kinematics, math.radians(gaze.saccade_tolerance_deg), gaze.settle_ms / 1000.0
        )
        self.move_timeout_s = gaze.saccade_timeout_ms / 1000.0
        self.misses_allowed = gaze.trace_misses
        self.max_turn_rad = math.radians(gaze.trace_max_turn_deg)
        self.line_tolerance = math.tan(math.radians(gaze.trace_line_tolerance_deg))
        self.job: TraceJob | None = None
        self.edge: EdgeObservation | None = None

    def on_edge(self, edge: EdgeObservation) -> None:
        self.edge = edge

    def begin(self, command: GazeCommand) -> None:
        """A new job: to the command's start gaze first."""
        self.job = TraceJob(
            command.request_id, command.max_samples, (command.pan_rad, command.tilt_rad)
        )
        self.settling.restart()

    def end(self, reason: str, wall_ns: int) -> TraceResult:
        """The job's samples and why it ended; no job after this."""
        job = self.job
        assert job is not None
        self.job = None
        return TraceResult(
            t_capture_ns=wall_ns,
            stamps=((STAGE, wall_ns),),
            request_id=job.request_id,
            samples_rad=tuple(job.samples),
            reason=reason,
        )

    def step(self, odometry: Odometry | None, wall_ns: int, mono_s: float) -> str | None:
        """One tick of the job: settle on the goal, or take the newest edge captured since;
        why the trace ends, or None while it goes on."""
        job = self.job
        assert job is not None
        if job.moving:
            if job.moved_s is None:
                job.moved_s = mono_s
            if self.settling.settled(odometry, job.goal_rad, mono_s):
                job.moving, job.look_since_ns = False, wall_ns
            elif mono_s - job.moved_s > self.move_timeout_s:
                return "the head did not settle on the line"
            return None
        edge = self.edge
        if edge is None or edge.t_capture_ns < job.look_since_ns or edge.head is None:
            return None
        self.edge = None  # each look is used once
        job.look_since_ns = wall_ns
        return self._look(job, edge)

    def _look(self, job: TraceJob, edge: EdgeObservation) -> str | None:
        """Sample the edge and step along it, or end the leg."""
        if not edge.found:
            job.misses += 1
            return (
                self._end_leg(job, "the edge was lost")
                if job.misses >= self.misses_allowed
                else None
            )
        if edge.turn_rad > self.max_turn_rad:
            job.corner_looks += 1
            return self._end_leg(job, "a corner") if job.corner_looks >= CORNER_LOOKS else None
        job.corner_looks = 0
        head = edge.head
        assert head is not None
        camera = self.lens.at_pose(head)
        here = target_angles(
            camera, self.kinematics, head.pan_rad, head.tilt_rad, edge.u_px, edge.v_px
        )
        if self._off_the_line(job, here.pan_rad, here.tilt_rad):
            job.off_line += 1  # the path bends: a corner passed (or one bad look)
            if job.off_line >= OFF_LINE_SAMPLES:
                return self._end_leg(job, "the edge turned")
        else:
            job.off_line = 0
            job.samples.append((here.pan_rad, here.tilt_rad))
        if len(job.samples) >= job.max_samples:
            return job.first_leg or "enough samples"
        options = [
            target_angles(camera, self.kinematics, head.pan_rad, head.tilt_rad, *point)
            for point in (edge.ahead_px, edge.behind_px)
        ]
        steps = [(o.pan_rad - here.pan_rad, o.tilt_rad - here.tilt_rad) for o in options]
        # keep going the same way along the edge (the first step goes "ahead")
        last = job.step_rad
        pick = 0 if last is None or steps[0][0] * last[0] + steps[0][1] * last[1] >= 0 else 1
        if job.start_rad is None:
            job.start_rad, job.first_step_rad = (here.pan_rad, here.tilt_rad), steps[pick]
        job.step_rad = steps[pick]
        goal = options[pick]
        (pan_lo, pan_hi), (tilt_lo, tilt_hi) = self.joint_limits_rad
        if not (pan_lo <= goal.pan_rad <= pan_hi and tilt_lo <= goal.tilt_rad <= tilt_hi):
            return self._end_leg(job, "the joint limits")
        self._move_to(job, (goal.pan_rad, goal.tilt_rad))
        return None

    def _off_the_line(self, job: TraceJob, pan_rad: float, tilt_rad: float) -> bool:
        """A ground line's samples lie on a line in the frontal plane (a homography keeps lines
        straight): is this one farther than the tolerance from the line through the samples
        so far?"""
        if len(job.samples) < MIN_LINE_SAMPLES:
            return False
        points = np.array([self.kinematics.frontal_from_angles(p, t) for p, t in job.samples])
        centre = points.mean(axis=0)
        _, _, vt = np.linalg.svd(points - centre, full_matrices=False)
        normal = np.array([-vt[0][1], vt[0][0]])
        here = np.array(self.kinematics.frontal_from_angles(pan_rad, tilt_rad))
        return abs(float((here - centre) @ normal)) > self.line_tolerance

    def _move_to(self, job: TraceJob, goal_rad: Angles) -> None:
        job.goal_rad = goal_rad
        job.moving, job.moved_s, job.misses, job.corner_looks = True, None, 0, 0
        self.settling.restart()

    def _end_leg(self, job: TraceJob, reason: str) -> str | None:
        """The first leg ends: back to the start, then along the edge the other way (None);
        the second ends the trace (why both legs ended)."""
        if job.first_leg is not None or job.start_rad is None or job.first_step_rad is None:
            return f"{job.first_leg}; then {reason}" if job.first_leg is not None else reason
        job.first_leg = reason
        job.off_line = 0
        job.step_rad = (-job.first_step_rad[0], -job.first_step_rad[1])
        self._move_to(job, job.start_rad)
        return None
