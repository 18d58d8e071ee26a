"""The `estimator` process: detections -> target on the ground -> filter -> prediction over the
loop's latency (DESIGN §5; seed 000 §4-6). The work is `gazed.estimation.target_tracker`.

Inputs: `vision/detection` (every mover's pixel and independent image velocity, with the head
pose at capture), `gaze/state` (the track the gaze follows), `servo/command` (the stamps of the
demands as written) and `servo/status` (the head's response lag): the actuation latency
(`gazed.estimation.loop_latency`).
Outputs: `estimator/prediction` (the chosen track's pan, tilt and their rates for the instant the
demand made from it will act: now + the actuation latency) and `estimator/state` (every track,
and the chosen one's state, covariance, model probabilities) after every detection, the
prediction first; `estimator/event` when the chosen track's most likely model changes; with no
detection for two frame periods, coasting predictions at the camera's rate for up to
`coast_max_ms`.
Settings: [estimator] filter and its noises, gate, coasting, track confirmation; [camera],
[head] and [calibration] (homography, height correction) for the geometry.
"""

from __future__ import annotations

import time

from gazed.bus import Bus
from gazed.config import Rig
from gazed.estimation.target_tracker import TargetTracker
from gazed.topics import (
    ESTIMATOR_EVENT,
    ESTIMATOR_PREDICTION,
    ESTIMATOR_STATE,
    GAZE_STATE,
    SERVO_COMMAND,
    SERVO_STATUS,
    VISION_DETECTION,
)
from services.runtime import HealthReport, Now, main

STAGE = "estimator"


class EstimatorService:
    def __init__(self, rig: Rig, bus: Bus) -> None:
        self.tracker = TargetTracker(rig, STAGE)
        self.detections = bus.subscribe(VISION_DETECTION, capacity=64, immediate=True)
        self.commands = bus.subscribe(SERVO_COMMAND, capacity=256)
        self.servo_status = bus.subscribe(SERVO_STATUS, capacity=4)
        self.gaze_states = bus.subscribe(GAZE_STATE, capacity=16)
        self.states = bus.publisher(ESTIMATOR_STATE)
        self.predictions = bus.publisher(ESTIMATOR_PREDICTION)
        self.events = bus.publisher(ESTIMATOR_EVENT)
        self.stage_ms = 0.0

    def step(self, now: Now) -> float:
        tracker = self.tracker
        for command in self.commands.take():
            tracker.latency.command_written(command)
        for status in self.servo_status.take():
            tracker.latency.head_responds(status.response_lag_s)
        for gaze_state in self.gaze_states.take():
            tracker.choose(gaze_state.target_id)
        detections = self.detections.take()
        for detection in detections:
            started = time.perf_counter()
            if not tracker.plausible(detection, now.wall_ns):
                continue
            update = tracker.update(detection, now.wall_ns)
            if update is not None:
                # the prediction first: the gaze controller waits for it, nobody waits for the state
                if update.prediction is not None:
                    self.predictions.put(update.prediction)
                state, events = tracker.settle(update)
                if state is not None:
                    self.states.put(state)
                for event in events:
                    self.events.put(event)
            self.stage_ms = (time.perf_counter() - started) * 1e3
        if detections:
            return tracker.heard(now.mono_s)
        prediction, wait_s = tracker.silent(now.wall_ns, now.mono_s)
        if prediction is not None:
            self.predictions.put(prediction)
        return wait_s

    def health(self) -> HealthReport:
        tracker, latency = self.tracker, self.tracker.latency
        return HealthReport(
            counters=tracker.counters(),
            stage_ms={
                "step": round(self.stage_ms, 3),
                "visual_latency": round(latency.visual_s * 1e3, 2),
                "actuation_latency": round(latency.actuation_s * 1e3, 2),
                "head_response_lag": round(latency.head_response_s * 1e3, 2),
            },
            notes={
                "filter": tracker.filter,
                "most_likely": tracker.most_likely(),
                "target": str(tracker.target_id),
            },
        )

    def close(self) -> None:
        pass


def build(rig: Rig, bus: Bus) -> EstimatorService:
    return EstimatorService(rig, bus)


if __name__ == "__main__":
    raise SystemExit(main("estimator", build))
