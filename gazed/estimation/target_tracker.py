"""The estimator's work per detection: every mover on the ground, one filter per person
(`tracks.TrackSet`), and the prediction of the chosen one to the instant a demand made from it
acts (DESIGN §5; seed 000 §4-6).

The chosen track is the gaze's (`gaze/state` target_id, `choose`). Before any choice, or once the
chosen track has ended, it is the only track if there is one, else the only confirmed one if
there is one, else none: nothing is predicted until the gaze chooses, but every frame's
`EstimatorState` lists every track, so that it can.

A detection that is not plausible — captured further in the future than `FUTURE_TOLERANCE_NS`,
or found at a pixel far off the image — is dropped and counted: it would poison the track.
A frame without a detection (or without a head pose, or with a ray above the horizon) is a
predict-only step: the tracks coast. A detection the filter refuses (not newer than the track)
is counted as rejected.

After every detection the track is predicted to its effect time, now + the actuation latency
(i.e. capture + visual latency + actuation latency, `LoopLatency`); without prediction over the
latency (`predict_over_latency = false`, the baseline) the estimate at the capture is offered
as if it held then. With no detection for two frame periods (vision restarting, frames lost)
the chosen track is still predicted at the camera's rate, marked coasting, for up to `coast_max_ms`,
so the gaze keeps following where the target should be.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from gazed.config import Rig
from gazed.estimation.estimator_messages import EstimatorMessages, maneuver_message
from gazed.estimation.loop_latency import LoopLatency
from gazed.estimation.measurement import Measurement
from gazed.estimation.observation import gaze_measurement, ground_measurement
from gazed.estimation.silhouette_reach import ToPixel, reach_box
from gazed.estimation.tracks import PersonTrack, Sighting, TrackSet
from gazed.geometry.ground import GroundGeometry, MeasurementNoise
from gazed.geometry.homography import HorizonError
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.zoom import ZoomLens
from gazed.messages import (
    Detection,
    EstimatorState,
    ManeuverEvent,
    Mover,
    Prediction,
    Stamp,
)

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
    track_id: int | None = None  # the chosen track, predicted


class TargetTracker:
    """Detections -> ground measurements of every mover -> one filter per track -> the chosen
    track's predictions to the effect time.

    `stage` is the name the estimator stamps its messages with; `clock_ns` the wall clock of
    those stamps."""

    def __init__(self, rig: Rig, stage: str, clock_ns: Callable[[], int] = time.time_ns) -> None:
        section = rig.estimator
        self.stage = stage
        self.clock_ns = clock_ns
        self.filter = section.filter
        self.predict_over_latency = section.predict_over_latency
        self.tracks = TrackSet(section)
        self.target_id: int | None = None  # the gaze's choice
        self.lens = ZoomLens.from_section(rig.camera)
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
        self.extent_core, self.extent_tail = section.mover_extent_noise, section.mover_extent_tail
        self.tail_weight = section.mover_extent_tail_weight
        self.latency = LoopLatency(stage, section.actuation_latency_default_ms / 1000.0)
        self.messages = EstimatorMessages(self.filter, self.geometry, self.latency)
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
            "retimed": 0,
        }
        self.frame_period_s = rig.camera.frame_period_s
        self.silence_s = 2.0 * self.frame_period_s  # no detection for this long: predict anyway
        self.coast_max_s = section.coast_max_ms / 1000.0
        self.last_detection_s: float | None = None
        self.silent_due_s = 0.0  # monotonic: when the next coasting prediction is due
        self.delay_ms: float | None = None  # the camera delay vision applied to the last frame

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

    def choose(self, target_id: int | None) -> None:
        """The gaze's chosen track (None: no choice)."""
        self.target_id = target_id

    def chosen(self) -> PersonTrack | None:
        """The gaze's track; without it, the only track, else the only confirmed one."""
        tracks = self.tracks.tracks
        if self.target_id is not None:
            track = self.tracks.get(self.target_id)
            if track is not None:
                return track
        if len(tracks) == 1:
            return tracks[0]
        confirmed = [track for track in tracks if track.confirmed]
        return confirmed[0] if len(confirmed) == 1 else None

    def most_likely(self) -> str:
        """The chosen track's most likely motion model ("" without one)."""
        track = self.chosen()
        return track.estimator.most_likely() if track is not None else ""

    def update(self, detection: Detection, now_ns: int) -> TrackUpdate | None:
        """Filter a plausible detection's movers that arrived at `now_ns` and predict the chosen
        track to the effect time; None when a filter refuses the frame."""
        try:
            self._observe(detection, now_ns)
            track = self.chosen()
            t_ns = self.clock_ns()
            stamps = (*detection.stamps, (self.stage, t_ns))
            t_effect_ns = t_ns + round(self.latency.actuation_s * 1e9)
            t_capture_ns = detection.t_capture_ns
            t_predicted_ns = t_effect_ns if self.predict_over_latency else t_capture_ns
            predicted = track.estimator.predict(t_predicted_ns / 1e9) if track else None
        except ValueError as exc:
            self._reject(detection.seq, exc)
            return None
        coasting = track is None or track.coasting
        track_id = track.id if track is not None else None
        prediction = None
        if predicted is not None:
            prediction = self.messages.prediction(
                predicted, t_capture_ns, stamps, t_effect_ns, t_ns, coasting, track_id
            )
        return TrackUpdate(detection.seq, t_capture_ns, stamps, coasting, prediction, track_id)

    def settle(self, update: TrackUpdate) -> tuple[EstimatorState | None, list[ManeuverEvent]]:
        """After the prediction: every track at the capture, the chosen one's filter state, and
        its maneuver events. None without tracks."""
        if not self.tracks.tracks:
            return None, []
        t_s = update.t_capture_ns / 1e9
        try:
            states = [(track, track.estimator.predict(t_s)) for track in self.tracks.tracks]
        except ValueError as exc:  # the tracks are already past this capture
            self._reject(update.seq, exc)
            return None, []
        chosen, now_state, tracks, events = None, None, [], []
        for track, state in states:
            assert state is not None  # an ended track is removed at once
            tracks.append(self.messages.track(track, state, t_s))
            drained = track.estimator.drain_events()
            if track.id == update.track_id:
                chosen, now_state, events = track, state, drained
        fields: dict[str, Any] = {"x": (), "P": (), "coasting": True}
        if chosen is not None and now_state is not None:
            probabilities = chosen.estimator.model_probabilities()
            position, velocity = now_state.position.tolist(), now_state.velocity.tolist()
            on_ground = self.geometry is not None
            fields = {
                "x": (*position, *velocity),
                "P": tuple(map(tuple, now_state.covariance.tolist())),
                "model_probabilities": probabilities,
                "most_likely": max(probabilities, key=probabilities.__getitem__),
                "ground_xy_m": tuple(position) if on_ground else None,
                "ground_velocity_m_s": tuple(velocity) if on_ground else None,
                "coasting": update.coasting,
                "target_id": chosen.id,
            }
        state = EstimatorState(
            t_capture_ns=update.t_capture_ns,
            stamps=update.stamps,
            filter=self.filter,
            tracks=tuple(tracks),
            **fields,
        )
        return state, [maneuver_message(e, update.t_capture_ns, update.stamps) for e in events]

    # ---------------------------------------------------------------------------------- silence

    def heard(self, mono_s: float) -> float:
        """Detections came at monotonic `mono_s`; the seconds until silence would begin."""
        self.last_detection_s = mono_s
        self.silent_due_s = mono_s + self.silence_s
        return self.silence_s

    def silent(self, wall_ns: int, mono_s: float) -> tuple[Prediction | None, float]:
        """No detection came: after `silence_s`, and for up to coast_max_ms, the chosen track
        predicted to the effect time and marked coasting, once a frame period however often it is
        called. Returns it (None: not due, or no track) and the seconds until the next call."""
        if self.last_detection_s is None:
            return None, IDLE_S
        silent_s = mono_s - self.last_detection_s
        if silent_s > self.coast_max_s:
            return None, IDLE_S
        if silent_s < self.silence_s:
            return None, self.frame_period_s
        if mono_s < self.silent_due_s:  # a step woken by something else, within a frame period
            return None, self.silent_due_s - mono_s
        self.silent_due_s = mono_s + self.frame_period_s
        prediction = None
        track = self.chosen()
        if track is not None:
            t_effect_ns = wall_ns + round(self.latency.actuation_s * 1e9)
            predicted = track.estimator.predict(t_effect_ns / 1e9)
            if predicted is not None:
                stamps = ((self.stage, wall_ns),)
                prediction = self.messages.prediction(
                    predicted, wall_ns, stamps, t_effect_ns, wall_ns, True, track.id
                )
                self.counts["silent_predictions"] += 1
        return prediction, self.frame_period_s

    def counters(self) -> dict[str, int]:
        """Its own counts, the tracks' and their filters'."""
        counters = dict(self.counts)
        counters.update(self.tracks.health())
        return counters

    # -------------------------------------------------------------------------------- internals

    def _observe(self, detection: Detection, now_ns: int) -> None:
        self.counts["detections"] += 1
        if self.delay_ms is not None and detection.delay_ms != self.delay_ms:
            # vision's camera delay changed: the stamps the tracks were built on were off by the
            # change, so their times move with it (their states are those of the true times)
            self.tracks.retime((self.delay_ms - detection.delay_ms) * 1e-3)
            self.counts["retimed"] += 1
        self.delay_ms = detection.delay_ms
        self.latency.detection_arrived(detection.t_capture_ns, now_ns)
        sightings = self._sightings(detection)
        self.tracks.step(detection.t_capture_ns / 1e9, sightings, self._to_pixel(detection))
        self.counts["measured" if sightings else "coasted"] += 1

    def _sightings(self, detection: Detection) -> list[Sighting]:
        """Every mover of the frame as a measurement; without a list of movers, the detection's
        own target where it found one."""
        movers = detection.movers
        if not movers and not detection.found:
            return []
        if detection.head is None:
            self.counts["no_head_pose"] += 1
            return []
        if not movers:
            measurement = self._measure(detection)
            return [Sighting(measurement)] if measurement is not None else []
        sightings = []
        for mover in movers:
            seen = detection.model_copy(update=_target_fields(mover))
            size = mover.box_width_px, mover.box_height_px
            measurement = self._measure(seen, self.noise.for_region(*size, self.extent_core))
            if measurement is None:
                continue
            if not mover.velocity_known:  # its (0, 0) would say the person stands still
                measurement = measurement.position_only()
            tail_cov = None
            if self.tail_weight > 0:  # the mixture's tail: the same point, its wider spread
                tail = self._measure(seen, self.noise.for_region(*size, self.extent_tail))
                tail_cov = tail.position_cov if tail is not None else None
            box = reach_box(mover.u_px, mover.v_px, *size)
            sightings.append(
                Sighting(
                    measurement,
                    _histogram(mover),
                    mover.box_height_px,
                    box,
                    tail_cov,
                    self.tail_weight if tail_cov is not None else 0.0,
                )
            )
        return sightings

    def _ground_geometry(self, detection: Detection) -> GroundGeometry | None:
        """The geometry a detection's points are measured with (None: on gaze angles)."""
        if self.geometry is None or detection.head is None:
            return None
        geometry = self.contact_geometry if detection.point == "ground-contact" else self.geometry
        assert geometry is not None
        return geometry.with_camera(self.lens.at_pose(detection.head))

    def _to_pixel(self, detection: Detection) -> ToPixel | None:
        """Where a track's ground point appears in the detection's frame (None: on gaze
        angles, or without a head pose)."""
        geometry = self._ground_geometry(detection)
        if geometry is None:
            return None
        head = detection.head
        assert head is not None
        return lambda x_m, y_m: geometry.pixel_from_ground(x_m, y_m, head.pan_rad, head.tilt_rad)

    def _measure(
        self, detection: Detection, noise: MeasurementNoise | None = None
    ) -> Measurement | None:
        """The measurement of a detection's target with `noise` (default: the detector's
        pixel noise alone); None above the horizon (counted)."""
        noise = self.noise if noise is None else noise
        try:
            geometry = self._ground_geometry(detection)
            if geometry is None:
                camera = self.lens.at_pose(detection.head)
                return gaze_measurement(detection, camera, self.kinematics, noise)
            return ground_measurement(detection, geometry, noise)
        except HorizonError:
            self.counts["above_horizon"] += 1
            return None

    def _reject(self, seq: int, exc: ValueError) -> None:
        self.counts["rejected"] += 1
        log.debug("detection %d rejected: %s", seq, exc)


def _target_fields(mover: Mover) -> dict[str, float]:
    """A mover's point and image velocity as a detection's target fields."""
    return {
        "u_px": mover.u_px,
        "v_px": mover.v_px,
        "du_px_s": mover.du_px_s,
        "dv_px_s": mover.dv_px_s,
    }


def _histogram(mover: Mover) -> np.ndarray | None:
    """A mover's appearance as a histogram summing to 1; None without one."""
    h = np.asarray(mover.appearance, dtype=float)
    total = float(h.sum()) if h.size else 0.0
    return h / total if total > 0.0 and np.all(h >= 0.0) else None
