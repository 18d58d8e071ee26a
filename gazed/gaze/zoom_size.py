"""The target's size for the zoom: its angular height a = h / f (its height in the frame h, as a
fraction of the frame's, over the focal length it was seen at), which zooming does not change.

An upright body of height H whose tracked middle is at horizontal distance d and slant range r
from the camera spans an angle of about H d / r² (its height, foreshortened by the cosine d / r of
the depression angle, over the range). So each sighting's a r² / d measures the body's height:
a property of the target, not of where it is, kept for as long as the gaze follows the same
track. Its median over the last `SIZE_WINDOW_S` is the body's height, and a box the detector
merges with an edge (or cuts short) moves it only if that lasts for over half the window. The
size the zoom holds is that height at the range of the estimator's latest prediction (where the
target is when the demand takes effect): it follows the target's range smoothly, and no short
run of bad boxes makes it jump.

The range is the estimator's ground position of the target (`Prediction.ground_xy_m`, taken
back to each sighting's capture with its ground velocity) against the camera's position
(`[calibration] camera_xyz_m`, the tracked point `target_height_m` above the ground). A rig
without the camera's position, or a prediction without a ground position, has no range: the
size is then the median of the last `SIZE_SAMPLES` sightings' a, sized afresh in each pursuit.
"""

from __future__ import annotations

import math
import statistics
from collections import deque
from typing import Protocol

from gazed.config import CalibrationSection
from gazed.messages import Prediction

SIZE_SAMPLES = 15  # without a range, the size is the median of this many sightings' (about 0.6 s)
SIZE_WINDOW_S = 10.0  # with one, the body's height is the median of this long's sightings
KEPT_SAMPLES = 1024  # at most this many sightings are kept (the window at any frame rate)


class PredictionSource(Protocol):
    """What holds the estimator's latest prediction of the chosen target (`Pursuit`)."""

    prediction: Prediction | None


class TargetSize:
    """`add` each sighting's angular height; `size` is the one to hold now (None: none yet)."""

    def __init__(self, calibration: CalibrationSection, source: PredictionSource) -> None:
        camera = calibration.camera_xyz_m
        self.camera_m = None if camera is None else (camera[0], camera[1], camera[2])
        self.point_height_m = calibration.target_height_m
        self.source = source
        self.track_id: int | None = None
        # (t_capture_ns, a, d / r² at capture or None without a range)
        self.samples: deque[tuple[int, float, float | None]] = deque(maxlen=KEPT_SAMPLES)

    def add(self, t_capture_ns: int, angular_height: float) -> None:
        """A sighting of the target, its box's height over the focal length it was seen at."""
        prediction = self._prediction()
        factor = None
        if prediction is not None and prediction.ground_xy_m is not None:
            dt_s = (t_capture_ns - prediction.t_effect_ns) / 1e9
            x, y = prediction.ground_xy_m
            vx, vy = prediction.ground_velocity_m_s or (0.0, 0.0)
            factor = self._factor(x + vx * dt_s, y + vy * dt_s)
        self.samples.append((t_capture_ns, angular_height, factor))

    def restart(self) -> None:
        """A new pursuit: a size without a range starts afresh (the target may have moved);
        the body's height stays with its track."""
        if self.camera_m is None:
            self.samples.clear()

    def size(self) -> float | None:
        """The angular height to hold now: the body's height at the predicted range; without
        a range, the recent sightings' median."""
        prediction = self._prediction()
        now = None
        if prediction is not None and prediction.ground_xy_m is not None:
            now = self._factor(*prediction.ground_xy_m)
        if now is not None and self.samples:
            newest_ns = self.samples[-1][0]
            heights = [
                a / factor
                for t_ns, a, factor in self.samples
                if factor is not None and newest_ns - t_ns <= SIZE_WINDOW_S * 1e9
            ]
            if heights:
                return statistics.median(heights) * now
        recent = [a for _, a, _ in list(self.samples)[-SIZE_SAMPLES:]]
        return statistics.median(recent) if recent else None

    def _prediction(self) -> Prediction | None:
        """The source's prediction; another track's forgets the last one's sightings."""
        prediction = self.source.prediction
        if prediction is not None and prediction.track_id != self.track_id:
            self.track_id = prediction.track_id
            self.samples.clear()
        return prediction

    def _factor(self, x_m: float, y_m: float) -> float | None:
        """d / r² of a target at ground point (x, y) (None: no camera position, or the target
        under the camera)."""
        if self.camera_m is None:
            return None
        cx, cy, cz = self.camera_m
        d2 = (x_m - cx) ** 2 + (y_m - cy) ** 2
        r2 = d2 + (cz - self.point_height_m) ** 2
        return math.sqrt(d2) / r2 if d2 > 0.0 else None
