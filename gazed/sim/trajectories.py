"""Target trajectories on the ground plane, as functions of time.

Analytic paths are chains of segments of constant tangential acceleration `a` and constant
curvature `κ` (a straight line has κ = 0). Within a segment, with d(τ) = s0 τ + a τ²/2 the
distance travelled:

    s(τ) = s0 + a τ,    θ(τ) = θ0 + κ d(τ),    θ̇ = κ s(τ)
    κ = 0:  (X, Y) = (X0, Y0) + d (cos θ0, sin θ0)
    κ ≠ 0:  (X, Y) = (X0, Y0) + (1/κ) (sin θ - sin θ0, cos θ0 - cos θ)

so a constant-speed turn (seed 000's CS model) is a = 0, κ = ω / s, and a straight acceleration
(CD) is κ = 0, a ≠ 0. Heading θ is measured from +X towards +Y. Closed paths repeat forever;
recorded tracks (`file:`) hold their last position after their end.

Each state carries the name of the seed-000 model that describes it exactly (`CSD`, `CS`, `CD`,
or `stop`), so a consumer can score an estimator's model choice.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

OBSERVATION_S = 0.04  # seed 000 §4.2: the rounded square is 50 observations of 40 ms a side
PEDESTRIAN_FRAME_S = 0.04  # ETH/UCY: 10 frame_id units = 0.4 s


@dataclass(frozen=True)
class TargetState:
    """The target on the ground at one instant."""

    t_s: float
    xy_m: tuple[float, float]
    velocity_m_s: tuple[float, float]
    speed_m_s: float
    heading_rad: float
    accel_m_s2: float
    turn_rate_rad_s: float
    model: str  # CSD, CS, CD or stop


@dataclass(frozen=True)
class Segment:
    """Constant tangential acceleration and curvature for `duration_s`. A `heading_rad` set
    here replaces the heading inherited from the previous segment (a turn on the spot)."""

    duration_s: float
    accel_m_s2: float = 0.0
    curvature_1_m: float = 0.0
    heading_rad: float | None = None


@dataclass(frozen=True)
class _Start:
    t_s: float
    x_m: float
    y_m: float
    speed_m_s: float
    heading_rad: float


class SegmentPath:
    """A chain of segments from a start point, speed and heading; `loop` repeats it."""

    def __init__(
        self,
        segments: list[Segment],
        start_xy_m: tuple[float, float],
        speed_m_s: float,
        heading_rad: float,
        *,
        loop: bool = True,
    ) -> None:
        if not segments or any(s.duration_s <= 0 for s in segments):
            raise ValueError("a path needs segments of positive duration")
        self.segments = segments
        self.loop = loop
        self.period_s = sum(s.duration_s for s in segments)
        self._starts: list[_Start] = []
        t, x, y, speed, heading = 0.0, start_xy_m[0], start_xy_m[1], speed_m_s, heading_rad
        for segment in segments:
            if segment.heading_rad is not None:
                heading = segment.heading_rad
            self._starts.append(_Start(t, x, y, speed, heading))
            x, y, speed, heading = advance(x, y, speed, heading, segment, segment.duration_s)
            t += segment.duration_s
        self.end = (x, y, speed, heading)
        self._start_times_s = np.array([start.t_s for start in self._starts])

    @property
    def duration_s(self) -> float | None:
        return None if self.loop else self.period_s

    def state(self, t_s: float) -> TargetState:
        local = t_s % self.period_s if self.loop else min(max(t_s, 0.0), self.period_s)
        index = int(np.searchsorted(self._start_times_s, local, side="right")) - 1
        index = min(max(index, 0), len(self.segments) - 1)
        start, segment = self._starts[index], self.segments[index]
        tau = local - start.t_s
        x, y, speed, heading = advance(
            start.x_m, start.y_m, start.speed_m_s, start.heading_rad, segment, tau
        )
        return _state(t_s, x, y, speed, heading, segment)


def advance(
    x: float, y: float, s0: float, theta0: float, segment: Segment, tau: float
) -> tuple[float, float, float, float]:
    d = s0 * tau + 0.5 * segment.accel_m_s2 * tau * tau
    speed = s0 + segment.accel_m_s2 * tau
    k = segment.curvature_1_m
    if k == 0.0:
        return x + d * math.cos(theta0), y + d * math.sin(theta0), speed, theta0
    theta = theta0 + k * d
    return (
        x + (math.sin(theta) - math.sin(theta0)) / k,
        y + (math.cos(theta0) - math.cos(theta)) / k,
        speed,
        theta,
    )


def _state(
    t_s: float, x: float, y: float, speed: float, heading: float, segment: Segment
) -> TargetState:
    speed = max(speed, 0.0)  # a ramp to rest may end a rounding error below zero
    turn = segment.curvature_1_m * speed
    if speed <= 1e-9 and segment.accel_m_s2 == 0.0:
        model = "stop"
    elif segment.curvature_1_m != 0.0:
        model = "CS"
    elif segment.accel_m_s2 != 0.0:
        model = "CD"
    else:
        model = "CSD"
    velocity = (speed * math.cos(heading), speed * math.sin(heading))
    return TargetState(t_s, (x, y), velocity, speed, heading, segment.accel_m_s2, turn, model)


# -- the named trajectories --------------------------------------------------------------------


def rounded_square(
    speed_m_s: float = 1.0, centre_xy_m: tuple[float, float] = (0.0, 0.0)
) -> SegmentPath:
    """Seed 000 §4.2: 50 observations (2 s) straight, 50 turning at 45°/s (a quarter turn),
    four times: a square with rounded corners, at constant speed."""
    straight_s = turn_s = 50 * OBSERVATION_S
    turn_rate = math.radians(45.0)
    kappa = turn_rate / speed_m_s
    side = speed_m_s * straight_s
    radius = 1.0 / kappa
    half = side / 2 + radius  # the start is mid-way along the bottom side, heading +X
    start = (centre_xy_m[0] - side / 2, centre_xy_m[1] - half)
    segments = [Segment(straight_s), Segment(turn_s, curvature_1_m=kappa)] * 4
    return SegmentPath(segments, start, speed_m_s, 0.0)


def oval(scale: float = 1.0, centre_xy_m: tuple[float, float] = (0.0, 0.0)) -> SegmentPath:
    """Seed 000 §6: the toy engine's oval — two straights of 0.9 m, two semicircles, ~14 s a
    lap. On each straight the speed rises from 0.4 to 0.5 m/s in 2 s (0.9 m); each semicircle
    brings it back to 0.4 m/s in 5 s, so the speed is continuous and the mean turn rate is
    2π/10 rad/s as the paper recovered (its 3.3 m of curve at these speeds is inconsistent; we
    keep the speeds, times and turn rate). `scale` multiplies lengths and speeds, not times."""
    v0, v1 = 0.4 * scale, 0.5 * scale
    straight_s, curve_s = 2.0, 5.0
    radius = (v0 + v1) / 2 * curve_s / math.pi
    accel = (v1 - v0) / straight_s
    decel = (v0 - v1) / curve_s
    length = 0.9 * scale
    start = (centre_xy_m[0] - length / 2, centre_xy_m[1] - radius)
    segments = [
        Segment(straight_s, accel_m_s2=accel),
        Segment(curve_s, accel_m_s2=decel, curvature_1_m=1.0 / radius),
    ] * 2
    return SegmentPath(segments, start, v0, 0.0)


def stop_and_go(
    speed_m_s: float = 1.0, centre_xy_m: tuple[float, float] = (0.0, 0.0)
) -> SegmentPath:
    """A square walked side by side: speed up (1 s), cruise (2 s), slow down (1 s), stand
    (2 s), turn a quarter on the spot, next side."""
    ramp_s, cruise_s, stand_s = 1.0, 2.0, 2.0
    accel = speed_m_s / ramp_s
    side = speed_m_s * (ramp_s + cruise_s)
    start = (centre_xy_m[0] - side / 2, centre_xy_m[1] - side / 2)
    segments = []
    for corner in range(4):
        segments += [
            Segment(ramp_s, accel_m_s2=accel, heading_rad=corner * math.pi / 2),
            Segment(cruise_s),
            Segment(ramp_s, accel_m_s2=-accel),
            Segment(stand_s),
        ]
    return SegmentPath(segments, start, 0.0, 0.0)


def figure_eight(
    speed_m_s: float = 1.0, radius_m: float = 2.0, centre_xy_m: tuple[float, float] = (0.0, 0.0)
) -> SegmentPath:
    """Two circles of `radius_m` touching at the centre, one counter-clockwise then one
    clockwise, at constant speed: the turn rate flips sign at the crossing."""
    lap_s = 2 * math.pi * radius_m / speed_m_s
    kappa = 1.0 / radius_m
    segments = [Segment(lap_s, curvature_1_m=kappa), Segment(lap_s, curvature_1_m=-kappa)]
    return SegmentPath(segments, centre_xy_m, speed_m_s, math.pi / 2)


class RecordedTrack:
    """A pedestrian track (`frame_id ped_id x y`, 10 frame_id units = 0.4 s), moved so its mean
    lies at `centre_xy_m`, interpolated by a C1 cubic (Catmull-Rom) between samples. It holds
    its last position after the end."""

    def __init__(
        self, times_s: np.ndarray, xy_m: np.ndarray, centre_xy_m: tuple[float, float] = (0.0, 0.0)
    ) -> None:
        if len(times_s) < 2:
            raise ValueError("a recorded track needs at least two samples")
        self.times_s = times_s - times_s[0]
        self.xy_m = xy_m - xy_m.mean(axis=0) + np.asarray(centre_xy_m)
        # Catmull-Rom tangents (finite differences; one-sided at the ends)
        self.tangents = np.gradient(self.xy_m, self.times_s, axis=0)

    @property
    def duration_s(self) -> float:
        return float(self.times_s[-1])

    def state(self, t_s: float) -> TargetState:
        t = min(max(t_s, 0.0), self.duration_s)
        i = min(int(np.searchsorted(self.times_s, t, side="right")) - 1, len(self.times_s) - 2)
        t0, t1 = self.times_s[i], self.times_s[i + 1]
        h = t1 - t0
        u = (t - t0) / h
        p0, p1 = self.xy_m[i], self.xy_m[i + 1]
        m0, m1 = self.tangents[i] * h, self.tangents[i + 1] * h
        # cubic Hermite basis and its derivative
        position = (
            (2 * u**3 - 3 * u**2 + 1) * p0
            + (u**3 - 2 * u**2 + u) * m0
            + (-2 * u**3 + 3 * u**2) * p1
            + (u**3 - u**2) * m1
        )
        velocity = (
            (6 * u**2 - 6 * u) * p0
            + (3 * u**2 - 4 * u + 1) * m0
            + (-6 * u**2 + 6 * u) * p1
            + (3 * u**2 - 2 * u) * m1
        ) / h
        if t_s >= self.duration_s:
            velocity = np.zeros(2)
        speed = float(np.hypot(*velocity))
        heading = math.atan2(velocity[1], velocity[0]) if speed > 1e-9 else 0.0
        return TargetState(
            t_s,
            (float(position[0]), float(position[1])),
            (float(velocity[0]), float(velocity[1])),
            speed,
            heading,
            0.0,
            0.0,
            "stop" if speed < 0.05 else "recorded",
        )


def read_pedestrians(path: Path) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """ped_id -> (times_s, xy_m) from a file in the format of ../shared/data/pedestrians/."""
    data = np.loadtxt(path, ndmin=2)
    if data.shape[1] != 4:
        raise ValueError(f"{path}: expected 4 columns 'frame_id ped_id x y', got {data.shape[1]}")
    tracks = {}
    for ped in np.unique(data[:, 1]):
        rows = data[data[:, 1] == ped]
        rows = rows[np.argsort(rows[:, 0])]
        tracks[int(ped)] = (rows[:, 0] * PEDESTRIAN_FRAME_S, rows[:, 2:4].copy())
    return tracks
