"""Reader of pedestrian track files, in either of two formats told apart by the first line:

- `frame_id ped_id x y` (../shared/data/pedestrians/): whitespace-separated floats, one
  observation per line, no header; 10 frame_id units are 0.4 s (the ETH/UCY convention).
- annotated people in footage (`gazed.eval.truth`, the PETS 2009 truth): a CSV whose header
  names `frame, t_s, id, ..., x_m, y_m`; a person's track is its ground position `x_m, y_m` at
  the file's `t_s`.

Tracks are returned sorted by time.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gazed.eval.truth import TruthFileError, read_truth

SECONDS_PER_FRAME_UNIT = 0.04


class TrackFileError(ValueError):
    """The file is in neither format; the message names the line."""


@dataclass(frozen=True)
class Track:
    ped_id: float
    t_s: np.ndarray  # (K,)
    xy_m: np.ndarray  # (K, 2)


def read_tracks(path: Path) -> list[Track]:
    """Every pedestrian's track in the file, in order of first appearance."""
    try:
        text = Path(path).read_text()
    except OSError as exc:
        raise TrackFileError(f"{path}: cannot read ({exc.strerror})") from exc
    first = next((line for line in text.splitlines() if line.strip()), "")
    if first.lstrip().startswith("frame,"):
        return _annotated_tracks(path)
    rows: list[tuple[float, float, float, float]] = []
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


def _annotated_tracks(path: Path) -> list[Track]:
    try:
        people = read_truth(path)
    except TruthFileError as exc:
        raise TrackFileError(str(exc)) from exc
    for person in people.values():
        if np.any(np.diff(person.t_s) <= 0):
            raise TrackFileError(f"{path}: person {person.id}'s times do not increase with frame")
    return [Track(float(p.id), p.t_s.copy(), p.ground_m.copy()) for p in people.values()]
