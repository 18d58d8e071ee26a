"""The estimator's wire messages made from its filters' states: a track, a prediction and a
maneuver event, on the ground (angles from the ground geometry) or, for `image-cv`, in gaze
angles (the state is the gaze itself)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gazed.estimation.appearance_model import TrackAppearance
from gazed.estimation.events import ManeuverEvent as ModelChange
from gazed.estimation.loop_latency import LoopLatency
from gazed.estimation.results import PredictedState
from gazed.estimation.tracks import PersonTrack
from gazed.geometry.ground import GroundGeometry
from gazed.messages import ManeuverEvent, Prediction, Stamp, Track, TrackLook


@dataclass(frozen=True)
class EstimatorMessages:
    """Messages of one estimator: its filter's name, its ground geometry (None for image-cv)
    and its loop latency (the actuation part a prediction reports)."""

    filter: str
    geometry: GroundGeometry | None
    latency: LoopLatency

    def track(self, track: PersonTrack, state: PredictedState, t_s: float) -> Track:
        """One track's message: its state at the frame's capture."""
        if self.geometry is None:  # image-cv: the state is the gaze itself
            pan, tilt = state.position.tolist()
            ground = velocity = cov = velocity_cov = cross_cov = None
        else:
            x, y = state.position.tolist()
            pan, tilt = self.geometry.gaze_from_ground(x, y)
            ground, velocity = (x, y), tuple(state.velocity.tolist())
            cov = _block(state.covariance[:2, :2])
            velocity_cov = _block(state.covariance[2:, 2:])
            cross_cov = _block(state.covariance[:2, 2:])
        return Track(
            id=track.id,
            confirmed=track.confirmed,
            pan_rad=pan,
            tilt_rad=tilt,
            ground_xy_m=ground,
            ground_velocity_m_s=velocity,
            ground_cov_m2=cov,
            ground_velocity_cov_m2_s2=velocity_cov,
            ground_position_velocity_cov_m2_s=cross_cov,
            age_s=max(0.0, t_s - track.first_s),
            hits=track.hits,
            coasting=track.coasting,
            box_height_px=track.box_height_px,
            most_likely=track.estimator.most_likely(),
            look=_look(track.appearance),
        )

    def prediction(
        self,
        predicted: PredictedState,
        t_capture_ns: int,
        stamps: tuple[Stamp, ...],
        t_effect_ns: int,
        t_ns: int,
        coasting: bool,
        track_id: int | None,
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
            cov = _block(predicted.covariance[:2, :2])
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
            track_id=track_id,
        )


def maneuver_message(
    event: ModelChange, t_capture_ns: int, stamps: tuple[Stamp, ...]
) -> ManeuverEvent:
    """A change of the most likely model as its wire message."""
    return ManeuverEvent(
        t_capture_ns=t_capture_ns,
        stamps=stamps,
        model=event.model,
        previous_model=event.previous_model,
        t_start_ns=round(event.t_start_s * 1e9),
        previous_duration_s=event.previous_duration_s,
        mean_s_dot_m_s2=event.mean_s_dot_m_s2,
        mean_theta_dot_rad_s=event.mean_theta_dot_rad_s,
    )


def _look(appearance: TrackAppearance | None) -> TrackLook | None:
    """A track's appearance model on the wire (None: it has none, or of one bin, which tells
    nobody apart)."""
    if appearance is None or len(appearance.template) < 2:
        return None
    return TrackLook(
        template=tuple(appearance.template.tolist()),
        h2_mean=appearance.mean,
        h2_shape=appearance.shape,
    )


def _block(C: np.ndarray) -> tuple[tuple[float, float], tuple[float, float]]:
    """A 2x2 block of a covariance as the wire's nested tuples."""
    (a, b), (c, d) = C.tolist()
    return (a, b), (c, d)
