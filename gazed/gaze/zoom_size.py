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

A box's edges are found to within a few pixels whatever its size, so its relative error falls
as the body's height in pixels grows: the body's height is a median weighted by the inverse
variance of that error, the square of the height in pixels that a body of unit height has at
the sighting's focal length and range, f d / r² (not of the box's own height, which a box
merged with clutter overstates), and sightings of the zoomed-in target outweigh those from the
widest view.

`recent_size` is the same over only the last `SIZE_SAMPLES` sightings: what the boxes say now.
The zoom zooms in only where both agree that the target is small (`zoom.py`): a track that has
left its target for clutter (the flow detector loses a target that stops) has boxes that
disagree with the body's height, and a zoom that follows the range of such a track in would
lose the real target for good.

The range is the estimator's ground position of the target (`Prediction.ground_xy_m`, taken
back to each sighting's capture with its ground velocity) against the camera's position
(`[calibration] camera_xyz_m`, the tracked point `target_height_m` above the ground). A rig
without the camera's position, or a prediction without a ground position, has no range: both
sizes are then the median of the last `SIZE_SAMPLES` sightings' a, sized afresh in each pursuit.
"""

from __future__ import annotations

import math
import statistics
from collections import deque
from typing import Protocol

from gazed.config import CalibrationSection
from gazed.messages import Prediction

SIZE_SAMPLES = 15  # the recent size is the median of this many sightings' (about 0.6 s)
SIZE_WINDOW_S = 10.0  # with a range, the body's height is the median of this long's sightings
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
        # (t_capture_ns, a, d / r² at capture or None without a range, the focal length)
        self.samples: deque[tuple[int, float, float | None, float]] = deque(maxlen=KEPT_SAMPLES)

    def add(self, t_capture_ns: int, angular_height: float, focal_px: float) -> None:
        """A sighting of the target: its box's height over the focal length it was seen at,
        and that focal length."""
        prediction = self._prediction()
        factor = None
        if prediction is not None and prediction.ground_xy_m is not None:
            dt_s = (t_capture_ns - prediction.t_effect_ns) / 1e9
            x, y = prediction.ground_xy_m
            vx, vy = prediction.ground_velocity_m_s or (0.0, 0.0)
            factor = self._factor(x + vx * dt_s, y + vy * dt_s)
        self.samples.append((t_capture_ns, angular_height, factor, focal_px))

    def restart(self) -> None:
        """A new pursuit: a size without a range starts afresh (the target may have moved);
        the body's height stays with its track."""
        if self.camera_m is None:
            self.samples.clear()

    def size(self) -> float | None:
        """The angular height to hold now: the body's height over the long window at the
        predicted range (None: nothing seen yet)."""
        return self._size(SIZE_WINDOW_S)

    def recent_size(self) -> float | None:
        """The same from the last `SIZE_SAMPLES` sightings only."""
        return self._size(None)

    def _size(self, window_s: float | None) -> float | None:
        """The size from the sightings within `window_s` of the newest (None: the last
        `SIZE_SAMPLES`); without a range now, the recent sightings' median."""
        prediction = self._prediction()
        now = None
        if prediction is not None and prediction.ground_xy_m is not None:
            now = self._factor(*prediction.ground_xy_m)
        samples = list(self.samples)
        # (t_capture_ns, the body's height, its weight)
        ranged = [(t_ns, a / f, (f * f_px) ** 2) for t_ns, a, f, f_px in samples if f is not None]
        if window_s is None:
            ranged = ranged[-SIZE_SAMPLES:]
        elif ranged:
            ranged = [r for r in ranged if ranged[-1][0] - r[0] <= window_s * 1e9]
        if now is not None and ranged:
            return now * weighted_median([h for _, h, _ in ranged], [w for *_, w in ranged])
        recent = [a for _, a, _, _ in samples[-SIZE_SAMPLES:]]
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


def weighted_median(values: list[float], weights: list[float]) -> float:
    """The value at which the weights below and above are each at most half the total (the
    lower of two that tie)."""
    pairs = sorted(zip(values, weights, strict=True))
    half, below = sum(weights) / 2.0, 0.0
    for value, weight in pairs:
        below += weight
        if below >= half:
            return value
    return pairs[-1][0]
