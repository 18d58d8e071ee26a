"""Motion estimation: learn which simple motion the target makes and predict it over latency.

    estimator = build_estimator(rig.estimator)          # the rig's [estimator] filter mode
    estimator.update(Measurement.ground(t_s, xy_m, cov_m2, velocity_m_s, cov_m2_s2))
    estimator.coast(t_s)                                 # a frame without a detection
    p = estimator.predict(t_s + latency_s)               # position, velocity, covariance
    estimator.model_probabilities(); estimator.most_likely(); estimator.drain_events()

Every mode (imm, innovation, alphabeta, image-cv) is a `TrackEstimator` over N tracks; the
batch calls `step` / `forecast` take one row per track. The `estimator` process's work per
detection — the measurement, the loop's latencies, coasting and the prediction to the effect
time — is `target_tracker.TargetTracker`.
"""

from gazed.estimation.estimator import TrackEstimator
from gazed.estimation.events import ManeuverEvent
from gazed.estimation.factory import FILTER_MODES, build_estimator
from gazed.estimation.measurement import Measurement
from gazed.estimation.results import Forecast, Outcome, PredictedState

__all__ = [
    "FILTER_MODES",
    "Forecast",
    "ManeuverEvent",
    "Measurement",
    "Outcome",
    "PredictedState",
    "TrackEstimator",
    "build_estimator",
]
