"""What the page shows, from the newest messages: overlays for a frame and the rig's state.

`LiveState` takes the bus's messages as they come (`take`) and answers two questions in plain
JSON-able dicts: what to draw over a frame taken at a given head pose (`overlay`: the detection
and its movers, the candidates, every track with its id, the chosen target, the prediction,
the fovea) and what the rest of the page shows (`snapshot`: the gaze state with its reason, the
tracks on the ground with their covariances, the prediction, the model probabilities and the
latency of each hop of the newest command).
"""

from __future__ import annotations

from typing import Any

from gazed.messages import (
    Candidates,
    Detection,
    EstimatorState,
    GazeDemand,
    GazeState,
    HeadPose,
    Message,
    Odometry,
    Prediction,
)
from gazed.plots.latency_hops import hop_latencies_ms
from gazed.view.projection import ImageProjection
from gazed.vision.odometry_history import OdometryHistory

ODOMETRY_SPAN_S = 5.0  # the frames shown are at most this old
ODOMETRY_MAX_GAP_S = 0.5


class LiveState:
    """The newest of each message the page needs, and the head's recent poses."""

    def __init__(self, projection: ImageProjection) -> None:
        self.projection = projection
        self.odometry = OdometryHistory(ODOMETRY_SPAN_S, ODOMETRY_MAX_GAP_S)
        self.detection: Detection | None = None
        self.candidates: Candidates | None = None
        self.estimator: EstimatorState | None = None
        self.prediction: Prediction | None = None
        self.gaze: GazeState | None = None
        self.command: GazeDemand | None = None

    def take(self, message: Message) -> None:
        """Keep a message of any of the topics the view reads (others are ignored)."""
        match message:
            case Odometry():
                self.odometry.add(message)
            case Detection():
                self.detection = message
            case Candidates():
                self.candidates = message
            case EstimatorState():
                self.estimator = message
            case Prediction():
                self.prediction = message
            case GazeState():
                self.gaze = message
            case GazeDemand():
                self.command = message

    def pose_at(self, t_capture_ns: int) -> HeadPose | None:
        """The head's pose when a frame was captured (None without odometry around then)."""
        return self.odometry.pose_at(t_capture_ns)

    @property
    def target_id(self) -> int | None:
        """The chosen track: the gaze's choice, else the estimator's."""
        if self.gaze is not None and self.gaze.target_id is not None:
            return self.gaze.target_id
        return self.estimator.target_id if self.estimator is not None else None

    def overlay(self, head: HeadPose | None) -> dict[str, Any]:
        """What to draw over a frame taken at `head` (pixels); tracks and the prediction only
        with a pose."""
        centre_u, centre_v = self.projection.centre_px
        overlay: dict[str, Any] = {
            "fovea": {"u": centre_u, "v": centre_v, "side": self.projection.fovea_px},
            "detection": None,
            "movers": [],
            "candidates": [],
            "tracks": [],
            "prediction": None,
            "target_id": self.target_id,
        }
        if self.detection is not None:
            d = self.detection
            overlay["detection"] = {"found": d.found, "u": d.u_px, "v": d.v_px, "seq": d.seq}
            overlay["movers"] = [
                {"u": m.u_px, "v": m.v_px, "w": m.box_width_px, "h": m.box_height_px}
                for m in d.movers
            ]
        if self.candidates is not None:
            overlay["candidates"] = [
                {"u": c.u_px, "v": c.v_px, "score": c.score} for c in self.candidates.candidates
            ]
        if head is None:
            return overlay
        if self.estimator is not None:
            for track in self.estimator.tracks:
                pixel = self.projection.pixel(head, track.pan_rad, track.tilt_rad)
                if pixel is not None:
                    overlay["tracks"].append(
                        {
                            "id": track.id,
                            "u": pixel[0],
                            "v": pixel[1],
                            "confirmed": track.confirmed,
                            "coasting": track.coasting,
                            "h": track.box_height_px,
                        }
                    )
        if self.prediction is not None:
            pixel = self.projection.pixel(head, self.prediction.pan_rad, self.prediction.tilt_rad)
            if pixel is not None:
                overlay["prediction"] = {"u": pixel[0], "v": pixel[1]}
        return overlay

    def snapshot(self) -> dict[str, Any]:
        """The rest of the page: gaze state, ground map, model probabilities, latency per hop."""
        state: dict[str, Any] = {
            "type": "state",
            "gaze": None,
            "target_id": self.target_id,
            "tracks": [],
            "prediction": None,
            "models": {},
            "most_likely": "",
            "latency_ms": {},
        }
        if self.gaze is not None:
            state["gaze"] = {
                "state": self.gaze.state,
                "previous": self.gaze.previous,
                "reason": self.gaze.reason,
            }
        if self.estimator is not None:
            state["models"] = dict(self.estimator.model_probabilities)
            state["most_likely"] = self.estimator.most_likely
            state["tracks"] = [
                {
                    "id": t.id,
                    "xy": t.ground_xy_m,
                    "velocity": t.ground_velocity_m_s,
                    "cov": t.ground_cov_m2,
                    "confirmed": t.confirmed,
                    "coasting": t.coasting,
                }
                for t in self.estimator.tracks
                if t.ground_xy_m is not None
            ]
            if not state["tracks"] and self.estimator.ground_xy_m is not None:
                state["tracks"] = [  # a filter without tracks: the one target it follows
                    {
                        "id": self.estimator.target_id,
                        "xy": self.estimator.ground_xy_m,
                        "velocity": self.estimator.ground_velocity_m_s,
                        "cov": None,
                        "confirmed": True,
                        "coasting": self.estimator.coasting,
                    }
                ]
        if self.prediction is not None and self.prediction.ground_xy_m is not None:
            state["prediction"] = {
                "xy": self.prediction.ground_xy_m,
                "cov": self.prediction.position_cov_m2,
                "track_id": self.prediction.track_id,
                "horizon_s": self.prediction.horizon_s,
            }
        if self.command is not None:
            state["latency_ms"] = hop_latencies_ms(self.command)
        return state
