"""The `gaze` process: decides where the head looks (DESIGN §7; seed 000 §1-2, §6).

Inputs: `estimator/prediction` (the chosen track's are used), `estimator/state` (every track,
for the choice of target), `vision/detection`, `vision/candidates`, `servo/odometry`,
`gaze/command` (trace requests from `gazed calibrate trace`; an operator's park, search,
hold and resume from the live view or `gazed operate`), `vision/edge` (while tracing),
`gaze/select` (an operator's choice of target, from `gazed select`).
Outputs: `gaze/demand` (joint angles and feed-forward rates, limited) at `[gaze] rate_hz` and at
once after each new prediction; `gaze/state` on every transition and every change of target,
with its reason and the chosen track's id; `gaze/trace` (the samples of a traced line) when a
trace ends.
Settings: [gaze] (control mode, rates, fovea, settling, lost and search timing, feedback gain,
the rule that picks the target), [head] (limits, park pose, kinematics), [camera] (pixels to
angles), [calibration] camera_xyz_m (the lost-search region in angles).

The state machine itself is `gazed.gaze.controller.GazeController`, and when it ticks is
`gazed.gaze.schedule.TickSchedule`; this module only moves messages in and out of them.
"""

from __future__ import annotations

import logging

from gazed.bus import Bus
from gazed.config import Rig
from gazed.gaze.controller import GazeController
from gazed.gaze.schedule import TickSchedule
from gazed.topics import (
    ESTIMATOR_PREDICTION,
    ESTIMATOR_STATE,
    GAZE_COMMAND,
    GAZE_DEMAND,
    GAZE_SELECT,
    GAZE_STATE,
    GAZE_TRACE,
    SERVO_ODOMETRY,
    VISION_CANDIDATES,
    VISION_DETECTION,
    VISION_EDGE,
)
from services.runtime import HealthReport, Now, main

log = logging.getLogger("gazed.gaze")


class GazeService:
    def __init__(self, rig: Rig, bus: Bus) -> None:
        self.controller = GazeController(rig, Now.read().mono_s)
        self.schedule = TickSchedule(rig.gaze.rate_hz, rig.camera.frame_period_s)
        self.predictions = bus.subscribe(ESTIMATOR_PREDICTION, capacity=16, immediate=True)
        self.detections = bus.subscribe(VISION_DETECTION, capacity=16)
        self.candidates = bus.subscribe(VISION_CANDIDATES, capacity=4)
        self.odometry = bus.subscribe(SERVO_ODOMETRY, capacity=16)
        self.commands = bus.subscribe(GAZE_COMMAND, capacity=16)
        self.edges = bus.subscribe(VISION_EDGE, capacity=4)
        self.estimates = bus.subscribe(ESTIMATOR_STATE, capacity=16)
        self.selections = bus.subscribe(GAZE_SELECT, capacity=16)
        self.traces = bus.publisher(GAZE_TRACE)
        self.demands = bus.publisher(GAZE_DEMAND)
        self.states = bus.publisher(GAZE_STATE)
        self.demands_sent = 0

    def step(self, now: Now) -> float:
        c = self.controller
        for odometry in self.odometry.take():
            c.on_odometry(odometry, now.wall_ns)
        for candidates in self.candidates.take():
            c.on_candidates(candidates, now.wall_ns)
        for detection in self.detections.take():
            c.on_detection(detection, now.wall_ns)
        for edge in self.edges.take():
            c.on_edge(edge)
        for command in self.commands.take():
            c.on_command(command, now.wall_ns, now.mono_s)
            self.schedule.act_now(now.mono_s)
        for estimate in self.estimates.take():
            c.on_estimator_state(estimate, now.wall_ns)
        for select in self.selections.take():
            c.on_select(select, now.wall_ns)
        fresh = self.predictions.take()
        for prediction in fresh:
            c.on_prediction(prediction)
        if self.schedule.due(now.mono_s, fresh_prediction=bool(fresh)):
            decision = c.tick(now.wall_ns, now.mono_s)
            for t in decision.transitions:
                log.debug("%s -> %s: %s", t.previous, t.state, t.reason)  # gazed run logs them
                self.states.put(t)
            if decision.demand is not None:
                self.demands.put(decision.demand)
                self.demands_sent += 1
            if decision.trace is not None:
                self.traces.put(decision.trace)
        return self.schedule.wait_s(now.mono_s)

    def health(self) -> HealthReport:
        c = self.controller
        counters = dict(c.counts)
        counters.update(demands=self.demands_sent, clamps=c.clamps, refused=c.shaper.refused)
        return HealthReport(
            counters=counters, notes={"state": c.state, "target": str(c.choice.target_id)}
        )

    def close(self) -> None:
        pass


def build(rig: Rig, bus: Bus) -> GazeService:
    return GazeService(rig, bus)


if __name__ == "__main__":
    raise SystemExit(main("gaze", build))
