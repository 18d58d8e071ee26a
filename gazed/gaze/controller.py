"""The gaze controller: a finite state machine choosing where the head should look (seed 000
§1-2 and §6, DESIGN §7; seed 004 §2 and §5 for static vs dynamic look-and-move).

States and transitions (each published with its reason):

    park    --head at the park pose-----------------------------> search
            --a target already in view (as from search)
    search  --target in the fovea (reacquire_detections in a row)--> pursuit
            --a detection or a motion candidate elsewhere-------> saccade
    saccade --head settled on the target (settle_ms)------------> pursuit
            --the move takes too long---------------------------> search
    pursuit --no detection for lost_after_ms--------------------> lost
    lost    --reacquire_detections in a row (one per frame)-------> pursuit
            --lost for search_after_ms---------------------------> search
    any     --a `trace` command (`gazed calibrate trace`)---------> trace
    trace   --corner, lost edge, enough samples, joint limit, stop--> search

- search holds the head and watches the whole-frame motion candidates of frames taken
  at rest (a turning head's compensation residue looks like motion);
- saccade is a ballistic move to where the target will be when the move ends; detections are
  ignored until the head has settled;
- pursuit demands the predicted position and rates for the instant the demand acts (the
  prediction extrapolated to now + actuation latency), plus a feedback term on the residual
  between where the target was seen and where it had been predicted to be; before the
  estimator has a prediction, the detection itself (its angles and angular rates);
- lost coasts on the estimator's prediction and searches around it in a region that grows
  with the prediction's covariance (or with time where the prediction carries none): while the
  region fits in the fovea the fovea stays on the prediction; past that it tours the region's
  edge in stops a fovea apart, coasting with the prediction at each stop for a look
  (`reacquire_detections` frames after settling); detections from the moves between stops are
  ignored, for a turning head's compensation residue looks like motion;
- trace follows a ground line's edge for the line calibration (seed 000 §3.2.1): move to the
  start, settle, take the edge point nearest the fovea's centre from `vision/edge` as a sample
  (its joint angles), step along the edge to the next point (keeping the same direction), again,
  until a corner, a lost edge, enough samples or a joint limit; the samples go out on
  `gaze/trace`;
- `look-and-move` control (seed 004 §2: a PTZ camera that cannot image while moving) replaces
  continuous pursuit by move, settle, look: it waits for a detection captured after the head
  settled, then moves to where the target will be once the move and the settling are over.

Every demand is clamped to the joint and rate limits (counted); the feed-forward rates also
change by at most the acceleration limit per tick.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from gazed.config import Rig
from gazed.gaze.aim import angle_between, move_duration_s
from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.target_angles import target_angles
from gazed.messages import (
    Candidates,
    Detection,
    EdgeObservation,
    GazeCommand,
    GazeDemand,
    GazeState,
    GazeStateName,
    HeadPose,
    Odometry,
    Prediction,
    Stamp,
    TraceResult,
)
from gazed.servo.limits import DemandLimiter

STAGE = "gaze"
STILL_RATE_RAD_S = math.radians(2.0)  # below this the head counts as at rest
PREDICTION_FRESH_S = 0.5  # an older prediction is not used for pursuit
FUTURE_TOLERANCE_NS = 500_000_000  # a message stamped further ahead of our clock is bogus
TAKING_UP = ("park", "search", "lost")  # the states that take a detection up (in a row)


@dataclass(frozen=True)
class Aim:
    """A target direction at an instant, with its angular rates."""

    t_ns: int
    pan_rad: float
    tilt_rad: float
    pan_rate_rad_s: float = 0.0
    tilt_rate_rad_s: float = 0.0

    def at(self, t_ns: int) -> tuple[float, float]:
        dt = (t_ns - self.t_ns) / 1e9
        return self.pan_rad + self.pan_rate_rad_s * dt, self.tilt_rad + self.tilt_rate_rad_s * dt


@dataclass(frozen=True)
class Decision:
    demand: GazeDemand | None
    transitions: tuple[GazeState, ...]  # in order: one tick can pass through several states
    trace: TraceResult | None = None

    @property
    def transition(self) -> GazeState | None:
        """The last transition of the tick (the state it ended in), if any."""
        return self.transitions[-1] if self.transitions else None


@dataclass(frozen=True)
class ScanStop:
    """Lost: one stop of the fovea's tour of the search region's edge."""

    phase_rad: float  # where on the ring around the prediction
    ring_rad: float  # the ring's radius when the stop began
    look_from_ns: int  # detections captured earlier come from the move here
    next_s: float  # when to move on to the next stop (monotonic)


@dataclass
class TraceJob:
    """One ground line being traced (seed 000 §3.2.1): move, settle, look at the edge, sample
    the edge point nearest the fovea's centre, step along the edge, again."""

    request_id: str
    max_samples: int
    goal: Aim
    samples: list[tuple[float, float]]
    moving: bool = True
    moved_s: float | None = None  # when the current move began (monotonic)
    look_since_ns: int = 0
    misses: int = 0
    corner_looks: int = 0
    off_line: int = 0  # samples in a row off the line through the earlier ones
    step: tuple[float, float] | None = None  # the last step's direction in joint angles
    start: Aim | None = None
    first_step: tuple[float, float] | None = None
    first_leg: str | None = None  # why the first leg ended, once it has: then the other way


class GazeController:
    """Feed it what arrives (`odometry`, `prediction`, `detection`, `candidates`), call
    `tick(wall_ns, mono_s)` at the control rate, publish what it decides."""

    def __init__(self, rig: Rig, mono_s: float) -> None:
        gaze = rig.gaze
        self.gaze = gaze
        self.camera = CameraModel.from_section(rig.camera)
        self.kinematics = HeadKinematics.from_section(rig.head)
        self.limiter = DemandLimiter(rig.head)
        self.rate_max = rig.head.rate_max_rad_s
        self.accel_max = rig.head.accel_max_rad_s2
        self.park = rig.head.park_rad
        self.fovea_rad = math.radians(gaze.fovea_half_angle_deg)
        self.camera_xyz_m = rig.calibration.camera_xyz_m
        self.state: GazeStateName = "park"
        self.entered_s = mono_s
        self.entered_ns = 0
        self.odometry: Odometry | None = None
        self.prediction: Prediction | None = None
        self.found: Detection | None = None  # latest detection with the target, taken into account
        self.in_a_row = 0  # park, search, lost: detections in consecutive frames since entering it
        self.frame_period_s = rig.camera.frame_period_s
        self.candidates: Candidates | None = None
        self.goal: Aim | None = None  # saccade or look-and-move target
        self.settled_since_s: float | None = None
        self.looking = True  # look-and-move: waiting for a fresh look (else moving)
        self.look_since_ns = 0  # look-and-move: a look needs a frame captured from here on
        self.correction = (0.0, 0.0)
        self.scan: ScanStop | None = None  # lost: the current stop on the search ring
        self.holding_at: tuple[float, float] | None = None  # a hold's joint angles
        self.predictions: deque[Prediction] = deque(maxlen=64)
        self.last_rates = (0.0, 0.0)
        self.last_tick_s = mono_s
        self.pending: list[GazeState] = []
        self.trace_job: TraceJob | None = None
        self.edge: EdgeObservation | None = None
        self.finished_trace: TraceResult | None = None
        self.counts = {
            "transitions": 0,
            "saccades": 0,
            "ignored_while_moving": 0,
            "stale_predictions": 0,
            "refused_odometry": 0,
        }

    # -- inputs ----------------------------------------------------------------------------

    def on_odometry(self, odometry: Odometry, wall_ns: int | None = None) -> None:
        """The head's newest pose; live (with our clock), one stamped in the future or older
        than the one held is refused and counted."""
        if wall_ns is not None and (
            odometry.t_capture_ns - wall_ns > FUTURE_TOLERANCE_NS
            or (self.odometry is not None and odometry.t_capture_ns < self.odometry.t_capture_ns)
        ):
            self.counts["refused_odometry"] += 1
            return
        self.odometry = odometry

    def on_prediction(self, prediction: Prediction) -> None:
        self.prediction = prediction
        self.predictions.append(prediction)

    def on_detection(self, detection: Detection) -> None:
        if not detection.found or detection.head is None:
            return
        if (
            self.state == "saccade"
            or (self.gaze.control == "look-and-move" and not self.looking)
            or (
                self.state == "lost"
                and self.scan is not None
                and detection.t_capture_ns < self.scan.look_from_ns
            )
        ):
            self.counts["ignored_while_moving"] += 1  # captured mid-move: blurred, off its track
            return
        if self.state == "pursuit":
            self._update_correction(detection)
        if self.state in TAKING_UP:
            self._count_in_a_row(detection)
        self.found = detection

    def on_candidates(self, candidates: Candidates) -> None:
        self.candidates = candidates

    def on_edge(self, edge: EdgeObservation) -> None:
        self.edge = edge

    def on_command(self, command: GazeCommand, wall_ns: int, mono_s: float) -> None:
        """`trace`: follow a ground line's edge from a start gaze; `stop`: end a trace."""
        if command.command == "stop":
            if self.trace_job is not None:
                self._finish_trace("stopped by request", wall_ns, mono_s)
            return
        if self.trace_job is not None:
            self._finish_trace("replaced by a new request", wall_ns, mono_s)
        self.trace_job = TraceJob(
            command.request_id,
            command.max_samples,
            Aim(wall_ns, command.pan_rad, command.tilt_rad),
            [],
        )
        self.enter("trace", f"tracing a line ({command.request_id})", wall_ns, mono_s)

    # -- the loop body ------------------------------------------------------------------------

    def tick(self, wall_ns: int, mono_s: float) -> Decision:
        dt_s = max(mono_s - self.last_tick_s, 1e-3)
        self.last_tick_s = mono_s
        handler = {
            "park": self._park,
            "search": self._search,
            "saccade": self._saccade,
            "pursuit": self._pursuit,
            "lost": self._lost,
            "trace": self._trace,
        }[self.state]
        demand = handler(wall_ns, mono_s)
        if demand is None or demand.kind != "hold":
            self.holding_at = None
        if demand is not None:
            demand = self._limited(demand, dt_s)
            if demand is None:  # a non-finite number reached the demand: hold instead
                demand = self._hold(wall_ns, mono_s)
        transitions, self.pending = tuple(self.pending), []
        trace, self.finished_trace = self.finished_trace, None
        return Decision(demand, transitions, trace)

    def enter(self, state: GazeStateName, reason: str, wall_ns: int, mono_s: float) -> None:
        if state == self.state:
            return
        self.pending.append(
            GazeState(
                t_capture_ns=wall_ns,
                stamps=((STAGE, wall_ns),),
                state=state,
                previous=self.state,
                reason=reason,
            )
        )
        self.state = state
        self.entered_s = mono_s
        self.entered_ns = wall_ns
        self.settled_since_s = None
        self.in_a_row = 0
        self.scan = None
        self.counts["transitions"] += 1

    # -- states ------------------------------------------------------------------------------

    def _park(self, wall_ns: int, mono_s: float) -> GazeDemand | None:
        # a target already in view (a restarted controller, the head held where it was) is
        # taken up at once rather than parked away from
        taken = self._take_up_detection(wall_ns, mono_s)
        if taken is not None:
            return taken
        if self._at(self.park[0], self.park[1], math.radians(1.0)):
            self.enter("search", "head parked", wall_ns, mono_s)
        return self._demand("park", self.park[0], self.park[1], wall_ns)

    def _search(self, wall_ns: int, mono_s: float) -> GazeDemand | None:
        taken = self._take_up_detection(wall_ns, mono_s)
        if taken is not None:
            return taken
        candidate = self._best_candidate(wall_ns)
        if candidate is not None:
            return self._start_saccade(candidate, "motion candidate", wall_ns, mono_s)
        return self._hold(wall_ns, mono_s)

    def _take_up_detection(self, wall_ns: int, mono_s: float) -> GazeDemand | None:
        """A detection since this state began, the last of `reacquire_detections` in a row:
        pursue it if it is in the fovea, else saccade."""
        detection = self._recent_found(wall_ns, since_ns=self.entered_ns)
        if detection is None or self.in_a_row < self.gaze.reacquire_detections:
            return None
        target = self._detection_aim(detection)
        if self._offset_from_axis(target, detection) <= self.fovea_rad:
            self.enter("pursuit", "target in the fovea", wall_ns, mono_s)
            return self._pursuit(wall_ns, mono_s)
        return self._start_saccade(target, "detection outside the fovea", wall_ns, mono_s)

    def _start_saccade(
        self, target: Aim, reason: str, wall_ns: int, mono_s: float
    ) -> GazeDemand | None:
        """Aim where the target will be when the move (at the head's limits) is over."""
        if self.odometry is None:
            return self._hold(wall_ns, mono_s)
        pan_now, tilt_now = target.at(wall_ns)
        duration_s = max(
            move_duration_s(pan_now - self.odometry.pan_rad, self.rate_max[0], self.accel_max[0]),
            move_duration_s(tilt_now - self.odometry.tilt_rad, self.rate_max[1], self.accel_max[1]),
        )
        arrival_ns = wall_ns + round((duration_s + self.gaze.settle_ms / 1000.0) * 1e9)
        pan, tilt = target.at(arrival_ns)
        self.goal = Aim(arrival_ns, pan, tilt)
        self.counts["saccades"] += 1
        self.enter("saccade", reason, wall_ns, mono_s)
        return self._demand("position", pan, tilt, wall_ns)

    def _saccade(self, wall_ns: int, mono_s: float) -> GazeDemand | None:
        assert self.goal is not None
        if self._settled_at(self.goal.pan_rad, self.goal.tilt_rad, mono_s):
            self.found = None  # only detections from after the move count
            self.enter("pursuit", "settled on the target", wall_ns, mono_s)
            self.looking = True
            return self._hold(wall_ns, mono_s)
        if mono_s - self.entered_s > self.gaze.saccade_timeout_ms / 1000.0:
            self.enter("search", "saccade did not settle", wall_ns, mono_s)
            return self._hold(wall_ns, mono_s)
        return self._demand("position", self.goal.pan_rad, self.goal.tilt_rad, wall_ns)

    def _pursuit(self, wall_ns: int, mono_s: float) -> GazeDemand | None:
        since_ns = self.entered_ns - round(self.gaze.lost_after_ms * 1e6)
        detection = self._recent_found(wall_ns, since_ns=since_ns)
        if detection is None and mono_s - self.entered_s > self.gaze.lost_after_ms / 1000.0:
            self.enter("lost", f"no detection for {self.gaze.lost_after_ms:g} ms", wall_ns, mono_s)
            return self._lost(wall_ns, mono_s)
        if self.gaze.control == "look-and-move":
            return self._look_and_move(wall_ns, mono_s)
        return self._follow(wall_ns, correction=True)

    def _look_and_move(self, wall_ns: int, mono_s: float) -> GazeDemand | None:
        if self.looking:
            fresh = self.found is not None and self.found.t_capture_ns >= max(
                self.look_since_ns, self.entered_ns
            )
            if not fresh:
                return self._hold(wall_ns, mono_s)
            assert self.found is not None
            aim = self._aim(wall_ns) or self._detection_aim(self.found)
            assert self.odometry is not None
            pan_now, tilt_now = aim.at(wall_ns)
            duration_s = max(
                move_duration_s(
                    pan_now - self.odometry.pan_rad, self.rate_max[0], self.accel_max[0]
                ),
                move_duration_s(
                    tilt_now - self.odometry.tilt_rad, self.rate_max[1], self.accel_max[1]
                ),
            )
            arrival_ns = wall_ns + round((duration_s + self.gaze.settle_ms / 1000.0) * 1e9)
            pan, tilt = aim.at(arrival_ns)
            self.goal = Aim(arrival_ns, pan, tilt)
            self.looking = False
            self.settled_since_s = None
            return self._demand("position", pan, tilt, wall_ns, self.found)
        assert self.goal is not None
        if self._settled_at(self.goal.pan_rad, self.goal.tilt_rad, mono_s):
            self.looking = True
            self.look_since_ns = wall_ns
        return self._demand("position", self.goal.pan_rad, self.goal.tilt_rad, wall_ns)

    def _lost(self, wall_ns: int, mono_s: float) -> GazeDemand | None:
        detection = self._recent_found(wall_ns, since_ns=self.entered_ns)
        if detection is not None and self.in_a_row >= self.gaze.reacquire_detections:
            self.enter("pursuit", "target seen again", wall_ns, mono_s)
            return self._pursuit(wall_ns, mono_s)
        lost_s = mono_s - self.entered_s
        if lost_s > self.gaze.search_after_ms / 1000.0:
            self.enter("search", f"lost for {lost_s:.1f} s", wall_ns, mono_s)
            return self._hold(wall_ns, mono_s)
        region_rad = self._search_radius_rad(lost_s)
        if region_rad > math.radians(self.gaze.lost_search_max_deg):
            # the prediction says too little (a track too young for a velocity, or coasted too
            # long): the whole frame's motion, watched from a still head, says more
            reason = f"search region {math.degrees(region_rad):.0f}° wide after {lost_s:.1f} s"
            self.enter("search", reason, wall_ns, mono_s)
            return self._hold(wall_ns, mono_s)
        if self._aim(wall_ns) is None:  # nothing to coast on
            return self._hold(wall_ns, mono_s)
        demand = self._follow(wall_ns, correction=False)
        assert demand is not None
        ring_rad = max(region_rad - self.fovea_rad, 0.0)
        if ring_rad == 0.0:  # the region fits in the fovea: keep it on the prediction
            return demand
        stop = self._scan_stop(ring_rad, wall_ns, mono_s)
        return demand.model_copy(
            update={
                "pan_rad": demand.pan_rad + stop.ring_rad * math.cos(stop.phase_rad),
                "tilt_rad": demand.tilt_rad + stop.ring_rad * math.sin(stop.phase_rad),
            }
        )

    def _scan_stop(self, ring_rad: float, wall_ns: int, mono_s: float) -> ScanStop:
        """The current stop on the ring around the prediction, or the next one once the look
        at it is over: a fovea further round (neighbouring views touch), held for the move,
        the settling, `reacquire_detections` frames and the visual latency of their reports."""
        stop = self.scan
        if stop is not None and mono_s < stop.next_s:
            return stop
        if stop is None:
            phase_rad, move_pan, move_tilt = 0.0, ring_rad, 0.0
        else:
            phase_rad = stop.phase_rad + min(2.0 * math.pi / 3.0, 2.0 * self.fovea_rad / ring_rad)
            move_pan = ring_rad * math.cos(phase_rad) - stop.ring_rad * math.cos(stop.phase_rad)
            move_tilt = ring_rad * math.sin(phase_rad) - stop.ring_rad * math.sin(stop.phase_rad)
        move_s = max(
            move_duration_s(move_pan, self.rate_max[0], self.accel_max[0]),
            move_duration_s(move_tilt, self.rate_max[1], self.accel_max[1]),
        )
        look_s = move_s + self.gaze.settle_ms / 1000.0
        latency_s = self.prediction.visual_latency_s if self.prediction is not None else 0.0
        frames_s = (self.gaze.reacquire_detections + 1) * self.frame_period_s
        self.scan = ScanStop(
            phase_rad,
            ring_rad,
            wall_ns + round(look_s * 1e9),
            mono_s + look_s + frames_s + latency_s,
        )
        self.in_a_row = 0
        return self.scan

    def _trace(self, wall_ns: int, mono_s: float) -> GazeDemand | None:
        job = self.trace_job
        if job is None:
            self.enter("search", "no line to trace", wall_ns, mono_s)
            return self._hold(wall_ns, mono_s)
        if job.moving:
            if job.moved_s is None:
                job.moved_s = mono_s
            if self._settled_at(job.goal.pan_rad, job.goal.tilt_rad, mono_s):
                job.moving, job.look_since_ns = False, wall_ns
            elif mono_s - job.moved_s > self.gaze.saccade_timeout_ms / 1000.0:
                return self._finish_trace("the head did not settle on the line", wall_ns, mono_s)
            return self._demand("position", job.goal.pan_rad, job.goal.tilt_rad, wall_ns)
        edge = self.edge
        if edge is None or edge.t_capture_ns < job.look_since_ns or edge.head is None:
            return self._demand("position", job.goal.pan_rad, job.goal.tilt_rad, wall_ns)
        self.edge = None  # each look is used once
        job.look_since_ns = wall_ns
        if not edge.found:
            job.misses += 1
            if job.misses >= self.gaze.trace_misses:
                return self._end_leg("the edge was lost", wall_ns, mono_s)
            return self._demand("position", job.goal.pan_rad, job.goal.tilt_rad, wall_ns)
        if edge.turn_rad > math.radians(self.gaze.trace_max_turn_deg):
            job.corner_looks += 1  # a corner only if a second look agrees (texture can fake one)
            if job.corner_looks >= 2:
                return self._end_leg("a corner", wall_ns, mono_s)
            return self._demand("position", job.goal.pan_rad, job.goal.tilt_rad, wall_ns)
        job.corner_looks = 0
        head = edge.head
        here = target_angles(
            self.camera, self.kinematics, head.pan_rad, head.tilt_rad, edge.u_px, edge.v_px
        )
        if self._off_the_line(job, here.pan_rad, here.tilt_rad):
            job.off_line += 1  # the path bends: a corner passed (or one bad look)
            if job.off_line >= 2:
                return self._end_leg("the edge turned", wall_ns, mono_s)
        else:
            job.off_line = 0
            job.samples.append((here.pan_rad, here.tilt_rad))
        if len(job.samples) >= job.max_samples:
            return self._finish_trace(job.first_leg or "enough samples", wall_ns, mono_s)
        options = [
            target_angles(self.camera, self.kinematics, head.pan_rad, head.tilt_rad, *point)
            for point in (edge.ahead_px, edge.behind_px)
        ]
        steps = [(o.pan_rad - here.pan_rad, o.tilt_rad - here.tilt_rad) for o in options]
        # keep going the same way along the edge (the first step goes "ahead")
        pick = (
            0
            if job.step is None or steps[0][0] * job.step[0] + steps[0][1] * job.step[1] >= 0
            else 1
        )
        if job.start is None:
            job.start, job.first_step = Aim(wall_ns, here.pan_rad, here.tilt_rad), steps[pick]
        job.step = steps[pick]
        goal = options[pick]
        (pan_lo, pan_hi), (tilt_lo, tilt_hi) = (
            self.limiter.pan_limits_rad,
            self.limiter.tilt_limits_rad,
        )
        if not (pan_lo <= goal.pan_rad <= pan_hi and tilt_lo <= goal.tilt_rad <= tilt_hi):
            return self._end_leg("the joint limits", wall_ns, mono_s)
        return self._move_along(job, Aim(wall_ns, goal.pan_rad, goal.tilt_rad), wall_ns)

    def _off_the_line(self, job: TraceJob, pan_rad: float, tilt_rad: float) -> bool:
        """A ground line's samples lie on a line in the frontal plane (a homography keeps lines
        straight): is this one farther than `trace_line_tolerance_deg` from the line through
        the samples so far?"""
        if len(job.samples) < 3:
            return False
        points = np.array([self.kinematics.frontal_from_angles(p, t) for p, t in job.samples])
        centre = points.mean(axis=0)
        _, _, vt = np.linalg.svd(points - centre, full_matrices=False)
        normal = np.array([-vt[0][1], vt[0][0]])
        here = np.array(self.kinematics.frontal_from_angles(pan_rad, tilt_rad))
        return abs(float((here - centre) @ normal)) > math.tan(
            math.radians(self.gaze.trace_line_tolerance_deg)
        )

    def _move_along(self, job: TraceJob, goal: Aim, wall_ns: int) -> GazeDemand:
        job.goal = goal
        job.moving, job.moved_s, job.misses, job.corner_looks = True, None, 0, 0
        self.settled_since_s = None
        return self._demand("position", goal.pan_rad, goal.tilt_rad, wall_ns)

    def _end_leg(self, reason: str, wall_ns: int, mono_s: float) -> GazeDemand | None:
        """The first leg ends: back to the start, then along the edge the other way."""
        job = self.trace_job
        assert job is not None
        if job.first_leg is not None or job.start is None or job.first_step is None:
            legs = f"{job.first_leg}; then {reason}" if job.first_leg is not None else reason
            return self._finish_trace(legs, wall_ns, mono_s)
        job.first_leg = reason
        job.off_line = 0
        job.step = (-job.first_step[0], -job.first_step[1])
        return self._move_along(job, job.start, wall_ns)

    def _finish_trace(self, reason: str, wall_ns: int, mono_s: float) -> GazeDemand | None:
        job = self.trace_job
        assert job is not None
        self.finished_trace = TraceResult(
            t_capture_ns=wall_ns,
            stamps=((STAGE, wall_ns),),
            request_id=job.request_id,
            samples_rad=tuple(job.samples),
            reason=reason,
        )
        self.trace_job = None
        self.enter("search", f"trace ended: {reason} ({len(job.samples)} samples)", wall_ns, mono_s)
        return self._hold(wall_ns, mono_s)

    def _hold(self, wall_ns: int, mono_s: float) -> GazeDemand | None:
        """Stay where the head was when the hold began: chasing each new reading instead would
        close a loop through the odometry's delay and the encoder's step, and the head would
        hunt by a step every poll (which the detectors see as motion)."""
        del mono_s
        if self.holding_at is None:
            if self.odometry is None:
                return None
            self.holding_at = (self.odometry.pan_rad, self.odometry.tilt_rad)
        return self._demand("hold", *self.holding_at, wall_ns)

    # -- pursuit demands ------------------------------------------------------------------------

    def _aim(self, wall_ns: int) -> Aim | None:
        """The estimator's latest prediction, if fresh, as an aim."""
        p = self.prediction
        if p is None:
            return None
        if (
            abs(wall_ns - p.t_effect_ns) / 1e9 > PREDICTION_FRESH_S
        ):  # stale, or bogus from the future
            self.counts["stale_predictions"] += 1
            return None
        return Aim(p.t_effect_ns, p.pan_rad, p.tilt_rad, p.pan_rate_rad_s, p.tilt_rate_rad_s)

    def _follow(self, wall_ns: int, correction: bool) -> GazeDemand | None:
        """Position and rates for the instant the demand acts (now + actuation latency)."""
        aim = self._aim(wall_ns)
        source: Prediction | Detection | None = self.prediction
        if aim is None:
            if self.found is None:
                return self._hold(wall_ns, 0.0)
            aim, source = self._detection_aim(self.found), self.found
        actuation_s = self.prediction.actuation_latency_s if self.prediction is not None else 0.0
        pan, tilt = aim.at(wall_ns + round(actuation_s * 1e9))
        if correction:
            gain = self.gaze.residual_gain
            pan, tilt = pan + gain * self.correction[0], tilt + gain * self.correction[1]
        return self._demand(
            "pursuit", pan, tilt, wall_ns, source, (aim.pan_rate_rad_s, aim.tilt_rate_rad_s)
        )

    def _update_correction(self, detection: Detection) -> None:
        """The residual between where the target was seen and where it had been predicted to be
        at that instant, smoothed; bounded by the fovea."""
        predicted = [p for p in self.predictions if p.t_effect_ns <= detection.t_capture_ns]
        if not predicted:
            return
        p = predicted[-1]
        seen = self._detection_aim(detection)
        pan_p, tilt_p = Aim(
            p.t_effect_ns, p.pan_rad, p.tilt_rad, p.pan_rate_rad_s, p.tilt_rate_rad_s
        ).at(detection.t_capture_ns)
        alpha = self.gaze.residual_smoothing
        bound = self.fovea_rad
        self.correction = (
            max(
                -bound,
                min(
                    bound, self.correction[0] + alpha * (seen.pan_rad - pan_p - self.correction[0])
                ),
            ),
            max(
                -bound,
                min(
                    bound,
                    self.correction[1] + alpha * (seen.tilt_rad - tilt_p - self.correction[1]),
                ),
            ),
        )

    def _detection_aim(self, detection: Detection) -> Aim:
        assert detection.head is not None
        head = detection.head
        target = target_angles(
            self.camera,
            self.kinematics,
            head.pan_rad,
            head.tilt_rad,
            detection.u_px,
            detection.v_px,
        )
        pan_rate, tilt_rate = target.rates(detection.du_px_s, detection.dv_px_s)
        return Aim(detection.t_capture_ns, target.pan_rad, target.tilt_rad, pan_rate, tilt_rate)

    def _search_radius_rad(self, lost_s: float) -> float:
        """Grows with the prediction's position covariance seen from the camera, or with time."""
        p = self.prediction
        grow = math.radians(self.gaze.lost_search_growth_deg_s) * lost_s
        camera = self.camera_xyz_m
        if (
            p is not None
            and p.position_cov_m2 is not None
            and p.ground_xy_m is not None
            and camera is not None
        ):
            (a, b), (c, d) = p.position_cov_m2
            sigma_m = math.sqrt(max(0.5 * (a + d + math.hypot(a - d, b + c)), 0.0))
            distance_m = math.hypot(
                p.ground_xy_m[0] - camera[0], p.ground_xy_m[1] - camera[1], camera[2]
            )
            grow = max(grow, sigma_m / distance_m)
        return grow

    # -- helpers ---------------------------------------------------------------------------------

    def _count_in_a_row(self, detection: Detection) -> None:
        """Park, search, lost: one more detection in a row if it comes a frame or two after the
        previous one; the first of a new run otherwise (a repeat of a frame counts nothing)."""
        if self.found is None:
            self.in_a_row = 1
            return
        gap_s = (detection.t_capture_ns - self.found.t_capture_ns) / 1e9
        if gap_s <= 0.0:
            return
        self.in_a_row = self.in_a_row + 1 if gap_s <= 2.5 * self.frame_period_s else 1

    def _recent_found(self, wall_ns: int, since_ns: int) -> Detection | None:
        d = self.found
        if d is None or d.t_capture_ns < since_ns or d.t_capture_ns - wall_ns > FUTURE_TOLERANCE_NS:
            return None
        if (wall_ns - d.t_capture_ns) / 1e6 > self.gaze.lost_after_ms:
            return None
        return d

    def _best_candidate(self, wall_ns: int) -> Aim | None:
        c = self.candidates
        if c is None or c.head is None or not c.candidates or c.t_capture_ns < self.entered_ns:
            return None
        if (wall_ns - c.t_capture_ns) / 1e6 > self.gaze.lost_after_ms:
            return None
        head = c.head
        if not _at_rest(head):
            # seen while the head still turned: whatever its compensation missed looks like
            # motion too, so only frames from a head at rest are searched
            self.counts["ignored_while_moving"] += 1
            return None
        best = max(c.candidates, key=lambda k: k.score)
        if best.score < self.gaze.candidate_min_score:
            return None
        target = target_angles(
            self.camera, self.kinematics, head.pan_rad, head.tilt_rad, best.u_px, best.v_px
        )
        pan_rate, tilt_rate = target.rates(best.du_px_s, best.dv_px_s)
        return Aim(c.t_capture_ns, target.pan_rad, target.tilt_rad, pan_rate, tilt_rate)

    def _offset_from_axis(self, target: Aim, detection: Detection) -> float:
        assert detection.head is not None
        head = detection.head
        return angle_between(
            target.pan_rad, target.tilt_rad, head.pan_rad, head.tilt_rad, self.kinematics
        )

    def _at(self, pan_rad: float, tilt_rad: float, tolerance_rad: float) -> bool:
        o = self.odometry
        if o is None:
            return False
        return (
            _at_rest(o)
            and angle_between(o.pan_rad, o.tilt_rad, pan_rad, tilt_rad, self.kinematics)
            <= tolerance_rad
        )

    def _settled_at(self, pan_rad: float, tilt_rad: float, mono_s: float) -> bool:
        """At the goal and at rest for settle_ms."""
        if not self._at(pan_rad, tilt_rad, math.radians(self.gaze.saccade_tolerance_deg)):
            self.settled_since_s = None
            return False
        if self.settled_since_s is None:
            self.settled_since_s = mono_s
        return mono_s - self.settled_since_s >= self.gaze.settle_ms / 1000.0

    def _demand(
        self,
        kind: str,
        pan_rad: float,
        tilt_rad: float,
        wall_ns: int,
        source: Prediction | Detection | None = None,
        rates: tuple[float, float] = (0.0, 0.0),
    ) -> GazeDemand:
        stamps: tuple[Stamp, ...] = source.stamps if source is not None else ()
        return GazeDemand(
            t_capture_ns=source.t_capture_ns if source is not None else wall_ns,
            stamps=(*stamps, (STAGE, wall_ns)),
            kind=kind,
            pan_rad=pan_rad,
            tilt_rad=tilt_rad,
            pan_rate_rad_s=rates[0],
            tilt_rate_rad_s=rates[1],
        )

    def _limited(self, demand: GazeDemand, dt_s: float) -> GazeDemand | None:
        """Joint and rate limits (counted), and the acceleration limit on feed-forward rates;
        None (counted) for a demand with a non-finite number."""
        target = self.limiter.limit(demand)
        if target is None:
            self.last_rates = (0.0, 0.0)
            return None
        rates = (target.pan_rate_rad_s, target.tilt_rate_rad_s)
        if demand.kind == "pursuit":
            rates = tuple(
                last + max(-a * dt_s, min(a * dt_s, r - last))
                for r, last, a in zip(rates, self.last_rates, self.accel_max, strict=True)
            )
        self.last_rates = rates if demand.kind == "pursuit" else (0.0, 0.0)
        return demand.model_copy(
            update={
                "pan_rad": target.pan_rad,
                "tilt_rad": target.tilt_rad,
                "pan_rate_rad_s": rates[0],
                "tilt_rate_rad_s": rates[1],
            }
        )

    @property
    def clamps(self) -> int:
        return self.limiter.clamps


def _at_rest(pose: HeadPose | Odometry) -> bool:
    """Both joints turning slower than STILL_RATE_RAD_S."""
    return max(abs(pose.pan_rate_rad_s), abs(pose.tilt_rate_rad_s)) < STILL_RATE_RAD_S
