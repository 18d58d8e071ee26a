"""Which of the estimator's tracks the gaze follows (DESIGN §11: the gaze owns the choice).

The rig's rule (`target_rule`) picks a confirmed track when there is no choice; an operator's
`gaze/select` picks one by id, by a ground point (the nearest track on the ground) or by a pixel
with the head pose it was seen at (the pixel's gaze angles through the camera model and the
head's kinematics, then the nearest track by angle). Either choice holds until its track ends —
it is absent from the estimator's state — and then the rule picks again. An empty `gaze/select`
hands the choice back to the rule at once.

The estimator keeps a track's id through short losses (it coasts), so a target lost and
reacquired keeps its id and the choice holds; the gaze uses only the predictions of its chosen
track (one with no `track_id` is the estimator's only track).
"""

from __future__ import annotations

from dataclasses import dataclass

from gazed.config import GazeSection
from gazed.gaze.target_rule import (
    GroundZone,
    nearest_by_angle,
    nearest_on_ground,
    rule_pick,
)
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.target_angles import target_angles
from gazed.geometry.zoom import ZoomLens
from gazed.messages import EstimatorState, GazeSelect, Prediction, Track

OPERATOR = "operator"  # how every gaze/state reason about an operator's request begins
REFUSED = "operator refused"  # ... and one that changed nothing


@dataclass(frozen=True)
class ChoiceChange:
    """The chosen track changed (or an operator's request was refused): why, for gaze/state."""

    target_id: int | None
    reason: str
    changed: bool = True


class TargetChoice:
    """Feed it every `EstimatorState` and `GazeSelect`; `target_id` is the chosen track."""

    def __init__(self, gaze: GazeSection, lens: ZoomLens, kinematics: HeadKinematics) -> None:
        self.rule = gaze.select_rule
        self.zone = GroundZone(gaze.select_zone_xy_m) if gaze.select_zone_xy_m else None
        self.lens = lens
        self.kinematics = kinematics
        self.target_id: int | None = None
        self.by_operator = False
        self.tracks: tuple[Track, ...] = ()
        self.counts = dict.fromkeys(("other_tracks", "refused_selections"), 0)

    def accepts(self, prediction: Prediction) -> bool:
        """A prediction of the chosen track (or of the only track, or before any choice);
        the others are counted."""
        ok = (
            self.target_id is None
            or prediction.track_id is None
            or prediction.track_id == self.target_id
        )
        if not ok:
            self.counts["other_tracks"] += 1
        return ok

    def on_state(
        self, state: EstimatorState, head_rad: tuple[float, float] | None
    ) -> ChoiceChange | None:
        """The estimator's tracks at a frame: the chosen one ended, or the rule picks one."""
        self.tracks = state.tracks
        ended = None
        if self.target_id is not None and not any(t.id == self.target_id for t in state.tracks):
            ended, self.target_id, self.by_operator = self.target_id, None, False
        if self.target_id is None:
            picked = rule_pick(self.rule, state.tracks, self.kinematics, head_rad, self.zone)
            if picked is not None:
                self.target_id = picked.id
                lost = f"track {ended} ended; " if ended is not None else ""
                return ChoiceChange(picked.id, f"{lost}rule {self.rule} chose track {picked.id}")
        if ended is not None:
            return ChoiceChange(None, f"track {ended} ended; rule {self.rule} has no track")
        return None

    def on_select(self, select: GazeSelect, head_rad: tuple[float, float] | None) -> ChoiceChange:
        """An operator's request: a track by id, or the nearest to a ground point or a pixel;
        an empty request hands the choice back to the rule."""
        if select.track_id is None and select.ground_xy_m is None and select.pixel_px is None:
            self.target_id, self.by_operator = None, False
            picked = rule_pick(self.rule, self.tracks, self.kinematics, head_rad, self.zone)
            self.target_id = picked.id if picked is not None else None
            return ChoiceChange(self.target_id, f"{OPERATOR}: back to rule {self.rule}")
        track, how = self._resolve(select)
        if track is None:
            self.counts["refused_selections"] += 1
            return ChoiceChange(self.target_id, f"{REFUSED}: {how}; target unchanged", False)
        changed = track.id != self.target_id
        self.target_id, self.by_operator = track.id, True
        return ChoiceChange(track.id, f"{OPERATOR} chose track {track.id} {how}", changed)

    def _resolve(self, select: GazeSelect) -> tuple[Track | None, str]:
        """The track a request names, and how it was found (or why none was)."""
        if select.track_id is not None:
            found = next((t for t in self.tracks if t.id == select.track_id), None)
            return found, "by id" if found else f"no track {select.track_id}"
        if select.ground_xy_m is not None:
            x, y = select.ground_xy_m
            found = nearest_on_ground(self.tracks, (x, y))
            return found, f"nearest ({x:g}, {y:g}) m" if found else "no track on the ground"
        assert select.pixel_px is not None and select.head is not None  # GazeSelect checks
        u, v = select.pixel_px
        head = select.head
        camera = self.lens.at_pose(head)
        angles = target_angles(camera, self.kinematics, head.pan_rad, head.tilt_rad, u, v)
        found = nearest_by_angle(self.tracks, angles.pan_rad, angles.tilt_rad, self.kinematics)
        return found, f"nearest pixel ({u:g}, {v:g})" if found else "no tracks"
