"""Reader of annotated people in footage: one row per person per frame, as the PETS 2009 S2.L1
truth in `../shared/data/footage/pets09-s2l1/` gives them.

Columns (a header line names them, in any order; more columns are allowed):
`frame, t_s, id, box_u_px, box_v_px, box_w_px, box_h_px, foot_u_px, foot_v_px, x_m, y_m` —
the frame index, its time, the person's id, the box's centre and size in the video's pixels,
the middle of the box's bottom edge, and that foot point on the ground in metres.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

COLUMNS = (
    "frame",
    "t_s",
    "id",
    "box_u_px",
    "box_v_px",
    "box_w_px",
    "box_h_px",
    "foot_u_px",
    "foot_v_px",
    "x_m",
    "y_m",
)


class TruthFileError(ValueError):
    """The file is not an annotation file; the message names the file and the line."""


@dataclass(frozen=True)
class Person:
    """One annotated person, by frame: every array has one row per annotated frame."""

    id: int
    frame: np.ndarray  # (K,) int, increasing
    t_s: np.ndarray  # (K,)
    box_px: np.ndarray  # (K, 4): centre u, centre v, width, height
    foot_px: np.ndarray  # (K, 2)
    ground_m: np.ndarray  # (K, 2)

    @property
    def seconds_visible(self) -> float:
        return float(self.t_s[-1] - self.t_s[0]) if len(self.t_s) else 0.0

    def at_frame(self, frame: int) -> int | None:
        """The row of `frame`, or None where the person is not annotated in it."""
        row = int(np.searchsorted(self.frame, frame))
        return row if row < len(self.frame) and self.frame[row] == frame else None


def read_truth(path: str | Path) -> dict[int, Person]:
    """Every person in the file by id, each with its rows in frame order."""
    path = Path(path)
    try:
        handle = path.open(newline="")
    except OSError as exc:
        raise TruthFileError(f"{path}: cannot read ({exc.strerror})") from exc
    rows: dict[int, list[list[float]]] = {}
    with handle:
        reader = csv.DictReader(handle)
        missing = [c for c in COLUMNS if c not in (reader.fieldnames or [])]
        if missing:
            raise TruthFileError(
                f"{path}:1: missing column(s) {', '.join(missing)} "
                f"(expected a header with {', '.join(COLUMNS)})"
            )
        for record in reader:
            line = reader.line_num
            try:
                values = [float(record[c]) for c in COLUMNS]
            except (TypeError, ValueError) as exc:
                raise TruthFileError(f"{path}:{line}: not a number ({exc})") from exc
            if not all(math.isfinite(v) for v in values):
                raise TruthFileError(f"{path}:{line}: not finite")
            if values[0] < 0 or values[0] != int(values[0]) or values[2] != int(values[2]):
                raise TruthFileError(f"{path}:{line}: frame and id must be whole numbers >= 0")
            if values[5] <= 0 or values[6] <= 0:
                raise TruthFileError(f"{path}:{line}: the box must have a positive size")
            rows.setdefault(int(values[2]), []).append(values)
    if not rows:
        raise TruthFileError(f"{path}: no annotations")
    people = {}
    for person_id, own in rows.items():
        data = np.array(own)
        data = data[np.argsort(data[:, 0], kind="stable")]
        if np.any(np.diff(data[:, 0]) == 0):
            raise TruthFileError(f"{path}: person {person_id} is annotated twice in one frame")
        people[person_id] = Person(
            id=person_id,
            frame=data[:, 0].astype(int),
            t_s=data[:, 1],
            box_px=data[:, 3:7],
            foot_px=data[:, 7:9],
            ground_m=data[:, 9:11],
        )
    return people
