"""The estimator's work per detection: the target on the ground, the filter, and the prediction to
the instant a demand made from it acts (DESIGN §5; seed 000 §4-6).

A detection that is not plausible — captured further in the future than `FUTURE_TOLERANCE_NS`,
or found at a pixel far off the image — is dropped and counted: it would poison the track.
A frame without a detection (or without a head pose, or with a ray above the horizon) is a
predict-only step: the track coasts. A detection the filter refuses (not newer than the track)
is counted as rejected.

After every detection the track is predicted to its effect time, now + the actuation latency
(i.e. capture + visual latency + actuation latency, `LoopLatency`); without prediction over the
latency (`predict_over_latency = false`, the baseline) the estimate at the capture is offered
as if it held then. With no detection for two frame periods (vision restarting, frames lost)
the track is still predicted at the camera's rate, marked coasting, for up to `coast_max_ms`,
so the gaze keeps following where the target should be.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

from gazed.config import Rig
from gazed.estimation.factory import build_estimator
from gazed.estimation.loop_latency import LoopLatency
from gazed.estimation.observation import gaze_measurement, ground_measurement
from gazed.estimation.results import PredictedState
from gazed.geometry.camera import CameraModel
from gazed.geometry.ground import GroundGeometry, MeasurementNoise
from gazed.geometry.homography import HorizonError
from gazed.geometry.kinematics import HeadKinematics
from gazed.messages import Detection, EstimatorState, ManeuverEvent, Prediction, Stamp

IDLE_S = 1.0  # how long to wait when there is nothing to predict
FUTURE_TOLERANCE_NS = 1_000_000_000  # a detection captured further ahead of our clock is bogus

log = logging.getLogger("gazed.estimator")


@dataclass(frozen=True)
class TrackUpdate:
    """One detection taken: the prediction made from it (None: no track to predict), and what
    the state and events that follow it carry."""

    seq: int
    t_capture_ns: int
    stamps: tuple[Stamp, ...]
    coasting: bool
    prediction: Prediction | None


class TargetTracker:
    """Detections -> ground measurements -> the rig's filter -> predictions to the effect time.

    `stage` is the name the estimator stamps its messages with; `clock_ns` the wall clock of
    those stamps."""

    def __init__(self, rig: Rig, stage: str, clock_ns: Callable[[], int] = time.time_ns) -> None:
        section = rig.estimator
        self.stage = stage
        self.clock_ns = clock_ns
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
        self.latency = LoopLatency(stage, section.actuation_latency_default_ms / 1000.0)
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
        self.frame_period_s = rig.camera.frame_period_s
        self.silence_s = 2.0 * self.frame_period_s  # no detection for this long: predict anyway
        self.coast_max_s = section.coast_max_ms / 1000.0
        self.last_detection_s: float | None = None

    # ------------------------------------------------------------------------------ detections

    def plausible(self, detection: Detection, now_ns: int) -> bool:
        """Well-formed is not enough: a capture from the future, or a pixel far off the image,
        is dropped and counted."""
        if detection.t_capture_ns - now_ns > FUTURE_TOLERANCE_NS:
            self.counts["from_the_future"] += 1
            return False
        w, h = detection.width_px, detection.height_px
        if detection.found and not (
            -w <= detection.u_px <= 2 * w and -h <= detection.v_px <= 2 * h
        ):
            self.counts["off_the_image"] += 1
            return False
        return True

    def update(self, detection: Detection, now_ns: int) -> TrackUpdate | None:
        """Filter a plausible detection that arrived at `now_ns` and predict the track to the
        effect time; None when the filter refuses it."""
        try:
            self._observe(detection, now_ns)
            t_ns = self.clock_ns()
            stamps = (*detection.stamps, (self.stage, t_ns))
            t_effect_ns = t_ns + round(self.latency.actuation_s * 1e9)
            t_capture_ns = detection.t_capture_ns
            t_predicted_ns = t_effect_ns if self.predict_over_latency else t_capture_ns
            predicted = self.estimator.predict(t_predicted_ns / 1e9)
        except ValueError as exc:
            self._reject(detection.seq, exc)
            return None
        coasting = not detection.found
        prediction = None
        if predicted is not None:
            prediction = self._prediction(
                predicted, t_capture_ns, stamps, t_effect_ns, t_ns, coasting
            )
        return TrackUpdate(detection.seq, t_capture_ns, stamps, coasting, prediction)

    def settle(self, update: TrackUpdate) -> tuple[EstimatorState | None, list[ManeuverEvent]]:
        """After the prediction: the track's state at the capture, and the maneuver events."""
        try:
            now_state = self.estimator.predict(update.t_capture_ns / 1e9)
        except ValueError as exc:  # the track is already past this capture
            self._reject(update.seq, exc)
            return None, []
        state = None
        if now_state is not None:
            probabilities = self.estimator.model_probabilities()
            position, velocity = now_state.position.tolist(), now_state.velocity.tolist()
            on_ground = self.geometry is not None
            state = EstimatorState(
                t_capture_ns=update.t_capture_ns,
                stamps=update.stamps,
                filter=self.filter,
                x=(*position, *velocity),
                P=tuple(map(tuple, now_state.covariance.tolist())),
                model_probabilities=probabilities,
                most_likely=max(probabilities, key=probabilities.__getitem__),
                ground_xy_m=tuple(position) if on_ground else None,
                ground_velocity_m_s=tuple(velocity) if on_ground else None,
                coasting=update.coasting,
            )
        events = [
            ManeuverEvent(
                t_capture_ns=update.t_capture_ns,
                stamps=update.stamps,
                model=event.model,
                previous_model=event.previous_model,
                t_start_ns=round(event.t_start_s * 1e9),
                previous_duration_s=event.previous_duration_s,
                mean_s_dot_m_s2=event.mean_s_dot_m_s2,
                mean_theta_dot_rad_s=event.mean_theta_dot_rad_s,
            )
            for event in self.estimator.drain_events()
        ]
        return state, events

    # ---------------------------------------------------------------------------------- silence

    def heard(self, mono_s: float) -> float:
        """Detections came at monotonic `mono_s`; the seconds until silence would begin."""
        self.last_detection_s = mono_s
        return self.silence_s

    def silent(self, wall_ns: int, mono_s: float) -> tuple[Prediction | None, float]:
        """No detection came: after `silence_s`, and for up to coast_max_ms, the track predicted
        to the effect time and marked coasting, at the camera's rate. Returns that prediction
        (None: not due, or no track) and the seconds until the next call is wanted."""
        if self.last_detection_s is None:
            return None, IDLE_S
        silent_s = mono_s - self.last_detection_s
        if silent_s > self.coast_max_s:
            return None, IDLE_S
        prediction = None
        if silent_s >= self.silence_s:
            t_effect_ns = wall_ns + round(self.latency.actuation_s * 1e9)
            predicted = self.estimator.predict(t_effect_ns / 1e9)
            if predicted is not None:
                stamps = ((self.stage, wall_ns),)
                prediction = self._prediction(
                    predicted, wall_ns, stamps, t_effect_ns, wall_ns, True
                )
                self.counts["silent_predictions"] += 1
        return prediction, self.frame_period_s

    def counters(self) -> dict[str, int]:
        """Its own counts and the filter's."""
        counters = dict(self.counts)
        counters.update(self.estimator.health())
        return counters

    # -------------------------------------------------------------------------------- internals

    def _observe(self, detection: Detection, now_ns: int) -> None:
        self.counts["detections"] += 1
        self.latency.detection_arrived(detection.t_capture_ns, now_ns)
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

    def _reject(self, seq: int, exc: ValueError) -> None:
        self.counts["rejected"] += 1
        log.debug("detection %d rejected: %s", seq, exc)

    def _prediction(
        self,
        predicted: PredictedState,
        t_capture_ns: int,
        stamps: tuple[Stamp, ...],
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
            actuation_latency_s=self.latency.actuation_s,
            coasting=coasting,
        )
