"""Zoom control: hold the target's height in the frame with a zoom lens (`[gaze] zoom_*`).

It reads the gaze's latest detection (`Sightings.found`: the chosen track's mover) while it
pursues. The target's height is that of its box in the frame, the mover at the detection's
pixel (`Detection.movers`, `Mover.box_height_px`) less `zoom_box_margin_px` (the detector's
box reaches past the body by its smoothing), as a fraction h of the frame's height. Divided
by the lens's focal length at the frame's own zoom (the pose it was captured at), f_capture,
it is the target's size a = h / f_capture, which the zoom does not change; the median of the
last `SIZE_SAMPLES` sizes (a box the detector merged for a few frames with an edge behind the
target does not move the zoom) gives the focal length that shows the target at the setpoint
h*, h* / a: a goal that does not depend on how far the zoom has moved since the frames were
taken, so the loop's latency does not make it overshoot.

The frame must also hold the target: its centre at least `zoom_out_edge` of the frame's size
from the edge, and its independent image velocity at most `zoom_out_speed` frame heights per
second. Both scale with the focal length (a pixel offset and an image velocity are angles times
f), so each sighting gives the longest focal length that keeps them, its `room` times the focal
length it was seen at. The goal is the shorter of the two focal lengths, the setpoint's and
the room's: an escaping target is zoomed out just enough to keep it in the frame, not to the
widest, and the height is held again as soon as it is steady.

Each tick, the zoom demand moves towards a goal, at most `zoom_in_rate_s` or `zoom_out_rate_s`
(of the zoom range per second; the head's own rate limits the lens further) from the last
demand, within `zoom_min`..`zoom_max`. The goal moves only when the height is off it by more
than the hysteresis: `zoom_deadband`, or twice the standard deviation of the sizes' median where
the boxes are noisier (so the zoom does not hunt after the detector's noise):
- in any state but pursuit (and line tracing, which leaves the zoom alone), to the widest:
  a target is reacquired (search, saccade, lost) with the widest view first;
- in pursuit, with the focal length of the latest frame longer than the shorter of the
  setpoint's and the latest sighting's room by more than the hysteresis: out, to it at once;
- shorter than the shorter of the setpoint's and the room of every sighting of the last
  `zoom_in_steady_ms` (the focal length at which all of them would have held the target): in,
  to it, once pursuit has gone on for `zoom_in_steady_ms`, and never on a detection older than
  `lost_after_ms`; each tick the focal length nears that room by no more than the fraction
  dt / latency of their ratio (in logarithm), the latency being the latest sighting's age, so
  the zoom in does not outrun the evidence the frames give of the room;
- otherwise the demand stays.

Off (`zoom_control = false`, or a fixed lens) every demand goes out unchanged: no zoom.
"""

from __future__ import annotations

import itertools
import math
import statistics
from collections import deque
from dataclasses import dataclass

from gazed.config import GazeSection
from gazed.gaze.sightings import Sightings
from gazed.geometry.zoom import ZoomLens
from gazed.messages import Detection, GazeDemand, GazeStateName, Odometry

LEAVE_ALONE: tuple[GazeStateName, ...] = ("trace", "hold")  # states that never move the zoom
TICK_MAX_S = 0.5  # a longer gap between ticks ramps the zoom by this much time at most
SIZE_SAMPLES = 15  # the target's size is the median of this many sightings' (about 0.6 s)
MIN_SPREAD_SAMPLES = 5  # the sizes' spread is measured from this many on
MAD_TO_SIGMA = 1.4826  # a normal distribution's standard deviation over its median deviation
MEDIAN_SE_FACTOR = 1.2533  # a normal sample's median's standard error over the mean's
NOISE_DEADBANDS = 2.0  # the hysteresis: the goal moves by this many of its standard deviations
MIN_LATENCY_S = 1e-3  # a sighting's age below this counts as this


@dataclass(frozen=True)
class ZoomSighting:
    """What one detection says for the zoom: when it was taken, the focal length it was seen
    at, and by how much that focal length may grow (or must shrink, below 1) for the frame to
    hold the target (inside the edge margin, no faster than `zoom_out_speed`)."""

    t_capture_ns: int
    focal_px: float
    room: float


def target_height_px(detection: Detection) -> float | None:
    """The height of the target's box: the mover at the detection's pixel (None: no such
    mover, or one without a box)."""
    for mover in detection.movers:
        if (mover.u_px, mover.v_px) == (detection.u_px, detection.v_px):
            return mover.box_height_px if mover.box_height_px > 0 else None
    return None


class ZoomControl:
    """`apply` sets the zoom of each demand, from the detections `sightings` takes."""

    def __init__(self, gaze: GazeSection, lens: ZoomLens, sightings: Sightings) -> None:
        self.gaze = gaze
        self.lens = lens
        self.sightings = sightings
        self.enabled = gaze.zoom_control and lens.zooms_lens
        self.width_px, self.height_px = lens.base.width_px, lens.base.height_px
        self.stale_ns = round(gaze.lost_after_ms * 1e6)
        self.steady_ns = round(gaze.zoom_in_steady_ms * 1e6)
        self.seen: ZoomSighting | None = None
        self.sizes: deque[float] = deque(maxlen=SIZE_SAMPLES)  # h / f_capture (1/px)
        self.rooms: deque[tuple[int, float]] = deque()  # (t_capture_ns, room's focal_px)
        self.unsteady_ns: int | None = None  # when pursuit last began
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
            height = max(height_px - self.gaze.zoom_box_margin_px, 1.0) / h
            self.sizes.append(height / focal_px)
        self.rooms.append((detection.t_capture_ns, focal_px * room))
        while self.rooms[0][0] < detection.t_capture_ns - self.steady_ns:
            self.rooms.popleft()

    def apply(
        self,
        demand: GazeDemand | None,
        state: GazeStateName,
        odometry: Odometry | None,
        wall_ns: int,
        mono_s: float,
    ) -> GazeDemand | None:
        """The demand with the zoom to go to (unchanged when off, or in a state that leaves
        the zoom alone, or before the zoom's position is known; no demand, none)."""
        zoom = self.zoom(state, odometry, wall_ns, mono_s)
        if zoom is None or demand is None:
            return demand
        return demand.model_copy(update={"zoom": zoom})

    def zoom(
        self, state: GazeStateName, odometry: Odometry | None, wall_ns: int, mono_s: float
    ) -> float | None:
        """The zoom demand for this tick (None: leave the zoom)."""
        dt_s = 0.0 if self.last_s is None else min(max(mono_s - self.last_s, 0.0), TICK_MAX_S)
        self.last_s = mono_s
        if not self.enabled or state in LEAVE_ALONE:
            return None
        if state != "pursuit":
            self.unsteady_ns = wall_ns  # zoom in only after a while in pursuit
            self.sizes.clear()  # and sized afresh
            self.rooms.clear()
        elif self.sightings.found is not None:
            self.on_detection(self.sightings.found)
        if self.demanded is None:
            if odometry is None or odometry.zoom is None:
                return None
            self.demanded = odometry.zoom
        goal, rate_s = self._goal(state, wall_ns)
        now = self.demanded
        if goal is not None:
            goal = min(max(goal, self.gaze.zoom_min), self.gaze.zoom_max)
            step = rate_s * dt_s
            if goal > now:
                step = min(step, max(self._in_step(now, dt_s, wall_ns), 0.0))
            now = min(max(goal, now - step), now + step)
        self.demanded = now
        return now

    def _in_step(self, zoom: float, dt_s: float, wall_ns: int) -> float:
        """How far in the zoom may move this tick: its focal length nears the room of the
        recent sightings by the fraction dt / latency of their ratio (in logarithm), the latency
        being the latest sighting's age, so by the time a frame taken at the new zoom is seen
        the focal length has grown within what they allowed."""
        if self.seen is None or not self.rooms:
            return 0.0
        focal_px = self.lens.focal_px(zoom)
        room_px = min(room_px for _, room_px in self.rooms)
        if room_px <= focal_px:
            return 0.0
        latency_s = max((wall_ns - self.seen.t_capture_ns) / 1e9, dt_s, MIN_LATENCY_S)
        grown_px = focal_px * (room_px / focal_px) ** min(dt_s / latency_s, 1.0)
        return self.lens.zoom_for_focal(grown_px) - zoom

    def _size_noise(self) -> float:
        """The hysteresis the size's own noise asks for: twice the relative standard deviation
        of its median, so the zoom does not hunt after the noise of the boxes."""
        return NOISE_DEADBANDS * _relative_spread(self.sizes)

    def _goal(self, state: GazeStateName, wall_ns: int) -> tuple[float | None, float]:
        """Where the zoom should go and how fast (None: stay)."""
        gaze = self.gaze
        widest = (gaze.zoom_min, gaze.zoom_out_rate_s)
        if state != "pursuit":
            return widest
        seen = self.seen
        if seen is None or wall_ns - seen.t_capture_ns > self.stale_ns:
            return None, 0.0
        # the setpoint's focal length; with no size yet, none
        size_px = gaze.zoom_target_height / statistics.median(self.sizes) if self.sizes else 0.0
        band = max(gaze.zoom_deadband, self._size_noise())
        # out: to the shorter of the setpoint's and the longest the latest frame allows
        out_px = min(seen.focal_px * seen.room, size_px or seen.focal_px)
        if seen.focal_px / out_px > 1.0 + band:
            return self.lens.zoom_for_focal(out_px), gaze.zoom_out_rate_s
        began = self.unsteady_ns is None or seen.t_capture_ns - self.unsteady_ns >= self.steady_ns
        if not size_px or not began or not self.rooms:
            return None, 0.0
        # in: to the shorter of the setpoint's and the longest every recent frame allows
        in_px = min(size_px, min(room_px for _, room_px in self.rooms))
        if seen.focal_px / in_px < 1.0 - band:
            return self.lens.zoom_for_focal(in_px), gaze.zoom_in_rate_s
        return None, 0.0


def _relative_spread(sizes: deque[float]) -> float:
    """The relative standard deviation of the median of `sizes`, from the differences between
    successive sizes (so a target coming closer, whose size grows, is not taken for noise):
    their robust deviation (1.4826 MAD) over the root of 2, over the median, times the
    median's efficiency factor over the root of the count."""
    if len(sizes) < MIN_SPREAD_SAMPLES:
        return 0.0
    steps = [b - a for a, b in itertools.pairwise(sizes)]
    centre = statistics.median(steps)
    mad = statistics.median(abs(step - centre) for step in steps)
    sigma = MAD_TO_SIGMA * mad / math.sqrt(2.0)
    return MEDIAN_SE_FACTOR * sigma / statistics.median(sizes) / math.sqrt(len(sizes))


def _room(allowed: float, now: float) -> float:
    """How much a quantity that scales with the focal length may grow to reach `allowed`."""
    return math.inf if now <= 0.0 else allowed / now
