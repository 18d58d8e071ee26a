"""Scenarios by name: the trajectory `[sim] trajectory` (or a command's `--scenario`) names."""

from __future__ import annotations

from pathlib import Path

from gazed.config import TRAJECTORY_NAMES
from gazed.sim.random_walk import random_walk
from gazed.sim.reach import FieldOfRegard
from gazed.sim.trajectories import (
    RecordedTrack,
    SegmentPath,
    figure_eight,
    oval,
    read_pedestrians,
    rounded_square,
    stop_and_go,
)

Trajectory = SegmentPath | RecordedTrack

NAMES = TRAJECTORY_NAMES


def make_trajectory(
    spec: str,
    *,
    seed: int = 1,
    speed_m_s: float = 1.0,
    scale: float = 1.0,
    centre_xy_m: tuple[float, float] = (0.0, 0.0),
    base_dir: Path | None = None,
    reach: FieldOfRegard | None = None,
) -> Trajectory:
    """A trajectory by name (`NAMES`) or `file:PATH[#ped_id]` (default: the longest track);
    `random` keeps within `reach` when one is given."""
    if spec == "rounded-square":
        return rounded_square(speed_m_s, centre_xy_m)
    if spec == "oval":
        return oval(scale, centre_xy_m)
    if spec == "stop-and-go":
        return stop_and_go(speed_m_s, centre_xy_m)
    if spec == "figure-eight":
        return figure_eight(speed_m_s, 2.0 * scale, centre_xy_m)
    if spec == "random":
        return random_walk(seed, speed_m_s, 4.0 * scale, centre_xy_m, reach=reach)
    if spec.startswith("file:"):
        path_text, _, ped_text = spec[len("file:") :].partition("#")
        path = Path(path_text)
        if not path.is_absolute() and base_dir is not None:
            path = base_dir / path
        tracks = read_pedestrians(path)
        if ped_text:
            if int(float(ped_text)) not in tracks:
                raise ValueError(f"{path}: no pedestrian {ped_text}")
            times, xy = tracks[int(float(ped_text))]
        else:
            times, xy = max(tracks.values(), key=lambda track: len(track[0]))
        return RecordedTrack(times, xy * scale, centre_xy_m)
    raise ValueError(
        f"unknown trajectory {spec!r} (expected one of {', '.join(NAMES)} or file:PATH[#ped_id])"
    )
