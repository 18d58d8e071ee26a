"""Pursuit's demand (seed 000 §6): the predicted position and rates for the instant the demand
acts (the prediction extrapolated to now + actuation latency), plus a feedback term on the
residual between where the target was seen and where it had been predicted to be at that
instant, smoothed and bounded by the fovea. Before the estimator has a prediction, or when it
has gone stale, the detection itself (its angles and angular rates) is followed.
"""

from __future__ import annotations

from collections import deque

from gazed.config import GazeSection
from gazed.gaze.aim import Aim, angle_between, detection_aim
from gazed.gaze.demand import make_demand
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.zoom import ZoomLens
from gazed.messages import Detection, GazeDemand, Prediction

PREDICTION_FRESH_S = 0.5  # an older prediction is not used for pursuit
KEPT_PREDICTIONS = 64  # the newest predictions, to reach back over the visual latency


def _bounded(value: float, bound: float) -> float:
    return max(-bound, min(bound, value))


class ResidualFeedback:
    """Keeps the recent predictions; `update` with each detection seen in pursuit; `correction`
    is the smoothed residual (pan, tilt), radians."""

    def __init__(self, smoothing: float, bound_rad: float) -> None:
        self.smoothing = smoothing
        self.bound_rad = bound_rad
        self.predictions: deque[Prediction] = deque(maxlen=KEPT_PREDICTIONS)
        self.correction = (0.0, 0.0)

    def on_prediction(self, prediction: Prediction) -> None:
        self.predictions.append(prediction)

    def update(self, seen: Aim) -> None:
        """Move the correction toward the residual of `seen` (a detection, at its capture)
        against the newest prediction made for an instant no later than it."""
        predicted = [p for p in self.predictions if p.t_effect_ns <= seen.t_ns]
        if not predicted:
            return
        pan_p, tilt_p = Aim.of_prediction(predicted[-1]).at(seen.t_ns)
        alpha, (pan_c, tilt_c) = self.smoothing, self.correction
        self.correction = (
            _bounded(pan_c + alpha * (seen.pan_rad - pan_p - pan_c), self.bound_rad),
            _bounded(tilt_c + alpha * (seen.tilt_rad - tilt_p - tilt_c), self.bound_rad),
        )


class Pursuit:
    """Holds the estimator's latest prediction; `aim` is it while fresh (a stale one is
    counted in `stale_predictions`), `demand` what pursuit (or a coast on the prediction)
    asks of the head."""

    def __init__(
        self,
        gaze: GazeSection,
        fovea_rad: float,
        lens: ZoomLens,
        kinematics: HeadKinematics,
    ) -> None:
        self.gain = gaze.residual_gain
        self.fovea_rad = fovea_rad
        self.feedback = ResidualFeedback(gaze.residual_smoothing, fovea_rad)
        self.lens = lens
        self.kinematics = kinematics
        self.prediction: Prediction | None = None
        self.stale_predictions = 0
        # the last saccade's landing (wall clock, head pose) while the predictions that come
        # are still made from frames exposed before it
        self._landing: tuple[int, tuple[float, float] | None] | None = None

    def on_prediction(self, prediction: Prediction) -> None:
        if self._landing is not None:
            if prediction.t_capture_ns >= self._landing[0]:
                self._landing = None  # seen after the landing: the target the move found
            elif not self._lands_on(prediction):
                return  # another target's, on its way through the loop as the head landed
        self.prediction = prediction
        self.feedback.on_prediction(prediction)

    def restart(self) -> None:
        """Another target: forget the predictions of the last one and their residual."""
        self._forget()
        self._landing = None

    def _forget(self) -> None:
        self.prediction = None
        self.feedback.predictions.clear()
        self.feedback.correction = (0.0, 0.0)

    def landed(self, head_rad: tuple[float, float] | None, wall_ns: int) -> None:
        """A saccade has settled with the head at `head_rad`: a prediction made from frames
        exposed before now that does not put the target in the fovea now is another target's
        (a track taken up before or during the move, from frames the move was not aimed by),
        and is not pursued. That holds for the prediction held now and for those still on
        their way through the loop's latency; the first made from a frame exposed after the
        landing ends the check."""
        self._landing = (wall_ns, head_rad)
        if self.prediction is not None and not self._lands_on(self.prediction):
            self._forget()

    def _lands_on(self, p: Prediction) -> bool:
        """Whether `p` puts the target in the fovea of the head as it landed."""
        assert self._landing is not None
        landed_ns, head_rad = self._landing
        if head_rad is None:
            return False
        pan, tilt = Aim.of_prediction(p).at(landed_ns)
        return angle_between(pan, tilt, *head_rad, self.kinematics) <= self.fovea_rad

    def on_detection(self, detection: Detection) -> None:
        """A detection seen in pursuit: it updates the residual feedback."""
        self.feedback.update(detection_aim(self.lens, self.kinematics, detection))

    def aim(self, wall_ns: int) -> Aim | None:
        """The latest prediction, if fresh, as an aim."""
        p = self.prediction
        if p is None:
            return None
        if abs(wall_ns - p.t_effect_ns) / 1e9 > PREDICTION_FRESH_S:  # stale, or from the future
            self.stale_predictions += 1
            return None
        return Aim.of_prediction(p)

    def ground_at(self, t_ns: int) -> tuple[float, float] | None:
        """The target's ground position at `t_ns`: the newest prediction made for an instant
        no later than it (else the oldest kept), on along its ground velocity. None without a
        prediction within `PREDICTION_FRESH_S` of the instant, or one without a ground
        position."""
        kept = self.feedback.predictions
        if not kept:
            return None
        p = next((p for p in reversed(kept) if p.t_effect_ns <= t_ns), kept[0])
        dt_s = (t_ns - p.t_effect_ns) * 1e-9
        if p.ground_xy_m is None or abs(dt_s) > PREDICTION_FRESH_S:
            return None
        vx, vy = p.ground_velocity_m_s or (0.0, 0.0)
        return p.ground_xy_m[0] + vx * dt_s, p.ground_xy_m[1] + vy * dt_s

    @property
    def actuation_s(self) -> float:
        """How long after it is sent a demand acts: the latest prediction's actuation latency."""
        return self.prediction.actuation_latency_s if self.prediction is not None else 0.0

    def demand(self, wall_ns: int, found: Detection | None, correction: bool) -> GazeDemand | None:
        """Position and rates for the instant the demand acts (now + actuation latency), from
        the prediction or else the detection `found`; with `correction`, plus the feedback
        term. None with neither to follow."""
        aim = self.aim(wall_ns)
        source: Prediction | Detection | None = self.prediction
        if aim is None:
            if found is None:
                return None
            aim, source = detection_aim(self.lens, self.kinematics, found), found
        pan, tilt = aim.at(wall_ns + round(self.actuation_s * 1e9))
        if correction:
            pan_c, tilt_c = self.feedback.correction
            pan, tilt = pan + self.gain * pan_c, tilt + self.gain * tilt_c
        rates = (aim.pan_rate_rad_s, aim.tilt_rate_rad_s)
        return make_demand("pursuit", pan, tilt, wall_ns, source, rates)
