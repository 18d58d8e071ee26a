"""The `estimator` process: detections -> target on the ground -> filter -> prediction over the
loop's latency (DESIGN §5; seed 000 §4-6).

Inputs: `vision/detection` (the target's pixel and independent image velocity, with the head
pose at capture), `servo/command` (the stamps of the demands as written) and `servo/status` (the
head's response lag): the actuation latency.
Outputs: `estimator/state` (the filter's state, covariance, model probabilities) and
`estimator/prediction` (pan, tilt and their rates for the instant the demand made from it will
act: now + the actuation latency, i.e. capture + visual latency + actuation latency) after every
detection; `estimator/event` when the most likely model changes.
Settings: [estimator] filter and its noises, gate, coasting; [camera], [head] and
[calibration] (homography, height correction) for the geometry.

A frame without a detection (or without a head pose, or with a ray above the horizon) is a
predict-only step: the track coasts. With no detection at all for two frame periods (vision
restarting, frames lost) the track is still predicted at the camera's rate, marked coasting,
for up to `coast_max_ms`, so the gaze keeps following where the target should be. Both latencies
are measured live: visual from stamps, as the time from capture to the detection's arrival here;
actuation as the median time from this process's stamp to the servo's write stamp on
`servo/command`, plus the time the head then takes to get where it was told (the response lag
the servo measures from the head's position reports, `gazed.servo.response_lag`; 0 until
measured, and for a head that cannot report its position).
"""

from __future__ import annotations

import logging
import time
from dataclasses import replace

from gazed.bus import Bus
from gazed.config import Rig
from gazed.estimation import PredictedState, build_estimator
from gazed.estimation.observation import gaze_measurement, ground_measurement
from gazed.geometry.camera import CameraModel
from gazed.geometry.ground import GroundGeometry, MeasurementNoise
from gazed.geometry.homography import HorizonError
from gazed.geometry.kinematics import HeadKinematics
from gazed.latency import LatencyWindow, stage_gap_s
from gazed.messages import Detection, EstimatorState, ManeuverEvent, Prediction
from gazed.topics import (
    ESTIMATOR_EVENT,
    ESTIMATOR_PREDICTION,
    ESTIMATOR_STATE,
    SERVO_COMMAND,
    SERVO_STATUS,
    VISION_DETECTION,
)
from services.runtime import HealthReport, Now, main

STAGE = "estimator"
IDLE_S = 1.0
FUTURE_TOLERANCE_NS = 1_000_000_000  # a detection captured further ahead of our clock is bogus

log = logging.getLogger("gazed.estimator")


class EstimatorService:
    def __init__(self, rig: Rig, bus: Bus) -> None:
        section = rig.estimator
        self.filter = section.filter
        self.predict_over_latency = section.predict_over_latency
        self.estimator = build_estimator(section)
        self.camera = CameraModel.from_section(rig.camera)
        self.kinematics = HeadKinematics.from_section(rig.head)
        # image-cv works on gaze angles alone; every other mode needs the ground homography
        self.geometry = GroundGeometry.from_rig(rig) if self.filter != "image-cv" else None
        # a detector that reports the ground contact point (`background`) needs no height correction
        self.contact_geometry = (
            replace(self.geometry, height=None) if self.geometry is not None else None
        )
        self.noise = MeasurementNoise.from_head(
            rig.head, section.pixel_noise_px, section.pixel_rate_noise_px_s
        )
        self.detections = bus.subscribe(VISION_DETECTION, capacity=64, immediate=True)
        self.commands = bus.subscribe(SERVO_COMMAND, capacity=256)
        self.servo_status = bus.subscribe(SERVO_STATUS, capacity=4)
        self.states = bus.publisher(ESTIMATOR_STATE)
        self.predictions = bus.publisher(ESTIMATOR_PREDICTION)
        self.events = bus.publisher(ESTIMATOR_EVENT)
        self.visual = LatencyWindow(default_s=0.0)
        self.actuation = LatencyWindow(default_s=section.actuation_latency_default_ms / 1000.0)
        self.head_response_s = 0.0
        self.counts = {
            "detections": 0,
            "measured": 0,
            "coasted": 0,
            "no_head_pose": 0,
            "above_horizon": 0,
            "silent_predictions": 0,
            "rejected": 0,
            "from_the_future": 0,
            "off_the_image": 0,
        }
        self.stage_ms = 0.0
        self.frame_period_s = rig.camera.frame_period_s
        self.silence_s = 2.0 * self.frame_period_s  # no detection for this long: predict anyway
        self.coast_max_s = section.coast_max_ms / 1000.0
        self.last_detection_s: float | None = None

    def step(self, now: Now) -> float:
        for command in self.commands.take():
            gap = stage_gap_s(command, STAGE, "servo")
            if gap is not None:
                self.actuation.add(gap)
        for status in self.servo_status.take():
            self.head_response_s = status.response_lag_s or 0.0
        detections = self.detections.take()
        for detection in detections:
            started = time.perf_counter()
            if not self._plausible(detection, now):
                continue
            try:
                self._observe(detection, now)
                self._publish(detection, time.time_ns())
            except ValueError as exc:  # the filter refused it (e.g. not newer than the track)
                self.counts["rejected"] += 1
                log.debug("detection %d rejected: %s", detection.seq, exc)
            self.stage_ms = (time.perf_counter() - started) * 1e3
        if detections:
            self.last_detection_s = now.mono_s
            return self.silence_s
        return self._silent(now)

    @property
    def actuation_s(self) -> float:
        """From this process's stamp until the head is where the demand told it to be."""
        return self.actuation.median_s + self.head_response_s

    def _silent(self, now: Now) -> float:
        """No detection for a while (vision restarting, frames lost): keep predicting from the
        track, marked coasting, at the camera's rate, for up to coast_max_ms."""
        if self.last_detection_s is None:
            return IDLE_S
        silent_s = now.mono_s - self.last_detection_s
        if silent_s > self.coast_max_s:
            return IDLE_S
        if silent_s >= self.silence_s:
            t_effect_ns = now.wall_ns + round(self.actuation_s * 1e9)
            predicted = self.estimator.predict(t_effect_ns / 1e9)
            if predicted is not None:
                stamps = ((STAGE, now.wall_ns),)
                self.predictions.put(
                    self._prediction(predicted, now.wall_ns, stamps, t_effect_ns, now.wall_ns, True)
                )
                self.counts["silent_predictions"] += 1
        return self.frame_period_s

    def _plausible(self, detection: Detection, now: Now) -> bool:
        """Well-formed is not enough: a capture from the future, or a pixel far off the image,
        is dropped and counted (it would poison the track)."""
        if detection.t_capture_ns - now.wall_ns > FUTURE_TOLERANCE_NS:
            self.counts["from_the_future"] += 1
            return False
        w, h = detection.width_px, detection.height_px
        if detection.found and not (
            -w <= detection.u_px <= 2 * w and -h <= detection.v_px <= 2 * h
        ):
            self.counts["off_the_image"] += 1
            return False
        return True

    def _observe(self, detection: Detection, now: Now) -> None:
        self.counts["detections"] += 1
        self.visual.add((now.wall_ns - detection.t_capture_ns) / 1e9)
        t_s = detection.t_capture_ns / 1e9
        if not detection.found:
            self._coast(t_s)
            return
        try:
            if self.geometry is None:
                measurement = gaze_measurement(detection, self.camera, self.kinematics, self.noise)
            else:
                geometry = (
                    self.contact_geometry if detection.point == "ground-contact" else self.geometry
                )
                assert geometry is not None
                measurement = ground_measurement(detection, geometry, self.noise)
        except HorizonError:
            self.counts["above_horizon"] += 1
            self._coast(t_s)
            return
        except ValueError:
            self.counts["no_head_pose"] += 1
            self._coast(t_s)
            return
        self.estimator.update(measurement)
        self.counts["measured"] += 1

    def _coast(self, t_s: float) -> None:
        self.estimator.coast(t_s)
        self.counts["coasted"] += 1

    def _publish(self, detection: Detection, t_ns: int) -> None:
        stamps = (*detection.stamps, (STAGE, t_ns))
        t_effect_ns = t_ns + round(self.actuation_s * 1e9)
        # without prediction over the latency (the baseline), the estimate at the capture is
        # offered as if it held when the demand acts
        t_predicted_s = (t_effect_ns if self.predict_over_latency else detection.t_capture_ns) / 1e9
        predicted = self.estimator.predict(t_predicted_s)
        if predicted is None:
            return
        coasting = not detection.found
        # the prediction first: the gaze controller waits for it, nobody waits for the state
        self.predictions.put(
            self._prediction(predicted, detection.t_capture_ns, stamps, t_effect_ns, t_ns, coasting)
        )
        now_state = self.estimator.predict(detection.t_capture_ns / 1e9)
        if now_state is not None:
            probabilities = self.estimator.model_probabilities()
            position, velocity = now_state.position.tolist(), now_state.velocity.tolist()
            on_ground = self.geometry is not None
            self.states.put(
                EstimatorState(
                    t_capture_ns=detection.t_capture_ns,
                    stamps=stamps,
                    filter=self.filter,
                    x=(*position, *velocity),
                    P=tuple(map(tuple, now_state.covariance.tolist())),
                    model_probabilities=probabilities,
                    most_likely=max(probabilities, key=probabilities.__getitem__),
                    ground_xy_m=tuple(position) if on_ground else None,
                    ground_velocity_m_s=tuple(velocity) if on_ground else None,
                    coasting=coasting,
                )
            )
        for event in self.estimator.drain_events():
            self.events.put(
                ManeuverEvent(
                    t_capture_ns=detection.t_capture_ns,
                    stamps=stamps,
                    model=event.model,
                    previous_model=event.previous_model,
                    t_start_ns=round(event.t_start_s * 1e9),
                    previous_duration_s=event.previous_duration_s,
                    mean_s_dot_m_s2=event.mean_s_dot_m_s2,
                    mean_theta_dot_rad_s=event.mean_theta_dot_rad_s,
                )
            )

    def _prediction(
        self,
        predicted: PredictedState,
        t_capture_ns: int,
        stamps: tuple[tuple[str, int], ...],
        t_effect_ns: int,
        t_ns: int,
        coasting: bool,
    ) -> Prediction:
        if self.geometry is None:  # image-cv: the state is the gaze itself
            pan, tilt = predicted.position.tolist()
            pan_rate, tilt_rate = predicted.velocity.tolist()
            ground = velocity = cov = None
        else:
            x, y = predicted.position.tolist()
            vx, vy = predicted.velocity.tolist()
            pan, tilt, pan_rate, tilt_rate = self.geometry.gaze_motion_from_ground(x, y, vx, vy)
            ground, velocity = (x, y), (vx, vy)
            cov = tuple(map(tuple, predicted.covariance[:2, :2].tolist()))
        return Prediction(
            t_capture_ns=t_capture_ns,
            stamps=stamps,
            filter=self.filter,
            t_effect_ns=t_effect_ns,
            horizon_s=(t_effect_ns - t_capture_ns) / 1e9,
            pan_rad=pan,
            tilt_rad=tilt,
            pan_rate_rad_s=pan_rate,
            tilt_rate_rad_s=tilt_rate,
            ground_xy_m=ground,
            ground_velocity_m_s=velocity,
            position_cov_m2=cov,
            visual_latency_s=(t_ns - t_capture_ns) / 1e9,
            actuation_latency_s=self.actuation_s,
            coasting=coasting,
        )

    def health(self) -> HealthReport:
        counters = dict(self.counts)
        counters.update(self.estimator.health())
        return HealthReport(
            counters=counters,
            stage_ms={
                "step": round(self.stage_ms, 3),
                "visual_latency": round(self.visual.median_s * 1e3, 2),
                "actuation_latency": round(self.actuation_s * 1e3, 2),
                "head_response_lag": round(self.head_response_s * 1e3, 2),
            },
            notes={"filter": self.filter, "most_likely": self.estimator.most_likely()},
        )

    def close(self) -> None:
        pass


def build(rig: Rig, bus: Bus) -> EstimatorService:
    return EstimatorService(rig, bus)


if __name__ == "__main__":
    raise SystemExit(main("estimator", build))
