"""Scores of a closed-loop run on footage against one annotated person (`gazed eval loop --truth`).

The frames are the views the head rendered (`ViewFrame`: the footage frame each came from, its
capture time, the head's pose then, whether the gaze was pursuing); `ViewPeople` places every
person annotated in that footage frame in the view. For the scored person:

- the run is from the first frame in which the person is inside the wide view to the frame
  they leave it (the first frame after that without them); `visible_frames` counts it;
- acquisition: the first frame of the run from which the person's box centre stays within the
  fovea for `ACQUIRED_FRAMES` frames (`loop_metrics.acquisition_index`); `acquired_after_s` is
  its capture time after the run's first frame;
- from acquisition to the run's end: `fovea_fraction` (frames with the box centre within the
  fovea over frames in the run), the gaze error RMS / p95 (the angle between the view's axis and
  the box centre), and `switches`: runs of at least `SWITCH_FRAMES` frames in which the gaze
  pursues another annotated person (`PeopleInView.gaze_on`) and the view's centre is not in the
  scored person's box (where two boxes overlap at the view's centre, the view shows the scored
  person too: which of the two the gaze is on is not told by the nearer box centre);
- `ground_rmse_m`: the estimator's ground point (its chosen track, not coasting) at a frame's
  capture time against the person's annotated ground point in that frame, from acquisition.

`reach_scores` tells, over the same frames, the share in which the head could not put the
person in its fovea within its joint limits, and the fovea fraction over the others: a loop
that could not follow from a person who walked where the head cannot look.

`pursuit_summary` tells what a run shows without truth: when the gaze
first pursued for `ACQUIRED_FRAMES` frames, the share of frames in pursuit from then, and how
often the pursued track's id changed for at least `SWITCH_FRAMES` frames.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from gazed.eval.loop_metrics import acquisition_index
from gazed.eval.truth import Person
from gazed.eval.view_people import PeopleInView, ViewPeople
from gazed.messages import EstimatorState

SWITCH_FRAMES = 3


@dataclass(frozen=True)
class ViewFrame:
    """One view the head rendered: its footage frame, capture time and pose, and the gaze then
    (pursuing or not, the track it follows)."""

    frame: int
    t_capture_ns: int
    pan_rad: float
    tilt_rad: float
    pursuing: bool
    target_id: int | None = None


def people_at(people: dict[int, Person], frame: int) -> tuple[list[int], np.ndarray]:
    """The ids of the people annotated in `frame` and their boxes (N, 4)."""
    ids, boxes = [], []
    for person in people.values():
        row = person.at_frame(frame)
        if row is not None:
            ids.append(person.id)
            boxes.append(person.box_px[row])
    return ids, np.array(boxes).reshape(-1, 4)


@dataclass(frozen=True)
class FrameFacts:
    """Every frame's annotated people (their ids, in the order of `seen`'s rows), where they are
    in the view, and the id of the one the gaze pursues (None: none, or not pursuing)."""

    ids: list[list[int]]
    seen: list[PeopleInView]
    gaze_on: list[int | None]

    @classmethod
    def of(
        cls, frames: list[ViewFrame], people: dict[int, Person], geometry: ViewPeople
    ) -> FrameFacts:
        ids, seen, gaze_on = [], [], []
        for frame in frames:
            own, boxes = people_at(people, frame.frame)
            here = geometry.at_pose(boxes, frame.pan_rad, frame.tilt_rad)
            on = here.gaze_on()
            ids.append(own)
            seen.append(here)
            gaze_on.append(own[on] if on is not None and frame.pursuing else None)
        return cls(ids, seen, gaze_on)

    def person(self, person_id: int) -> PersonFrames:
        """The person in every frame."""
        n = len(self.ids)
        visible, reachable, held = np.zeros(n, bool), np.zeros(n, bool), np.zeros(n, bool)
        error = np.full(n, np.nan)
        for k, (own, here) in enumerate(zip(self.ids, self.seen, strict=True)):
            if person_id in own:
                row = own.index(person_id)
                visible[k], error[k] = here.in_wide[row], here.error_rad[row]
                reachable[k], held[k] = here.reachable[row], here.held[row]
        return PersonFrames(visible, error, reachable, held)


@dataclass(frozen=True)
class PersonFrames:
    """Per frame: whether the person is in the wide view, their gaze error (nan where not
    annotated), whether the head could foveate them and whether their box holds the view's
    centre."""

    visible: np.ndarray
    error_rad: np.ndarray
    reachable: np.ndarray
    held: np.ndarray

    def scored(self, fovea_rad: float) -> tuple[int, int | None, int] | None:
        """The run's first frame, its acquisition (None: not acquired) and its end."""
        span = run_span(self.visible)
        if span is None:
            return None
        first, end = span
        acquired = acquisition_index(self.error_rad[first:end], fovea_rad)
        return first, None if acquired is None else first + acquired, end


def run_span(visible: np.ndarray) -> tuple[int, int] | None:
    """[first, end) of the first run of frames in which the person is in the wide view."""
    inside = np.flatnonzero(visible)
    if not len(inside):
        return None
    first = int(inside[0])
    gone = np.flatnonzero(~visible[first:])
    return first, first + int(gone[0]) if len(gone) else len(visible)


def count_switches(others: list[bool]) -> int:
    """Runs of at least SWITCH_FRAMES frames pursuing another person."""
    switches = run = 0
    for other in [*others, False]:
        if other:
            run += 1
            continue
        switches += run >= SWITCH_FRAMES
        run = 0
    return switches


def score_person(
    frames: list[ViewFrame],
    facts: FrameFacts,
    person: Person,
    fovea_half_angle_deg: float,
    estimates: list[EstimatorState],
) -> dict[str, Any]:
    """The `person` scores of the module docstring (frames in capture order, `facts` of them)."""
    person_id = person.id
    own = facts.person(person_id)
    result: dict[str, Any] = {
        "id": person_id,
        "visible_frames": 0,
        "acquired_after_s": None,
        "fovea_fraction": 0.0,
        "switches": None,
        "gaze_error_deg": None,
        "ground_rmse_m": None,
    }
    scored = own.scored(math.radians(fovea_half_angle_deg))
    if scored is None:
        return result
    first, start, end = scored
    result["visible_frames"] = end - first
    if start is None:
        return result
    after_deg = np.degrees(own.error_rad[start:end])
    result.update(
        acquired_after_s=round((frames[start].t_capture_ns - frames[first].t_capture_ns) / 1e9, 3),
        fovea_fraction=round(float(np.mean(after_deg <= fovea_half_angle_deg)), 4),
        switches=count_switches(
            [
                on is not None and on != person_id and not held
                for on, held in zip(facts.gaze_on[start:end], own.held[start:end], strict=True)
            ]
        ),
        gaze_error_deg={
            "rms": round(float(np.sqrt(np.mean(after_deg**2))), 4),
            "p95": round(float(np.percentile(after_deg, 95)), 4),
        },
        ground_rmse_m=ground_rmse_m(frames[start:end], person, estimates),
    )
    return result


def reach_scores(
    facts: FrameFacts, person_id: int, fovea_half_angle_deg: float
) -> dict[str, float | None]:
    """Over the person's scored frames (from acquisition, or the run's first frame when not
    acquired): the share the head could not foveate, and the fovea fraction over the rest."""
    own = facts.person(person_id)
    scored = own.scored(math.radians(fovea_half_angle_deg))
    if scored is None:
        return {"out_of_reach_fraction": None, "fovea_fraction_reachable": None}
    first, start, end = scored
    frames = slice(first if start is None else start, end)
    reachable = own.reachable[frames]
    inside = np.degrees(own.error_rad[frames][reachable]) <= fovea_half_angle_deg
    fraction = round(float(np.mean(inside)), 4) if inside.size else None
    return {
        "out_of_reach_fraction": round(float(np.mean(~reachable)), 4),
        "fovea_fraction_reachable": 0.0 if start is None else fraction,
    }


def ground_rmse_m(
    frames: list[ViewFrame], person: Person, estimates: list[EstimatorState]
) -> float | None:
    """The estimator's ground point at each frame's capture against the person's, RMS (m)."""
    frame_at = {f.t_capture_ns: f.frame for f in frames}
    squared = []
    for estimate in estimates:
        frame = frame_at.get(estimate.t_capture_ns)
        if frame is None or estimate.ground_xy_m is None or estimate.coasting:
            continue
        row = person.at_frame(frame)
        if row is not None:
            squared.append(
                float(np.sum((np.asarray(estimate.ground_xy_m) - person.ground_m[row]) ** 2))
            )
    return round(math.sqrt(float(np.mean(squared))), 4) if squared else None


def first_pursued(facts: FrameFacts) -> int | None:
    """The id of the first annotated person the gaze pursues for SWITCH_FRAMES frames in a row
    (whom the rig's own rule chose), or None."""
    run_id, run = None, 0
    for current in facts.gaze_on:
        run = run + 1 if current is not None and current == run_id else 1
        run_id = current
        if run_id is not None and run >= SWITCH_FRAMES:
            return run_id
    return None


def pursuit_summary(frames: list[ViewFrame]) -> dict[str, Any]:
    """What a run shows without truth (module docstring)."""
    pursuing = np.array([f.pursuing for f in frames], bool)
    acquired = acquisition_index(np.where(pursuing, 0.0, 1.0), 0.5)  # pursuit: "in the fovea"
    if acquired is None:
        return {
            "frames": len(frames),
            "acquired_after_s": None,
            "pursuit_fraction": 0.0,
            "track_switches": None,
        }
    held: int | None = None
    switches = run = 0
    candidate: int | None = None
    for frame in frames[acquired:]:
        track = frame.target_id if frame.pursuing else None
        if track is None or track == held:
            candidate, run = None, 0
            continue
        run = run + 1 if track == candidate else 1
        candidate = track
        if run >= SWITCH_FRAMES:
            switches += held is not None
            held, candidate, run = track, None, 0
    return {
        "frames": len(frames),
        "acquired_after_s": round(
            (frames[acquired].t_capture_ns - frames[0].t_capture_ns) / 1e9, 3
        ),
        "pursuit_fraction": round(float(np.mean(pursuing[acquired:])), 4),
        "track_switches": switches,
    }
