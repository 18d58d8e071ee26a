"""The `random` scenario: a seeded walker with human maneuvers that stays within the head's reach.

Straights of 1-4 s, turns of 20-60°/s for 1-3 s, speed changes to 0.5-1.5 times the nominal
speed, and stops of 1-4 s. A segment that starts farther than `radius_m` from the centre, or
would end beyond 1.5 `radius_m`, is replaced by a turn back towards the centre.

With a `reach` (the rig's field of regard, `reach.FieldOfRegard`), every segment is checked
along its path, together with the stop that could follow it, and only a segment that keeps the
walker within reach is walked. Otherwise the turn home is tried; if that leaves reach too, the
walker stops (the stop already checked), turns on the spot to the heading nearest the centre's
whose walk-off stays within reach, and walks off. So the walker never leaves the region a
controller can follow it in, whatever the seed.
"""

from __future__ import annotations

import math

import numpy as np

from gazed.sim.reach import FieldOfRegard
from gazed.sim.trajectories import Segment, SegmentPath, advance

CHECK_STEP_S = 0.1  # a segment's path is checked at this spacing
STOP_S = 1.0  # the stop that could follow any segment: speed to rest in this long
TURN_ON_SPOT_S = 0.5
WALK_OFF_S = 1.0
HEADING_STEP_RAD = math.radians(15.0)  # the headings tried for a walk-off, nearest home first

State = tuple[float, float, float, float]  # x, y, speed, heading


def random_walk(
    seed: int,
    speed_m_s: float = 1.0,
    radius_m: float = 4.0,
    centre_xy_m: tuple[float, float] = (0.0, 0.0),
    duration_s: float = 3600.0,
    reach: FieldOfRegard | None = None,
) -> SegmentPath:
    """The seeded walk from `centre_xy_m` (module docstring)."""
    if reach is not None and not bool(reach.contains(np.array(centre_xy_m))):
        raise ValueError(
            f"the walk's centre {centre_xy_m} is out of the head's reach: move [sim]"
            " area_centre_xy_m into the area the head can look at"
        )
    rng = np.random.default_rng(seed)
    cx, cy = centre_xy_m
    heading0 = float(rng.uniform(-math.pi, math.pi))
    state: State = (cx, cy, speed_m_s, heading0)
    segments: list[Segment] = []
    total = 0.0
    while total < duration_s:
        x, y, speed, _ = state
        segment = _random_segment(rng, speed, speed_m_s)
        end = advance(*state, segment, segment.duration_s)
        if (
            math.hypot(x - cx, y - cy) > radius_m
            or math.hypot(end[0] - cx, end[1] - cy) > 1.5 * radius_m
            or not _within(reach, state, segment)
        ):
            segment = _homing_segment(state, speed_m_s, centre_xy_m)
        chosen = [segment]
        if not _within(reach, state, segment):
            chosen = _stop_and_turn(reach, state, speed_m_s, centre_xy_m)
        for segment in chosen:
            state = _after(state, segment)
            segments.append(segment)
            total += segment.duration_s
    return SegmentPath(segments, centre_xy_m, speed_m_s, heading0, loop=False)


def _random_segment(rng: np.random.Generator, speed: float, nominal_m_s: float) -> Segment:
    kind = rng.choice(["straight", "turn", "speed", "stop"], p=[0.35, 0.35, 0.2, 0.1])
    if kind == "straight":
        return Segment(float(rng.uniform(1.0, 4.0)))
    if kind == "turn" and speed > 0.05:
        rate = math.radians(float(rng.uniform(20.0, 60.0))) * float(rng.choice([-1.0, 1.0]))
        return Segment(float(rng.uniform(1.0, 3.0)), curvature_1_m=rate / speed)
    if kind == "stop" and speed > 0.05:
        ramp_s = float(rng.uniform(0.8, 1.5))
        return Segment(ramp_s, accel_m_s2=-speed / ramp_s)
    target = float(rng.uniform(0.5, 1.5)) * nominal_m_s  # a speed change, or walking off
    ramp_s = float(rng.uniform(1.0, 2.0))
    return Segment(ramp_s, accel_m_s2=(target - speed) / ramp_s)


def _homing_segment(state: State, nominal_m_s: float, centre_xy_m: tuple[float, float]) -> Segment:
    """Turn towards the centre at 60°/s (walking off first if standing)."""
    x, y, speed, heading = state
    if speed < 0.3 * nominal_m_s:
        return Segment(WALK_OFF_S, accel_m_s2=(nominal_m_s - speed) / WALK_OFF_S)
    home = math.atan2(centre_xy_m[1] - y, centre_xy_m[0] - x)
    error = (home - heading + math.pi) % (2 * math.pi) - math.pi
    rate = math.copysign(math.radians(60.0), error)
    return Segment(max(abs(error), 0.1) / abs(rate), curvature_1_m=rate / speed)


def _stop_and_turn(
    reach: FieldOfRegard | None,
    state: State,
    nominal_m_s: float,
    centre_xy_m: tuple[float, float],
) -> list[Segment]:
    """Stop, turn on the spot to the heading nearest the centre's whose walk-off stays within
    reach, and walk off; stand if none does."""
    speed = state[2]
    stop = Segment(STOP_S, accel_m_s2=-speed / STOP_S)
    x, y, _, _ = advance(*state, stop, STOP_S)
    home = math.atan2(centre_xy_m[1] - y, centre_xy_m[0] - x)
    walk_off = Segment(WALK_OFF_S, accel_m_s2=nominal_m_s / WALK_OFF_S)
    for k in range(int(math.pi / HEADING_STEP_RAD) + 1):
        for sign in (1.0, -1.0):
            turned = home + sign * k * HEADING_STEP_RAD
            if _within(reach, (x, y, 0.0, turned), walk_off):
                return [stop, Segment(TURN_ON_SPOT_S, heading_rad=turned), walk_off]
    return [stop, Segment(STOP_S)]


def _after(state: State, segment: Segment) -> State:
    """The walker's state at the end of a segment from `state`."""
    if segment.heading_rad is not None:
        state = (state[0], state[1], state[2], segment.heading_rad)
    x, y, speed, heading = advance(*state, segment, segment.duration_s)
    return x, y, max(speed, 0.0), heading


def _within(reach: FieldOfRegard | None, state: State, segment: Segment) -> bool:
    """Whether the segment from `state`, and a stop after it, keep within reach."""
    if reach is None:
        return True
    if segment.heading_rad is not None:
        state = (state[0], state[1], state[2], segment.heading_rad)
    end = _after(state, segment)
    stop = Segment(STOP_S, accel_m_s2=-end[2] / STOP_S)
    points = [
        advance(*start, part, float(t))[:2]
        for start, part in ((state, segment), (end, stop))
        for t in np.linspace(0.0, part.duration_s, math.ceil(part.duration_s / CHECK_STEP_S) + 1)
    ]
    return bool(np.all(reach.contains(np.array(points))))
