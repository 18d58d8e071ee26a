"""The target's body height, learnt from its boxes and its ground distance, and the size it has
at a distance: the zoom's size where the rig has ground geometry (`ZoomControl.size`).

A box measures how tall the target looks, which changes with its distance; how tall it is does
not. With the camera's centre at height z above the ground (`[calibration] camera_xyz_m`) and
the target's feet at ground distance d from below it, a body of height H spans the angle
α = atan(z / d) − atan((z − H) / d) from the camera, and a box that spans α says
H = z − d · tan(atan(z / d) − α). Each sighting of a track says one H, at the track's ground
position at the sighting's capture; the track's height is ln H's median over its sightings,
known to that median's standard error (1.4826 · MAD · 1.2533 / √n).

A motion detector's box of a person standing still is what still moves of them, often the same
hand or shoulder frame after frame, and a box merged with an edge behind them is too tall; on
a person's latest boxes alone, a few consistent ones of either kind are a size. Over a track's
life they are mostly a minority of its sightings (the detector sees a person by their walking),
and the median stands on the rest. The size at a distance is that body's angular height at the
track's ground position then: it follows the person's distance, and the boxes only teach it the
person's height. Where the person stood from the moment they were first seen, the height too is
learnt from what still moved of them, until they walk; `ZoomControl` takes the larger of this
size and the boxes'. Where the image rolls (a head whose pan axis is tilted), `ZoomControl`
gives the angle of the upright body behind each box, and the body's aspect (width over height),
whose median rolls the body back at the pose the size is for (`gazed.geometry.image_roll`).
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from gazed.gaze.median_error import median_and_error

HEIGHT_SAMPLES = 500  # a track's latest sightings that its height is the median of


def angular_height_rad(camera_z_m: float, distance_m: float, height_m: float) -> float:
    """The angle a body of `height_m`, standing `distance_m` along the ground from below a
    camera `camera_z_m` up, spans from the camera."""
    return math.atan2(camera_z_m, distance_m) - math.atan2(camera_z_m - height_m, distance_m)


def body_height_m(camera_z_m: float, distance_m: float, angle_rad: float) -> float | None:
    """The height of a body standing `distance_m` along the ground from below a camera
    `camera_z_m` up that spans `angle_rad` from it (None: no body spans it: its head would be
    past the zenith)."""
    head_rad = math.atan2(camera_z_m, distance_m) - angle_rad  # below the horizontal
    if head_rad <= -math.pi / 2:
        return None
    return camera_z_m - distance_m * math.tan(head_rad)


class TargetHeight:
    """`learn` one sighting of a track at a time; `angle_rad` is the track's angular height at
    a ground position, from its height so far."""

    def __init__(self, camera_xyz_m: tuple[float, float, float]) -> None:
        self.camera_xyz_m = camera_xyz_m
        self.track_id: int | None = None
        self.log_heights: deque[float] = deque(maxlen=HEIGHT_SAMPLES)
        self.log_aspects: deque[float] = deque(maxlen=HEIGHT_SAMPLES)  # width over height
        # the medians as they stand, taken again only after a sighting (None: not yet taken):
        # the zoom asks for them every tick
        self._height: tuple[float, float] | None = None
        self._aspect: float | None = None

    def distance_m(self, ground_xy_m: tuple[float, float]) -> float:
        """How far along the ground `ground_xy_m` lies from below the camera."""
        x, y, _ = self.camera_xyz_m
        return math.hypot(ground_xy_m[0] - x, ground_xy_m[1] - y)

    def learn(
        self,
        track_id: int | None,
        ground_xy_m: tuple[float, float],
        angle_rad: float,
        aspect: float | None = None,
    ) -> None:
        """A sighting of track `track_id` at `ground_xy_m` whose upright body spans `angle_rad`
        and is `aspect` as wide as tall (None: not known); a sighting of another track than the
        last starts the height afresh."""
        self._height = self._aspect = None
        if track_id != self.track_id:
            self.track_id = track_id
            self.log_heights.clear()
            self.log_aspects.clear()
        height_m = body_height_m(self.camera_xyz_m[2], self.distance_m(ground_xy_m), angle_rad)
        if height_m is not None:  # a box spans some angle: the body some height
            self.log_heights.append(math.log(height_m))
        if aspect is not None and aspect > 0:
            self.log_aspects.append(math.log(aspect))

    def aspect(self) -> float:
        """The body's width over its height, the median of its sightings' (0: none known)."""
        if self._aspect is None:
            logs = self.log_aspects
            self._aspect = math.exp(float(np.median(logs))) if logs else 0.0
        return self._aspect

    def height_m(self) -> tuple[float, float]:
        """The track's height (m) and the standard error of its logarithm (no sighting: an
        infinite error)."""
        if self._height is None:
            if not self.log_heights:
                self._height = (math.nan, math.inf)
            else:
                at, error = median_and_error(np.array(self.log_heights))
                self._height = (math.exp(at), error)
        return self._height

    def angle_rad(self, ground_xy_m: tuple[float, float]) -> tuple[float, float]:
        """The track's angular height at `ground_xy_m`, and its logarithm's standard error
        (that of the height's: the angle is about proportional to the height)."""
        height_m, error = self.height_m()
        if not math.isfinite(height_m):
            return math.nan, math.inf
        z = self.camera_xyz_m[2]
        return angular_height_rad(z, self.distance_m(ground_xy_m), height_m), error
