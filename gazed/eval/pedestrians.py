"""Reader of pedestrian track files (`frame_id ped_id x y`, ../shared/data/pedestrians/).

Whitespace-separated floats, one observation per line, no header; 10 frame_id units are
0.4 s (the ETH/UCY convention). Tracks are returned sorted by time.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

SECONDS_PER_FRAME_UNIT = 0.04


class TrackFileError(ValueError):
    """The file is not in the `frame_id ped_id x y` format; the message names the line."""


@dataclass(frozen=True)
class Track:
    ped_id: float
    t_s: np.ndarray  # (K,)
    xy_m: np.ndarray  # (K, 2)


def read_tracks(path: Path) -> list[Track]:
    """Every pedestrian's track in the file, in order of first appearance."""
    rows: list[tuple[float, float, float, float]] = []
    try:
        text = Path(path).read_text()
    except OSError as exc:
        raise TrackFileError(f"{path}: cannot read ({exc.strerror})") from exc
    for number, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        fields = line.split()
        if len(fields) != 4:
            raise TrackFileError(
                f"{path}:{number}: expected 4 fields 'frame_id ped_id x y', got {len(fields)}"
            )
        try:
            values = tuple(float(f) for f in fields)
        except ValueError as exc:
            raise TrackFileError(f"{path}:{number}: not a number ({exc})") from exc
        if not all(np.isfinite(values)):
            raise TrackFileError(f"{path}:{number}: not finite")
        rows.append(values)  # type: ignore[arg-type]
    if not rows:
        raise TrackFileError(f"{path}: no observations")
    data = np.array(rows)
    tracks = []
    _, first = np.unique(data[:, 1], return_index=True)
    for ped in data[np.sort(first), 1]:
        own = data[data[:, 1] == ped]
        own = own[np.argsort(own[:, 0], kind="stable")]
        t = own[:, 0] * SECONDS_PER_FRAME_UNIT
        if np.any(np.diff(t) <= 0):
            raise TrackFileError(f"{path}: pedestrian {ped:g} has two observations in one frame")
        tracks.append(Track(float(ped), t, own[:, 2:4].copy()))
    return tracks
