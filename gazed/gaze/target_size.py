"""The target's size for the zoom (`gazed.gaze.zoom`), from the heights of its boxes.

A box's height h (a fraction of the frame's height) over the focal length f it was seen at,
a = h / f, is the target's angular size: the zoom does not change it, the target's range does.
For an upright body of height L whose tracked point lies a horizontal distance d and a straight
distance R from the camera, a is proportional to L·d / R² (the rate of the elevation angle
with height), so L ∝ a·R² / d is the same in every frame of one target.

Each sighting is turned into that constant, c = a·R²/d, at the position the chosen track's
predictions give for its capture (a calibrated rig, `Prediction.ground_xy_m`). The detector's
boxes are mostly right and sometimes far too tall for a run of frames (an edge behind the
target joining its region), so c is judged against the whole track's (at most
`HISTORY_SIGHTINGS`): a sighting further from their median than `GATE_SIGMAS` standard
deviations, estimated robustly from their median absolute deviation (in logarithms, as the
error is a factor), is an outlier and left out, however long the run, as long as such boxes
are not the majority. The size is the median of the last `RECENT_SIGHTINGS` sightings kept,
scaled by d/R² to the latest prediction's position: a short window, so that what the model
leaves out (the body rolled in a head panned far from its base's axis, its width seen
obliquely) is measured rather than assumed, and the range carried to where the estimator
predicts the target, so the zoom does not trail an approaching target by the boxes' latency.

Without ground positions, c is the angular size itself, which changes with the range: no
sighting is left out, and the size is the median of the last `RECENT_SIGHTINGS`.
"""

from __future__ import annotations

import math
import statistics
from collections import deque
from collections.abc import Sequence

from gazed.messages import Prediction

RECENT_SIGHTINGS = 15  # the size: the median of this many sightings kept (0.6 s at 25 Hz)
HISTORY_SIGHTINGS = 1500  # the outlier gate: the track's last sightings (a minute at 25 Hz)
GATE_SIGMAS = 3.0  # a sighting this many standard deviations from the track's is an outlier
MAD_SIGMA = 1.4826  # a normal distribution's standard deviation over its median absolute deviation


class TargetSize:
    """Sightings' angular sizes in (`add`), the angular size to hold out (`angular`).

    `camera_xyz_m`: the camera's rotation centre and `point_height_m` the tracked point's
    height above the ground ([calibration]); `predictions`: the chosen track's recent
    predictions, oldest first (None, or no camera position: no range is used)."""

    def __init__(
        self,
        camera_xyz_m: tuple[float, float, float] | None,
        point_height_m: float,
        predictions: Sequence[Prediction] | None,
    ) -> None:
        self.camera_xyz_m = camera_xyz_m
        self.point_height_m = point_height_m
        self.predictions = predictions if camera_xyz_m is not None else None
        self.history: deque[float] = deque(maxlen=HISTORY_SIGHTINGS)  # ln c
        self.recent: deque[float] = deque(maxlen=RECENT_SIGHTINGS)  # c, the outliers left out
        self.key: tuple[int | None, bool] = (None, False)  # the track, and whether ranged
        self.scale = 1.0  # d / R² at the last sighting
        self.outliers = 0

    def clear_recent(self) -> None:
        """The pursuit ended: the size is measured afresh (the track's history stays while
        the same track is followed)."""
        self.recent.clear()

    def add(self, t_capture_ns: int, angular: float) -> None:
        """A sighting's angular size (h / f, positive) at its capture."""
        latest = self._latest()
        ground = None if latest is None else self._ground_at(t_capture_ns)
        key = (None if latest is None else latest.track_id, ground is not None)
        if key != self.key:  # another track, another body; or ranges begin or end
            self.history.clear()
            self.recent.clear()
            self.key = key
        self.scale = self._scale(ground)
        log_c = math.log(angular / self.scale)
        self.history.append(log_c)
        if self._outlier(log_c):
            self.outliers += 1
            return
        self.recent.append(math.exp(log_c))

    def angular(self) -> float | None:
        """The angular size (h / f) to hold now (None: no sighting kept yet): at the latest
        prediction's position, or where the last sighting was without one."""
        if not self.recent:
            return None
        latest = self._latest()
        ranged = latest is not None and self.key[1] and latest.track_id == self.key[0]
        scale = self._scale(latest.ground_xy_m) if ranged and latest else self.scale
        return statistics.median(self.recent) * scale

    def _outlier(self, log_c: float) -> bool:
        """Further from the history's median than the gate (not before the history holds a
        window's worth of sightings to judge by, nor without ranges, where c is the angular
        size and changes with the range over the history)."""
        if not self.key[1] or len(self.history) < RECENT_SIGHTINGS:
            return False
        centre = statistics.median(self.history)
        sigma = MAD_SIGMA * statistics.median(abs(x - centre) for x in self.history)
        return abs(log_c - centre) > GATE_SIGMAS * sigma

    def _latest(self) -> Prediction | None:
        """The newest prediction, if it places the target on the ground."""
        if not self.predictions or self.predictions[-1].ground_xy_m is None:
            return None
        return self.predictions[-1]

    def _ground_at(self, t_ns: int) -> tuple[float, float] | None:
        """Where the predictions put the target at `t_ns`: the one for the nearest instant,
        moved on with its velocity."""
        assert self.predictions is not None
        p = min(self.predictions, key=lambda k: abs(k.t_effect_ns - t_ns))
        if p.ground_xy_m is None:
            return None
        vx, vy = p.ground_velocity_m_s or (0.0, 0.0)
        dt_s = (t_ns - p.t_effect_ns) / 1e9
        return p.ground_xy_m[0] + vx * dt_s, p.ground_xy_m[1] + vy * dt_s

    def _scale(self, ground_xy_m: tuple[float, float] | None) -> float:
        """d / R² of the tracked point at `ground_xy_m`; 1 without a position, or right
        below the camera (where an upright body shows no height)."""
        if ground_xy_m is None or self.camera_xyz_m is None:
            return 1.0
        cx, cy, cz = self.camera_xyz_m
        d = math.hypot(ground_xy_m[0] - cx, ground_xy_m[1] - cy)
        if d <= 0.0:
            return 1.0
        return d / (d * d + (cz - self.point_height_m) ** 2)
