"""Zoom control: hold the target's height in the frame with a zoom lens (`[gaze] zoom_*`).

It reads the gaze's latest detection (`Sightings.found`: the chosen track's mover) while it
pursues. The target's height is that of its box in the frame, the mover at the detection's
pixel (`Detection.movers`, `Mover.box_height_px`) less `zoom_box_margin_px` (the detector's
box reaches past the body by its smoothing), as a fraction h of the frame's height. Divided
by the lens's focal length at the frame's own zoom (the pose it was captured at), f_capture,
it is the target's size a = h / f_capture, which the zoom does not change. The size the zoom
acts on is that of the last `SIZE_SAMPLES` sightings taken to the instant the demand acts (now
plus the actuation latency): a target nearing the camera grows as it comes, ln a along a line
over a fraction of a second, and the frames are a visual latency old. So ln a's Theil-Sen line
through the sightings (the median of the pairwise slopes, and the median intercept: a box the
detector merged for a few frames with an edge behind the target moves it no more than it moves
a median) is taken to that instant; with fewer sightings, their median. It gives the focal
length that shows the target at the setpoint h*, h* / a: a goal that does not depend on how far
the zoom has moved since the frames were taken, so the loop's latency does not make it
overshoot. Where the rig places the camera over the ground and the chosen track has a ground
position, the size is the larger of that and the size at the track's predicted distance of the
height its boxes teach (`gazed.gaze.target_height`): a standing person's boxes are what still
moves of them, often alike and small frame after frame, and too small a size zooms the target
out of the frame where too large a one only shows it smaller. Where the image rolls (a head
whose pan axis is tilted from the vertical, `roll`), each box is taken back to its upright body
at the sighting's pose to teach the height, and the body at the distance is rolled by the roll
at the prediction's pose: the box of a rolled body takes in its width.

The frame must also hold the target: its centre at least `zoom_out_edge` of the frame's size
from the edge, and its independent image velocity at most `zoom_out_speed` frame heights per
second. Both scale with the focal length (a pixel offset and an image velocity are angles times
f), so each sighting gives the longest focal length that keeps them, its `room` times the focal
length it was seen at. The goal is the shorter of the two focal lengths, the setpoint's and
the room's: an escaping target is zoomed out just enough to keep it in the frame, not to the
widest, and the height is held again as soon as it is steady.

Each tick, the zoom demand moves towards a goal, at most `zoom_in_rate_s` or `zoom_out_rate_s`
(of the zoom range per second) from the last demand, within `zoom_min`..`zoom_max`:
- in any state but pursuit and lost (and line tracing, which leaves the zoom alone), to the
  widest: a target is reacquired (search, saccade) with the widest view first;
- lost, out to the longest focal length whose frame holds the lost search's region (the
  controller's `region_rad`, the circle the target can be in around the prediction) with its
  centre at least `zoom_out_edge` from the frame's edge, as pursuit's room holds the target:
  the view widens as the region grows, never in. A motion detector loses a person who stops
  walking, and the region around a track that has stopped stays small, so the view that
  showed them still shows them when they walk on; a target that vanished at speed has a
  region that grows fast, and the view widens with it. Without a region (no prediction to
  coast on), to the widest;
- in pursuit, with the focal length of the latest frame longer than the goal's by more than
  the deadband: out, to the goal; shorter: in, to it, but only once the target has been
  steady (its room at least 1) for `zoom_in_steady_ms`, only on a size known to within the
  deadband (`size`'s error: the sightings' scatter about their line, or the height's about its
  median, as a standard error), and never on a detection older than `lost_after_ms`. A
  motion detector's boxes of a person standing still are what still moves of them, a hand or
  a shoulder, and scatter by factors from frame to frame: the zoom does not go in on them;
- otherwise the demand stays.

Off (`zoom_control = false`, or a fixed lens) every demand goes out unchanged: no zoom.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from gazed.config import GazeSection
from gazed.gaze.median_error import median_and_error
from gazed.gaze.pursuit import Pursuit
from gazed.gaze.sightings import Sightings
from gazed.gaze.target_height import TargetHeight
from gazed.geometry.image_roll import rolled_box, upright_body
from gazed.geometry.zoom import ZoomLens
from gazed.messages import Detection, GazeDemand, GazeStateName, Mover, Odometry

LEAVE_ALONE: tuple[GazeStateName, ...] = ("trace", "hold")  # states that never move the zoom
TICK_MAX_S = 0.5  # a longer gap between ticks ramps the zoom by this much time at most
SIZE_SAMPLES = 15  # the target's size is the line through this many sightings' (about 0.6 s)


@dataclass(frozen=True)
class ZoomSighting:
    """What one detection says for the zoom: when it was taken, the focal length it was seen
    at, and by how much that focal length may grow (or must shrink, below 1) for the frame to
    hold the target (inside the edge margin, no faster than `zoom_out_speed`)."""

    t_capture_ns: int
    focal_px: float
    room: float


def target_mover(detection: Detection) -> Mover | None:
    """The target's own mover: the one at the detection's pixel (None: no such mover)."""
    for mover in detection.movers:
        if (mover.u_px, mover.v_px) == (detection.u_px, detection.v_px):
            return mover
    return None


def target_height_px(detection: Detection) -> float | None:
    """The height of the target's box: the mover at the detection's pixel (None: no such
    mover, or one without a box)."""
    mover = target_mover(detection)
    return mover.box_height_px if mover is not None and mover.box_height_px > 0 else None


class ZoomControl:
    """`apply` sets the zoom of each demand, from the detections `sightings` takes."""

    def __init__(
        self,
        gaze: GazeSection,
        lens: ZoomLens,
        sightings: Sightings,
        pursuit: Pursuit | None = None,
        camera_xyz_m: tuple[float, float, float] | None = None,
        roll: Callable[[float, float], float] | None = None,
    ) -> None:
        self.gaze = gaze
        self.roll = roll  # the image's roll at a (pan, tilt): None, the image never rolls
        self.lens = lens
        self.sightings = sightings
        self.pursuit = pursuit  # the chosen track's predictions: its ground position
        # the target's height, where the rig places the camera over the ground
        self.target_height = TargetHeight(camera_xyz_m) if camera_xyz_m is not None else None
        self.enabled = gaze.zoom_control and lens.zooms_lens
        self.width_px, self.height_px = lens.base.width_px, lens.base.height_px
        self.steady_ns = round(gaze.zoom_in_steady_ms * 1e6)
        self.seen: ZoomSighting | None = None
        # each sighting's capture time and ln a, a = h / f_capture (1/px)
        self.sizes: deque[tuple[int, float]] = deque(maxlen=SIZE_SAMPLES)
        self.unsteady_ns: int | None = None  # the last time the target was not steady
        self.demanded: float | None = None
        self.last_s: float | None = None

    def on_detection(self, detection: Detection) -> None:
        """A found detection of the target the gaze follows; one without a head pose, or not
        newer than the last, says nothing new."""
        seen = self.seen
        if detection.head is None or (
            seen is not None and seen.t_capture_ns >= detection.t_capture_ns
        ):
            return
        u, v, w, h = detection.u_px, detection.v_px, self.width_px, self.height_px
        inside = 0.5 - self.gaze.zoom_out_edge  # of the frame's size, from its centre
        speed = math.hypot(detection.du_px_s, detection.dv_px_s) / h
        room = min(
            _room(inside * w, abs(u - (w - 1) / 2.0)),
            _room(inside * h, abs(v - (h - 1) / 2.0)),
            _room(self.gaze.zoom_out_speed, speed),
        )
        focal_px = self.lens.focal_px(detection.head.zoom)
        self.seen = ZoomSighting(detection.t_capture_ns, focal_px, room)
        height_px = target_height_px(detection)
        if height_px is not None:
            body_px = max(height_px - self.gaze.zoom_box_margin_px, 1.0)
            self.sizes.append((detection.t_capture_ns, math.log(body_px / h / focal_px)))
            ground = self._ground_at(detection.t_capture_ns)
            if self.target_height is not None and ground is not None:
                self._learn_height(detection, body_px, focal_px, ground)
        if room < 1.0:
            self.unsteady_ns = detection.t_capture_ns

    def _learn_height(
        self, detection: Detection, body_px: float, focal_px: float, ground: tuple[float, float]
    ) -> None:
        """Teach the target's height one sighting: its box, upright where the image rolls."""
        assert self.target_height is not None and detection.head is not None
        upright_px, aspect = body_px, None
        mover = target_mover(detection)
        if self.roll is not None and mover is not None and mover.box_width_px > 0:
            width_px = max(mover.box_width_px - self.gaze.zoom_box_margin_px, 1.0)
            roll = self.roll(detection.head.pan_rad, detection.head.tilt_rad)
            try:
                upright_px, upright_width_px = upright_body(body_px, width_px, roll)
            except ValueError:
                return  # rolled by 45°: the box does not tell the height
            if upright_px <= 0 or upright_width_px <= 0:
                return  # a box no upright body fills at this roll: the detector's, not a body
            aspect = upright_width_px / upright_px
        angle_rad = 2.0 * math.atan(upright_px / (2.0 * focal_px))
        self.target_height.learn(self._track_id(), ground, angle_rad, aspect)

    def apply(
        self,
        demand: GazeDemand | None,
        state: GazeStateName,
        odometry: Odometry | None,
        wall_ns: int,
        mono_s: float,
        actuation_s: float = 0.0,
        region_rad: float | None = None,
    ) -> GazeDemand | None:
        """The demand with the zoom to go to (unchanged when off, or in a state that leaves
        the zoom alone, or before the zoom's position is known; no demand, none).
        `actuation_s`: how long after `wall_ns` the demand acts; `region_rad`: lost, the
        radius of the search region around the prediction the frame is to hold."""
        zoom = self.zoom(state, odometry, wall_ns, mono_s, actuation_s, region_rad)
        if zoom is None or demand is None:
            return demand
        return demand.model_copy(update={"zoom": zoom})

    def zoom(
        self,
        state: GazeStateName,
        odometry: Odometry | None,
        wall_ns: int,
        mono_s: float,
        actuation_s: float = 0.0,
        region_rad: float | None = None,
    ) -> float | None:
        """The zoom demand for this tick (None: leave the zoom)."""
        dt_s = 0.0 if self.last_s is None else min(max(mono_s - self.last_s, 0.0), TICK_MAX_S)
        self.last_s = mono_s
        if not self.enabled or state in LEAVE_ALONE:
            return None
        if state != "pursuit":
            self.unsteady_ns = wall_ns  # steady again only after a while in pursuit
            self.sizes.clear()  # and sized afresh
        elif self.sightings.found is not None:
            self.on_detection(self.sightings.found)
        if self.demanded is None:
            if odometry is None or odometry.zoom is None:
                return None
            self.demanded = odometry.zoom
        goal, rate_s = self._goal(state, wall_ns, wall_ns + round(actuation_s * 1e9), region_rad)
        now = self.demanded
        if goal is not None:
            goal = min(max(goal, self.gaze.zoom_min), self.gaze.zoom_max)
            step = rate_s * dt_s
            now = min(max(goal, now - step), now + step)
        self.demanded = now
        return now

    def _goal(
        self, state: GazeStateName, wall_ns: int, effect_ns: int, region_rad: float | None
    ) -> tuple[float | None, float]:
        """Where the zoom should go and how fast (None: stay), for a demand that acts at
        `effect_ns`."""
        gaze = self.gaze
        widest = (gaze.zoom_min, gaze.zoom_out_rate_s)
        if state == "lost" and region_rad is not None:
            return self._holding(region_rad), gaze.zoom_out_rate_s
        if state != "pursuit":
            return widest
        seen = self.seen
        if seen is None or not self.sightings.fresh(seen.t_capture_ns, wall_ns):
            return None, 0.0
        goal_px = seen.focal_px * seen.room  # the longest focal length the frame allows
        # and the setpoint's; with no size yet, only out
        size_px, size_error = 0.0, math.inf
        if self.sizes:
            size, size_error = self.size(effect_ns)
            size_px = gaze.zoom_target_height / size
        goal_px = min(goal_px, size_px or seen.focal_px)
        ratio = seen.focal_px / goal_px  # the height it has now, of the goal's
        if abs(ratio - 1.0) <= gaze.zoom_deadband:
            return None, 0.0
        goal = self.lens.zoom_for_focal(goal_px)
        if ratio > 1.0:
            return goal, gaze.zoom_out_rate_s
        steady = self.unsteady_ns is None or seen.t_capture_ns - self.unsteady_ns >= self.steady_ns
        # a goal past the latest frame's focal length comes from the sizes: are they known?
        known = size_error <= gaze.zoom_deadband
        return (goal, gaze.zoom_in_rate_s) if steady and known else (None, 0.0)

    def _holding(self, region_rad: float) -> float | None:
        """The zoom whose frame holds a circle of `region_rad` about its centre inside the edge
        margin, where the demand is longer; None where it already does."""
        assert self.demanded is not None
        inside_px = (0.5 - self.gaze.zoom_out_edge) * min(self.width_px, self.height_px)
        reach = math.tan(min(region_rad, 0.5 * math.pi - 1e-6))  # px per px of focal length
        if self.lens.focal_px(self.demanded) * reach <= inside_px:
            return None
        return self.lens.zoom_for_focal(inside_px / reach)

    def size(self, t_ns: int) -> tuple[float, float]:
        """The target's size a = h / f (1/px) at `t_ns`, and the standard error of ln a: the
        boxes' (`box_size`), or where the rig places the camera over the ground and the chosen
        track has a ground position then, the larger of that and the size at its distance: the
        angular height α of the track's height learnt so far (`TargetHeight`) at its position,
        a = 2 tan(α / 2) / the frame's height. Each errs small in its own way, the boxes while
        the person stands, the height while most of what it learnt from was such boxes; and
        too large a size only shows the target smaller, too small a one zooms it out of the
        frame."""
        by_boxes = self.box_size(t_ns)
        ground = self._ground_at(t_ns)
        height = self.target_height
        if height is None or ground is None or height.track_id != self._track_id():
            return by_boxes
        angle_rad, error = height.angle_rad(ground)
        if not math.isfinite(angle_rad):
            return by_boxes
        prediction = self.pursuit.prediction if self.pursuit is not None else None
        aspect = height.aspect()
        if self.roll is not None and prediction is not None and aspect > 0:
            # rolled back only where the height was learnt upright (boxes with a width)
            roll = self.roll(prediction.pan_rad, prediction.tilt_rad)
            angle_rad = rolled_box(angle_rad, aspect * angle_rad, roll)[0]
        by_distance = (2.0 * math.tan(angle_rad / 2.0) / self.height_px, error)
        return by_distance if by_distance[0] > by_boxes[0] else by_boxes

    def box_size(self, t_ns: int) -> tuple[float, float]:
        """The target's size a at `t_ns` from the sightings' boxes: ln a's Theil-Sen line
        through a full window of them taken to that instant, or the median of fewer; and the
        standard error of ln a, from the sightings' scatter about the line (or the median,
        `median_and_error`)."""
        times_ns, logs = zip(*self.sizes, strict=True)
        t_s = (np.array(times_ns) - t_ns) * 1e-9  # before the instant: negative
        y = np.array(logs)
        if len(y) < SIZE_SAMPLES:
            intercepts = y
        else:
            i, j = np.triu_indices(len(y), 1)
            slope = float(np.median((y[j] - y[i]) / (t_s[j] - t_s[i])))  # sightings: newer each
            intercepts = y - slope * t_s
        at, error = median_and_error(intercepts)
        return math.exp(at), error

    def _ground_at(self, t_ns: int) -> tuple[float, float] | None:
        return self.pursuit.ground_at(t_ns) if self.pursuit is not None else None

    def _track_id(self) -> int | None:
        prediction = self.pursuit.prediction if self.pursuit is not None else None
        return prediction.track_id if prediction is not None else None


def _room(allowed: float, now: float) -> float:
    """How much a quantity that scales with the focal length may grow to reach `allowed`."""
    return math.inf if now <= 0.0 else allowed / now
