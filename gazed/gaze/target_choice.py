"""Which of the estimator's tracks the gaze follows (DESIGN §11: the gaze owns the choice).

The rig's rule (`target_rule`) picks a confirmed track when there is no choice; an operator's
`gaze/select` picks one by id, by a ground point (the nearest track on the ground) or by a pixel
with the head pose it was seen at (the pixel's gaze angles through the camera model and the
head's kinematics, then the nearest track by angle). Either choice holds until its track ends —
it is absent from the estimator's state — and then the rule picks again (an operator's choice
first waits for its person: below). An empty `gaze/select` hands the choice back to the rule at
once.

The estimator keeps a track's id through short losses (it coasts), so a target lost and
reacquired keeps its id and the choice holds; the gaze uses only the predictions of its chosen
track (one with no `track_id` is the estimator's only track).

Where the estimator could not keep the id (the person was missed long enough, or their
detections fell outside the track's gate), the person comes back as a new track while the
chosen one coasts, and ending the choice with the coasting track would hand it to the rule:
someone else. So a choice follows its person to their new track (track continuation, as in
track-segment association: Blackman & Popoli, "Design and Analysis of Modern Tracking Systems",
1999, §7.4): while the chosen track coasts, or once it has ended, a confirmed track that did not
exist when the chosen one last took a detection, and that takes detections now, continues it
where the two ground positions agree within `CONTINUATION_GATE_PROBABILITY`'s χ² gate of two
dimensions against the sum of their covariances. The chosen track's side is the wider of two:
the estimator's own (its coasting covariance, or once it has ended its last state walked on,
below), and the chosen track in the state of its last detection walked on (`walked_on`) over the
time since, so the gate widens as far as the person can have walked since they were last seen,
however little the estimator's covariance grows while it coasts. Someone else can walk there
too, so where both tracks carry an appearance (`Track.look`), the new track's template must also
lie within the chosen track's appearance gate, of the same probability (`look_gate`): it is not
the person where their clothes differ by more than the person's own movers do. A new track is
judged at every state until it continues the choice (its appearance anew each time, as its young
template learns its movers), and never again once it lies outside the ground's gate. Of several,
the one of least cost — the gate's distance plus the appearance's cost above its usual
(`look_gate`) — continues it. A chosen track that ends without having coasted was merged by the
estimator with another track of its person (a track ends by coasting otherwise), so any track
within both gates continues it, however old. Tracks without a ground position (image-cv) are not
continued.

An operator points at a person the moment they see them, often before the estimator has a
track of them (a person who has just walked in needs a few detections to be confirmed, and one
outside the head's view none until the view turns to them), and often beside others who have
tracks. A ground point is taken by the confirmed track that explains it best: the one under
whose position its person most likely was at the point when it was chosen. The track's ground
position is taken back along its velocity to the request's capture time, with the covariance
that gives it over the time (its position's, its velocity's over the time, and their
correlation: a young track's poor velocity spreads it far); a track whose message carries no
velocity covariance is taken back only to its birth. The person at the point is spread over
their width (the point and the track's position may each be anywhere across a shoulder,
`PERSON_WIDTH_M`), and, for the time from the request to the track's birth, over how far they
can have strayed from that velocity unseen: the covariance `walked_on` gives a lost person,
whose gate's edge lies at `WALK_MAX_M_S`. The track
fits where that position lies within `CONTINUATION_GATE_PROBABILITY`'s χ² gate of two dimensions
against the sum of this spread and the track's own covariance (all of it: a track's covariance
is long in range and narrow across, and a point across from it is not explained by its range);
of those that fit, the one of highest likelihood (the Gaussian density of that distance) takes
it, not the nearest in metres: a track born later, after its person could have walked further,
needs to lie nearer to be as likely. Tentative tracks are not people yet and take no point, but
one more likely than every confirmed track that fits is waited for: a person who has just
walked in is still tentative while those around them are confirmed, and a tentative track is
confirmed or dropped within the estimator's `confirm_frames`. A point no confirmed track can
take yet is held rather than refused, and taken by the first track that can. The same holds for
a continuation: a tentative new track of less cost than every confirmed one is waited for. While
it is held, the rule does not pick. It is held for as long as a person in view can go without a
confirmed track (`track_start_up_s`): the detector's start-up (`[vision]
background_learning_frames`), the estimator's confirmation (`confirm_frames`), and then as long
as the estimator keeps a person through missed detections (`coast_max_ms`). A point no track has
taken by then is refused, and the rule picks.

The first track that fits need not be the person's: while nobody at the point has a track yet
(they are outside the head's view, or the detector has not found them), the walk allowed them
grows, and someone else walking near the point can be born inside it first. Their own track
comes within the same start-up (`track_start_up_s` from the request), so for that long the point
stays open: a track confirmed since the choice that explains the point better (higher
likelihood, as above) than the chosen track did when it took it takes the choice over. The
chosen track is held to that first fit, when it was as young as the newcomer is: its fit later
takes its position back along a velocity over a longer life, and would fall behind any
newcomer's for that alone. Each track is judged once, when it is confirmed, so two tracks never
trade the choice back and forth; past the start-up no new track is the person's first.

An operator chose one person, and a track of someone else is not them: where the chosen track
ends and no track continues it, the choice is held for its person rather than handed to the
rule, which would pick another walker. The lost person is taken on along their last velocity,
their covariance grown so that the gate's edge lies as far as a person can stray from that in
the time since (`WALK_MAX_M_S` over it), so a new track born where they can have walked
continues the choice (the gates above). A new track outside the ground's gate is not them
however far the region grows later, and none held before (those the estimator already kept for
someone else) is. Meanwhile the gaze takes no other track's predictions: it coasts and
searches where the person was going. The hold lasts until
the gaze would give a lost target up and go back to search (`lost_after_ms` then
`search_after_ms`, from the chosen track's last detection; the estimator ends a track only after
coasting `coast_max_ms` of that); past that the rule picks. A held id that the estimator shows
again is followed again. The rule's own choice is its rule's: a track of it that ends is
replaced at once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from gazed.config import Rig
from gazed.estimation.chi_square import chi2_quantile
from gazed.gaze.look_gate import look_cost
from gazed.gaze.target_rule import (
    GroundZone,
    nearest_by_angle,
    rule_pick,
)
from gazed.gaze.walk_gate import ground_distance2, most_likely, point_fit, walked_on
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.target_angles import target_angles
from gazed.geometry.zoom import ZoomLens
from gazed.messages import EstimatorState, GazeSelect, Prediction, Track

OPERATOR = "operator"  # how every gaze/state reason about an operator's request begins
REFUSED = "operator refused"  # ... and one that changed nothing
CONTINUATION_GATE_PROBABILITY = 0.999  # the estimator's own default gate for a detection


@dataclass(frozen=True)
class ChoiceChange:
    """The chosen track changed (or an operator's request was refused): why, for gaze/state."""

    target_id: int | None
    reason: str
    changed: bool = True


class TargetChoice:
    """Feed it every `EstimatorState` and `GazeSelect`; `target_id` is the chosen track."""

    def __init__(self, rig: Rig, lens: ZoomLens, kinematics: HeadKinematics) -> None:
        gaze = rig.gaze
        self.rule = gaze.select_rule
        self.zone = GroundZone(gaze.select_zone_xy_m) if gaze.select_zone_xy_m else None
        self.lens = lens
        self.kinematics = kinematics
        self.target_id: int | None = None
        self.by_operator = False
        self.tracks: tuple[Track, ...] = ()
        self.counts = dict.fromkeys(
            ("other_tracks", "refused_selections", "continued", "held_for_person"), 0
        ) | {"revised_selections": 0}
        self.continuation_d2 = chi2_quantile(CONTINUATION_GATE_PROBABILITY, 2)
        self._chosen: Track | None = None  # the chosen track in the last state that held it
        self._chosen_ns = 0  # that state's capture time
        self._seen: Track | None = None  # the chosen track in the state of its last detection
        self._seen_ns = 0  # that state's capture time
        self._known: frozenset[int] = frozenset()  # the ids when it last took a detection
        self.pending: GazeSelect | None = None  # an operator's point no track was near yet
        self.pending_max_ns = round(track_start_up_s(rig) * 1e9)
        self.hold_max_ns = round((gaze.lost_after_ms + gaze.search_after_ms) * 1e6)
        self.holding = False  # an operator's chosen track ended: held for its person
        self._t_state_ns = 0  # the capture time of the last estimator state
        self._point: GazeSelect | None = None  # the operator's point taken, open to revision
        self._point_fit = 0.0  # how well the chosen track explained it when it took it
        self._confirmed: frozenset[int] = frozenset()  # the confirmed ids in the last state

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
        self._t_state_ns = state.t_capture_ns
        revised = self._revised(state.tracks, state.t_capture_ns)
        if self.pending is not None:
            return self._take_pending(state, head_rad)
        if revised is not None:
            return revised
        continued = self._continuation(state.tracks, state.t_capture_ns)
        if continued is not None:
            return continued
        ended = None
        if self.target_id is not None and not any(t.id == self.target_id for t in state.tracks):
            if self.by_operator and state.t_capture_ns - self._seen_ns <= self.hold_max_ns:
                return self._hold_for_person()
            ended, self.target_id, self.by_operator = self.target_id, None, False
            self.holding = False
        if self.target_id is None:
            picked = rule_pick(self.rule, state.tracks, self.kinematics, head_rad, self.zone)
            if picked is not None:
                self.target_id = picked.id
                lost = f"track {ended} ended; " if ended is not None else ""
                return ChoiceChange(picked.id, f"{lost}rule {self.rule} chose track {picked.id}")
        if ended is not None:
            return ChoiceChange(None, f"track {ended} ended; rule {self.rule} has no track")
        return None

    def _hold_for_person(self) -> ChoiceChange | None:
        """The operator's chosen track has ended with no track to continue it: the choice holds
        for its person (module docstring); said once, when the hold begins."""
        if self.holding:
            return None
        self.holding = True
        self.counts["held_for_person"] += 1
        return ChoiceChange(
            self.target_id,
            f"track {self.target_id} ended; held for its person where they were going",
            False,
        )

    def _continuation(self, tracks: tuple[Track, ...], t_ns: int) -> ChoiceChange | None:
        """The chosen track handed to the new track of its person (module docstring), or
        None."""
        chosen = next((t for t in tracks if t.id == self.target_id), None)
        if chosen is not None:
            newly = self._chosen is None or self._chosen.id != chosen.id
            if newly or not chosen.coasting:
                self._known = frozenset(t.id for t in tracks)
                self._seen, self._seen_ns = chosen, t_ns
            self._chosen, self._chosen_ns = chosen, t_ns
            self.holding = False
            if not chosen.coasting:
                return None
        lost = self._chosen
        if self.target_id is None or lost is None or lost.id != self.target_id:
            return None
        # ended at once, in the first state without it: merged (module docstring)
        merged = chosen is None and not lost.coasting and not self.holding
        if chosen is None:
            lost = walked_on(lost, (t_ns - self._chosen_ns) * 1e-9, self.continuation_d2)
        seen = self._seen if self._seen is not None and self._seen.id == lost.id else lost
        walked = walked_on(seen, (t_ns - self._seen_ns) * 1e-9, self.continuation_d2)
        best, best_cost, born_elsewhere = None, math.inf, set()
        for track in tracks:
            if (track.id in self._known and not merged) or track.coasting:
                continue
            d2 = _nearer(ground_distance2(lost, track), ground_distance2(walked, track))
            if d2 is None or d2 > self.continuation_d2:
                born_elsewhere.add(track.id)  # not where the person can have walked: never
                continue
            cost = d2 + look_cost(seen.look, track.look, CONTINUATION_GATE_PROBABILITY)
            if cost < best_cost:  # infinite: someone else to look at (judged again later)
                best, best_cost = track, cost
        self._known |= born_elsewhere
        if best is None or not best.confirmed:  # none, or wait for the tentative (docstring)
            return None
        self._bind(best, tracks, t_ns)
        self.counts["continued"] += 1
        return ChoiceChange(best.id, f"track {lost.id} lost; its person continues as {best.id}")

    def _take_pending(
        self, state: EstimatorState, head_rad: tuple[float, float] | None
    ) -> ChoiceChange | None:
        """The held ground point taken by the track whose person was there (module docstring),
        None while none can have been, or refused once none has in `pending_max_ns`."""
        assert self.pending is not None and self.pending.ground_xy_m is not None
        x, y = self.pending.ground_xy_m
        best = self._reaching(self.pending, state.tracks, state.t_capture_ns)
        if best is None:
            waited_ns = state.t_capture_ns - self.pending.t_capture_ns
            if waited_ns <= self.pending_max_ns:
                return None
            self.pending, self.by_operator, self.holding = None, False, False
            self.counts["refused_selections"] += 1
            before = self.target_id
            picked = rule_pick(self.rule, state.tracks, self.kinematics, head_rad, self.zone)
            self.target_id = picked.id if picked is not None else None
            return ChoiceChange(
                self.target_id,
                f"{REFUSED}: no track at ({x:g}, {y:g}) m in {waited_ns * 1e-9:.1f} s; "
                f"back to rule {self.rule}",
                self.target_id != before,
            )
        self._point = self.pending
        self._point_fit = (
            point_fit(self.pending, best, state.t_capture_ns, self.continuation_d2) or 0.0
        )
        self.pending, self.by_operator = None, True
        self._bind(best, state.tracks, state.t_capture_ns)
        return ChoiceChange(best.id, f"{OPERATOR} chose track {best.id} at ({x:g}, {y:g}) m")

    def _reaching(self, select: GazeSelect, tracks: tuple[Track, ...], t_ns: int) -> Track | None:
        """The track at `t_ns` that best explains the request's ground point, if it is confirmed
        (module docstring); None if none fits, or if the best is tentative."""
        best, _ = most_likely(select, tracks, t_ns, self.continuation_d2)
        return best if best is not None and best.confirmed else None

    def _revised(self, tracks: tuple[Track, ...], t_ns: int) -> ChoiceChange | None:
        """A track confirmed since the last state that explains the operator's point better
        than the chosen track, within the start-up from the request (module docstring)."""
        point, confirmed = self._point, self._confirmed
        self._confirmed = frozenset(t.id for t in tracks if t.confirmed)
        if point is None or not self.by_operator:
            return None
        if t_ns - point.t_capture_ns > self.pending_max_ns:
            self._point = None
            return None
        newcomers = [
            t for t in tracks if t.confirmed and t.id not in confirmed and t.id != self.target_id
        ]
        best, best_fit = most_likely(point, newcomers, t_ns, self.continuation_d2, self._point_fit)
        if best is None:
            return None
        self._point_fit = best_fit
        before = self.target_id
        self._bind(best, tracks, t_ns)
        self.counts["revised_selections"] += 1
        assert point.ground_xy_m is not None
        x, y = point.ground_xy_m
        return ChoiceChange(
            best.id, f"{OPERATOR}: track {best.id} explains ({x:g}, {y:g}) m better than {before}"
        )

    def on_select(self, select: GazeSelect, head_rad: tuple[float, float] | None) -> ChoiceChange:
        """An operator's request: a track by id, or the nearest to a ground point or a pixel;
        an empty request hands the choice back to the rule. A ground point with no track on the
        ground yet is held (module docstring)."""
        self.pending, self._point = None, None
        if select.ground_xy_m is not None and (
            self._reaching(select, self.tracks, self._t_state_ns) is None
        ):
            self.pending = select
            x, y = select.ground_xy_m
            return ChoiceChange(
                self.target_id, f"{OPERATOR}: no track yet; held for one at ({x:g}, {y:g}) m", False
            )
        if select.track_id is None and select.ground_xy_m is None and select.pixel_px is None:
            self.target_id, self.by_operator, self.holding = None, False, False
            picked = rule_pick(self.rule, self.tracks, self.kinematics, head_rad, self.zone)
            self.target_id = picked.id if picked is not None else None
            return ChoiceChange(self.target_id, f"{OPERATOR}: back to rule {self.rule}")
        track, how = self._resolve(select)
        if track is None:
            self.counts["refused_selections"] += 1
            return ChoiceChange(self.target_id, f"{REFUSED}: {how}; target unchanged", False)
        changed = track.id != self.target_id
        self.by_operator = True
        self._point = select if select.ground_xy_m is not None else None
        if self._point is not None:
            self._point_fit = (
                point_fit(select, track, self._t_state_ns, self.continuation_d2) or 0.0
            )
        self._bind(track, self.tracks, self._t_state_ns)
        return ChoiceChange(track.id, f"{OPERATOR} chose track {track.id} {how}", changed)

    def _bind(self, track: Track, tracks: tuple[Track, ...], t_ns: int) -> None:
        """Follow `track`, seen at `t_ns` among `tracks` (the ids a continuation is not)."""
        self.target_id, self.holding = track.id, False
        self._chosen = self._seen = track
        self._chosen_ns = self._seen_ns = t_ns
        self._known = frozenset(t.id for t in tracks)

    def _resolve(self, select: GazeSelect) -> tuple[Track | None, str]:
        """The track a request names, and how it was found (or why none was)."""
        if select.track_id is not None:
            found = next((t for t in self.tracks if t.id == select.track_id), None)
            return found, "by id" if found else f"no track {select.track_id}"
        if select.ground_xy_m is not None:  # one can take it (`on_select`)
            x, y = select.ground_xy_m
            found = self._reaching(select, self.tracks, self._t_state_ns)
            return found, f"nearest ({x:g}, {y:g}) m"
        assert select.pixel_px is not None and select.head is not None  # GazeSelect checks
        u, v = select.pixel_px
        head = select.head
        camera = self.lens.at_pose(head)
        angles = target_angles(camera, self.kinematics, head.pan_rad, head.tilt_rad, u, v)
        found = nearest_by_angle(self.tracks, angles.pan_rad, angles.tilt_rad, self.kinematics)
        return found, f"nearest pixel ({u:g}, {v:g})" if found else "no tracks"


def _nearer(a: float | None, b: float | None) -> float | None:
    """The smaller of two gate distances, either of which may be missing."""
    return min((d for d in (a, b) if d is not None), default=None)


def track_start_up_s(rig: Rig) -> float:
    """How long a person in view can go without a confirmed track (module docstring)."""
    frames = rig.vision.background_learning_frames + rig.estimator.confirm_frames
    digital = rig.camera.source == "digital"  # its views come one per wide frame
    period_s = 1.0 / rig.wide.rate_hz if digital else rig.camera.frame_period_s
    return frames * period_s + rig.estimator.coast_max_ms / 1000.0
