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
            --lost for search_after_ms, the region too wide, or--> search
              no prediction to coast on
    any     --a `trace` command (`gazed calibrate trace`)---------> trace
            --an operator's park, search or hold (`operator`)---> park, search, hold
    trace   --corner, lost edge, enough samples, joint limit, stop--> search

Each state's behaviour lives in its part: taking a target up (`sightings`), the saccade's
ballistic move (`move`, `aim.arrival_aim`), pursuit with feedback on the residual (`pursuit`),
the lost state's coasting search (`lost_search`), the line trace (`trace`), and the
look-and-move and peer control laws (`look_and_move`, `pixel_pid`); docs/gaze.md describes each.

Which of the estimator's tracks is the target is `target_choice` (the rig's rule or an
operator's `gaze/select`); only the chosen track's predictions are used, of a frame's movers
the one nearest its prediction (`focus`), and every change of target is published on
gaze/state, with the state unchanged, and its reason.

Every demand is clamped to the joint and rate limits (counted); the feed-forward rates also
change by at most the acceleration limit per tick (`demand`); its zoom is `zoom`'s.
"""

from __future__ import annotations

import math
from functools import partial

from gazed.config import Rig
from gazed.gaze import FUTURE_TOLERANCE_NS
from gazed.gaze.aim import Aim, MoveLimits, angle_between
from gazed.gaze.decision import Decision, state_message
from gazed.gaze.demand import DemandShaper, Hold, make_demand
from gazed.gaze.focus import focus
from gazed.gaze.look_and_move import LookAndMove
from gazed.gaze.lost_search import LostSearch
from gazed.gaze.move import Move, Settling, at_goal
from gazed.gaze.operator import OperatorControl
from gazed.gaze.pixel_pid import PixelPid, pixel_error
from gazed.gaze.pursuit import Pursuit
from gazed.gaze.sightings import Sightings
from gazed.gaze.target_choice import ChoiceChange, TargetChoice
from gazed.gaze.trace import LineTracer
from gazed.gaze.zoom import ZoomControl
from gazed.geometry.homography import GroundHomography
from gazed.geometry.image_roll import image_roll_rad
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.zoom import ZoomLens
from gazed.messages import (
    Candidates,
    Detection,
    EdgeObservation,
    EstimatorState,
    GazeCommand,
    GazeDemand,
    GazeSelect,
    GazeState,
    GazeStateName,
    Odometry,
    Prediction,
    TraceResult,
)

PARK_TOLERANCE_RAD = math.radians(1.0)  # this close to the park pose, the head is parked
TAKING_UP = ("park", "search", "lost")  # the states that take a detection up (in a row)
MOVE_THEN_LOOK = ("look-and-move", "move-wait-move")  # controls that ignore frames while moving
PID_STALE_FRAMES = 3  # the pid stops the head after this many frame periods without a detection


class GazeController:
    """Feed it what arrives (`odometry`, `prediction`, `detection`, `candidates`, `edge`,
    `command`), call `tick(wall_ns, mono_s)` at the control rate, publish what it decides."""

    def __init__(self, rig: Rig, mono_s: float) -> None:
        gaze = self.gaze = rig.gaze
        self.lens = lens = ZoomLens.from_section(rig.camera)
        self.kinematics = kinematics = HeadKinematics.from_section(rig.head)
        self.park = rig.head.park_rad
        self.fovea_rad = math.radians(gaze.fovea_half_angle_deg)
        move_limits = MoveLimits(rig.head.rate_max_rad_s, rig.head.accel_max_rad_s2)
        frame_period_s = rig.camera.frame_period_s
        # the parts, each holding the state of its concern
        self.shaper = DemandShaper(rig.head)
        self.hold = Hold()
        self.sightings = Sightings(gaze, frame_period_s, lens, kinematics)
        self.pursuit = Pursuit(gaze, self.fovea_rad, lens, kinematics)
        settling = Settling(
            kinematics, math.radians(gaze.saccade_tolerance_deg), gaze.settle_ms / 1000.0
        )
        self.move = Move(move_limits, settling)  # saccade or look-and-move
        self.look_and_move = LookAndMove(self.move)
        limits_rad = (self.shaper.limiter.pan_limits_rad, self.shaper.limiter.tilt_limits_rad)
        self.pid = PixelPid(
            (gaze.pid_kp_per_s, gaze.pid_ki_per_s2, gaze.pid_kd_s),
            gaze.pid_deadband_px,
            move_limits.rate_max_rad_s,
            limits_rad,
            PID_STALE_FRAMES * frame_period_s,
        )
        self.lost_search = LostSearch(
            gaze, self.fovea_rad, rig.calibration.camera_xyz_m, move_limits, frame_period_s
        )
        self.tracer = LineTracer(gaze, lens, kinematics, limits_rad)
        self.choice = TargetChoice(rig, lens, kinematics)
        homography = GroundHomography.from_section(rig.calibration)
        roll = partial(image_roll_rad, homography, kinematics) if homography is not None else None
        self.zoom = ZoomControl(
            gaze, lens, self.sightings, self.pursuit, rig.calibration.camera_xyz_m, roll
        )
        self.operator = OperatorControl(self)  # park, search, hold, resume
        # the state machine
        self.state: GazeStateName = "park"
        self.entered_s = mono_s
        self.entered_ns = 0
        self.pending: list[GazeState] = []  # this tick's transitions
        self.finished_trace: TraceResult | None = None
        self.lost_region_rad: float | None = None  # lost: the search region's radius
        self.odometry: Odometry | None = None
        self.last_tick_s = mono_s
        self.own_counts = dict.fromkeys(
            ("transitions", "saccades", "ignored_while_moving", "refused_odometry"), 0
        )

    @property
    def counts(self) -> dict[str, int]:
        """What the controller and its parts counted."""
        counts = dict(self.own_counts)
        counts["ignored_while_moving"] += self.sightings.turning_candidates
        counts["stale_predictions"] = self.pursuit.stale_predictions
        counts.update(self.choice.counts)
        return counts

    @property
    def clamps(self) -> int:
        return self.shaper.clamps

    # -- inputs ----------------------------------------------------------------------------

    def on_odometry(self, odometry: Odometry, wall_ns: int | None = None) -> None:
        """The head's newest pose; live (with our clock), one stamped in the future or older
        than the one held is refused and counted."""
        if wall_ns is not None and (
            odometry.t_capture_ns - wall_ns > FUTURE_TOLERANCE_NS
            or (self.odometry is not None and odometry.t_capture_ns < self.odometry.t_capture_ns)
        ):
            self.own_counts["refused_odometry"] += 1
            return
        self.odometry = odometry

    def on_prediction(self, prediction: Prediction) -> None:
        if self.choice.accepts(prediction):  # the chosen track's only
            self.pursuit.on_prediction(prediction)

    def on_estimator_state(self, state: EstimatorState, wall_ns: int) -> None:
        """The estimator's tracks: the chosen one may have ended, or the rule picks one."""
        self._retarget(self.choice.on_state(state, self._head_rad()), wall_ns)

    def on_select(self, select: GazeSelect, wall_ns: int) -> None:
        """An operator's choice of target (`gazed select`)."""
        self._retarget(self.choice.on_select(select, self._head_rad()), wall_ns)

    def on_detection(self, detection: Detection, wall_ns: int | None = None) -> None:
        """Vision's report on one frame, found or not; `wall_ns`: when it came in (None: not
        known, its lag not counted)."""
        if wall_ns is not None:
            self.sightings.arrived(detection.t_capture_ns, wall_ns)
        detection = focus(detection, self.pursuit.prediction, self.lens, self.kinematics)
        if not detection.found or detection.head is None:
            return
        if (
            self.state == "saccade"
            or (self.gaze.control in MOVE_THEN_LOOK and not self.look_and_move.looking)
            or (self.state == "lost" and self.lost_search.from_the_move(detection.t_capture_ns))
        ):
            self.own_counts["ignored_while_moving"] += 1  # captured mid-move: blurred, off track
            return
        if self.state == "pursuit":
            self.pursuit.on_detection(detection)
            if self.gaze.control == "pid":
                error_rad, error_px = pixel_error(self.lens, self.kinematics, detection)
                self.pid.update(error_rad, error_px, detection.t_capture_ns)
        self.sightings.take(detection, count=self.state in TAKING_UP)

    def on_candidates(self, candidates: Candidates, wall_ns: int | None = None) -> None:
        if wall_ns is not None:
            self.sightings.arrived(candidates.t_capture_ns, wall_ns)
        self.sightings.on_candidates(candidates)

    def on_edge(self, edge: EdgeObservation) -> None:
        self.tracer.on_edge(edge)

    def on_command(self, command: GazeCommand, wall_ns: int, mono_s: float) -> None:
        """`trace` a ground line's edge from a start gaze, `stop` it, or an operator's command."""
        if command.command == "stop":
            if self.tracer.job is not None:
                self._finish_trace("stopped by request", wall_ns, mono_s)
            return
        if self.tracer.job is not None:
            self._finish_trace("replaced by a new request", wall_ns, mono_s)
        if self.operator.on_command(command.command, wall_ns, mono_s):
            return
        self.tracer.begin(command)
        self.enter("trace", f"tracing a line ({command.request_id})", wall_ns, mono_s)

    # -- the loop body ------------------------------------------------------------------------

    def tick(self, wall_ns: int, mono_s: float) -> Decision:
        dt_s = max(mono_s - self.last_tick_s, 1e-3)
        self.last_tick_s = mono_s
        handlers = {
            "park": self._park,
            "search": self._search,
            "saccade": self._saccade,
            "pursuit": self._pursuit,
            "lost": self._lost,
            "trace": self._trace,
        }
        demand = (self.operator.handler or handlers[self.state])(wall_ns, mono_s)
        if demand is None or demand.kind != "hold":
            self.hold.release()
        if demand is not None:
            demand = self.shaper.shape(demand, dt_s)
            if demand is None:  # a non-finite number reached the demand: hold instead
                demand = self._hold(wall_ns)
        demand = self.zoom.apply(
            demand,
            self.state,
            self.odometry,
            wall_ns,
            mono_s,
            self.pursuit.actuation_s,
            self.lost_region_rad if self.state == "lost" else None,
        )
        transitions, self.pending = tuple(self.pending), []
        trace, self.finished_trace = self.finished_trace, None
        return Decision(demand, transitions, trace)

    def enter(self, state: GazeStateName, reason: str, wall_ns: int, mono_s: float) -> None:
        if state == self.state:
            return
        self.pending.append(
            state_message(state, self.state, reason, self.choice.target_id, wall_ns)
        )
        self.state = state
        self.entered_s = mono_s
        self.entered_ns = wall_ns
        self.move.settling.restart()
        self.sightings.restart_run()
        self.lost_search.reset()
        self.lost_region_rad = None
        self.pid.restart()
        self.own_counts["transitions"] += 1

    def _retarget(self, change: ChoiceChange | None, wall_ns: int) -> None:
        if change is None:
            return
        held = self.pursuit.prediction
        if held is not None and held.track_id not in (None, change.target_id):
            self.pursuit.restart()  # another track's predictions: not the new target's
        self.pending.append(
            state_message(self.state, self.state, change.reason, change.target_id, wall_ns)
        )

    def _head_rad(self) -> tuple[float, float] | None:
        o = self.odometry
        return (o.pan_rad, o.tilt_rad) if o is not None else None

    # -- states ------------------------------------------------------------------------------

    def _park(self, wall_ns: int, mono_s: float) -> GazeDemand | None:
        # a target already in view (a restarted controller, the head held where it was) is
        # taken up at once rather than parked away from
        taken = self._take_up_detection(wall_ns, mono_s)
        if taken is not None:
            return taken
        if at_goal(self.odometry, self.park, PARK_TOLERANCE_RAD, self.kinematics):
            self.enter("search", "head parked", wall_ns, mono_s)
        return make_demand("park", *self.park, wall_ns)

    def _search(self, wall_ns: int, mono_s: float) -> GazeDemand | None:
        taken = self._take_up_detection(wall_ns, mono_s)
        if taken is not None:
            return taken
        candidate = self.sightings.best_candidate(wall_ns, since_ns=self.entered_ns)
        if candidate is not None:
            return self._start_saccade(candidate, "motion candidate", wall_ns, mono_s)
        return self._hold(wall_ns)

    def _take_up_detection(self, wall_ns: int, mono_s: float) -> GazeDemand | None:
        """A detection since this state began, the last of `reacquire_detections` in a row:
        pursue it if it is in the fovea, else saccade."""
        detection = self.sightings.recent(wall_ns, since_ns=self.entered_ns)
        if detection is None or self.sightings.in_a_row < self.gaze.reacquire_detections:
            return None
        head = detection.head
        assert head is not None
        target = self.sightings.aim(detection)
        off_axis_rad = angle_between(
            target.pan_rad, target.tilt_rad, head.pan_rad, head.tilt_rad, self.kinematics
        )
        if off_axis_rad <= self.fovea_rad:
            self.enter("pursuit", "target in the fovea", wall_ns, mono_s)
            return self._pursuit(wall_ns, mono_s)
        return self._start_saccade(target, "detection outside the fovea", wall_ns, mono_s)

    def _start_saccade(
        self, target: Aim, reason: str, wall_ns: int, mono_s: float
    ) -> GazeDemand | None:
        """Aim where the target will be when the move (at the head's limits) is over."""
        goal = self.move.start(target, self.odometry, wall_ns)
        if goal is None:
            return self._hold(wall_ns)
        self.own_counts["saccades"] += 1
        self.enter("saccade", reason, wall_ns, mono_s)
        return make_demand("position", goal.pan_rad, goal.tilt_rad, wall_ns)

    def _saccade(self, wall_ns: int, mono_s: float) -> GazeDemand | None:
        goal = self.move.goal
        assert goal is not None
        if self.move.over(self.odometry, mono_s):
            self.sightings.forget()  # only detections from after the move count
            self.pursuit.landed(self._head_rad(), wall_ns)
            self.enter("pursuit", "settled on the target", wall_ns, mono_s)
            self.look_and_move.restart()
            return self._hold(wall_ns)
        if mono_s - self.entered_s > self.gaze.saccade_timeout_ms / 1000.0:
            self.enter("search", "saccade did not settle", wall_ns, mono_s)
            return self._hold(wall_ns)
        return make_demand("position", goal.pan_rad, goal.tilt_rad, wall_ns)

    def _pursuit(self, wall_ns: int, mono_s: float) -> GazeDemand | None:
        since_ns = self.entered_ns - round(self.gaze.lost_after_ms * 1e6)
        detection = self.sightings.recent(wall_ns, since_ns=since_ns)
        if detection is None and mono_s - self.entered_s > self.gaze.lost_after_ms / 1000.0:
            self.enter("lost", f"no detection for {self.gaze.lost_after_ms:g} ms", wall_ns, mono_s)
            return self._lost(wall_ns, mono_s)
        if self.gaze.control in MOVE_THEN_LOOK:
            return self._look_and_move(wall_ns, mono_s)
        if self.gaze.control == "pid":
            demand = self.pid.demand(self.odometry, wall_ns, self.sightings.found)
            return demand if demand is not None else self._hold(wall_ns)
        return self._follow(wall_ns, correction=True)

    def _look_and_move(self, wall_ns: int, mono_s: float) -> GazeDemand | None:
        def target(found: Detection) -> Aim:
            if self.gaze.control == "move-wait-move":  # where it was seen, no motion assumed
                seen = self.sightings.aim(found)
                return Aim(seen.t_ns, seen.pan_rad, seen.tilt_rad)
            return self.pursuit.aim(wall_ns) or self.sightings.aim(found)

        found, since_ns = self.sightings.found, self.entered_ns
        demand = self.look_and_move.step(found, target, self.odometry, since_ns, wall_ns, mono_s)
        return demand if demand is not None else self._hold(wall_ns)

    def _lost(self, wall_ns: int, mono_s: float) -> GazeDemand | None:
        detection = self.sightings.recent(wall_ns, since_ns=self.entered_ns)
        if detection is not None and self.sightings.in_a_row >= self.gaze.reacquire_detections:
            self.enter("pursuit", "target seen again", wall_ns, mono_s)
            return self._pursuit(wall_ns, mono_s)
        lost_s = mono_s - self.entered_s
        if lost_s > self.gaze.search_after_ms / 1000.0:
            self.enter("search", f"lost for {lost_s:.1f} s", wall_ns, mono_s)
            return self._hold(wall_ns)
        prediction = self.pursuit.prediction
        region_rad = self.lost_search.radius_rad(prediction, lost_s)
        self.lost_region_rad = region_rad  # the zoom's view holds it
        if region_rad > self.lost_search.max_radius_rad:
            # the prediction says too little (a track too young for a velocity, or coasted too
            # long): the whole frame's motion, watched from a still head, says more
            reason = f"search region {math.degrees(region_rad):.0f}° wide after {lost_s:.1f} s"
            self.enter("search", reason, wall_ns, mono_s)
            return self._hold(wall_ns)
        if self.pursuit.aim(wall_ns) is None:  # nothing to coast on: the whole frame says more
            self.enter("search", "no prediction to coast on", wall_ns, mono_s)
            return self._hold(wall_ns)
        demand = self._follow(wall_ns, correction=False)
        assert demand is not None and prediction is not None
        stop, began = self.lost_search.stop(
            region_rad, prediction.visual_latency_s, wall_ns, mono_s
        )
        if began:
            self.sightings.restart_run()  # a look from the new stop starts a new run
        if stop is None:  # the region fits in the fovea: keep it on the prediction
            return demand
        pan_rad, tilt_rad = stop.offset_rad
        return demand.model_copy(
            update={"pan_rad": demand.pan_rad + pan_rad, "tilt_rad": demand.tilt_rad + tilt_rad}
        )

    def _trace(self, wall_ns: int, mono_s: float) -> GazeDemand | None:
        job = self.tracer.job
        if job is None:
            self.enter("search", "no line to trace", wall_ns, mono_s)
            return self._hold(wall_ns)
        ended = self.tracer.step(self.odometry, wall_ns, mono_s)
        if ended is not None:
            return self._finish_trace(ended, wall_ns, mono_s)
        return make_demand("position", *job.goal_rad, wall_ns)

    def _finish_trace(self, reason: str, wall_ns: int, mono_s: float) -> GazeDemand | None:
        result = self.finished_trace = self.tracer.end(reason, wall_ns)
        samples = len(result.samples_rad)
        self.enter("search", f"trace ended: {reason} ({samples} samples)", wall_ns, mono_s)
        return self._hold(wall_ns)

    # -- demands ---------------------------------------------------------------------------------

    def _hold(self, wall_ns: int) -> GazeDemand | None:
        return self.hold.demand(self.odometry, wall_ns)

    def _follow(self, wall_ns: int, correction: bool) -> GazeDemand | None:
        """Pursuit's demand; a hold with nothing to follow."""
        demand = self.pursuit.demand(wall_ns, self.sightings.found, correction)
        return demand if demand is not None else self._hold(wall_ns)
