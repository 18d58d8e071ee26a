"""Which track the gaze follows: the rig's rules (in a ground zone), an operator's choice by id,
ground point or pixel, a choice that holds until its track ends, and the gaze/state messages and
prediction filtering that follow from it in the controller."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_gaze_controller import RIG, Clock, detection, odometry, prediction

from gazed.config import GazeSection
from gazed.estimation.association import hellinger_squared
from gazed.gaze.controller import GazeController
from gazed.gaze.focus import focus
from gazed.gaze.target_choice import TargetChoice, track_start_up_s
from gazed.gaze.target_rule import GroundZone, rule_pick
from gazed.gaze.walk_gate import WALK_MAX_M_S, walked_on
from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.target_angles import target_angles
from gazed.geometry.zoom import ZoomLens
from gazed.messages import (
    EstimatorState,
    GazeSelect,
    HeadPose,
    Mover,
    Prediction,
    Track,
    TrackLook,
)

CAMERA = CameraModel.from_section(RIG.camera)
LENS = ZoomLens.fixed(CAMERA)
KINEMATICS = HeadKinematics.from_section(RIG.head)


def track(
    id: int,
    pan_deg: float,
    xy: tuple[float, float],
    *,
    confirmed: bool = True,
    box: float = 50.0,
    hits: int = 10,
) -> Track:
    return Track(
        id=id,
        confirmed=confirmed,
        pan_rad=math.radians(pan_deg),
        tilt_rad=math.radians(-10.0),
        ground_xy_m=xy,
        age_s=1.0,
        hits=hits,
        box_height_px=box,
    )


# id 1 appeared first; 2 is on the optical axis at pan 20°; 3 is the tallest; 4 the most seen
TRACKS = (
    track(3, -30.0, (-3.0, 5.0), box=120.0),
    track(1, 40.0, (4.0, 5.0)),
    track(2, 21.0, (2.0, 5.0)),
    track(4, -5.0, (-0.5, 5.0), hits=50),
    track(0, 19.0, (1.9, 5.0), confirmed=False, box=500.0, hits=99),  # clutter, so far
)


def state(*tracks: Track) -> EstimatorState:
    return EstimatorState(t_capture_ns=1, filter="imm", x=(), P=(), tracks=tracks)


def choice(**gaze: object) -> TargetChoice:
    return TargetChoice(RIG.model_copy(update={"gaze": GazeSection(**gaze)}), LENS, KINEMATICS)


@pytest.mark.parametrize(
    ("rule", "expected"), [("first", 1), ("nearest-centre", 2), ("largest", 3), ("longest-seen", 4)]
)
def test_each_rule_picks_among_the_confirmed_tracks(rule: str, expected: int) -> None:
    head_rad = (math.radians(20.0), math.radians(-10.0))
    picked = rule_pick(rule, TRACKS, KINEMATICS, head_rad)  # type: ignore[arg-type]
    assert picked is not None and picked.id == expected


def test_a_zone_limits_the_rule() -> None:
    zone = GroundZone([[-4.0, 4.0], [0.0, 4.0], [0.0, 6.0], [-4.0, 6.0]])  # x < 0 only
    assert [t.id for t in TRACKS if zone.holds(t)] == [3, 4]
    assert rule_pick("first", TRACKS, KINEMATICS, None, zone).id == 3  # type: ignore[union-attr]
    assert rule_pick("first", TRACKS[1:3], KINEMATICS, None, zone) is None


def test_the_rules_choice_holds_until_its_track_ends() -> None:
    c = choice(select_rule="first")
    change = c.on_state(state(*TRACKS), None)
    assert (
        change is not None and change.target_id == 1 and "rule first chose track 1" in change.reason
    )
    assert c.on_state(state(track(0, 0.0, (0.0, 1.0)), *TRACKS), None) is None  # 0 now: held
    change = c.on_state(state(*TRACKS[2:]), None)  # 1 ended
    assert change is not None and change.target_id == 2
    assert change.reason == "track 1 ended; rule first chose track 2"
    change = c.on_state(state(), None)
    assert change is not None and change.target_id is None and "has no track" in change.reason


def test_an_operator_chooses_by_id_ground_point_and_pixel() -> None:
    c = choice(select_rule="first")
    c.on_state(state(*TRACKS), None)
    change = c.on_select(GazeSelect(t_capture_ns=1, track_id=3), None)
    assert (change.target_id, change.changed) == (3, True)
    assert change.reason == "operator chose track 3 by id"
    change = c.on_select(GazeSelect(t_capture_ns=1, ground_xy_m=(-0.2, 4.8)), None)
    assert change.target_id == 4 and "nearest (-0.2, 4.8) m" in change.reason
    # the pixel where track 2 appears from a head at pan 10°, tilt -5°
    head = HeadPose(pan_rad=math.radians(10.0), tilt_rad=math.radians(-5.0))
    direction = KINEMATICS.gaze(TRACKS[2].pan_rad, TRACKS[2].tilt_rad)
    ray = KINEMATICS.camera_to_base(head.pan_rad, head.tilt_rad).T @ direction
    u, v = CAMERA.pixel(ray)
    assert abs(u - CAMERA.K[0, 2]) > 50  # off centre: the pose is what makes it track 2
    change = c.on_select(GazeSelect(t_capture_ns=1, pixel_px=(u, v), head=head), None)
    assert change.target_id == 2 and change.reason.startswith(
        "operator chose track 2 nearest pixel"
    )
    assert c.on_state(state(*TRACKS), None) is None  # the rule does not take it back


def test_an_unknown_id_is_refused_and_an_empty_choice_goes_back_to_the_rule() -> None:
    c = choice(select_rule="largest")
    c.on_state(state(*TRACKS), None)
    c.on_select(GazeSelect(t_capture_ns=1, track_id=4), None)
    refused = c.on_select(GazeSelect(t_capture_ns=1, track_id=77), None)
    assert (refused.target_id, refused.changed) == (4, False)
    assert refused.reason == "operator refused: no track 77; target unchanged"
    assert c.counts["refused_selections"] == 1
    back = c.on_select(GazeSelect(t_capture_ns=1), None)
    assert back.target_id == 3 and back.reason == "operator: back to rule largest"


def at(t_s: float, *tracks: Track) -> EstimatorState:
    return EstimatorState(t_capture_ns=round(t_s * 1e9), filter="imm", x=(), P=(), tracks=tracks)


def test_an_operators_choice_is_held_for_its_person_then_ends() -> None:
    c = choice(select_rule="first", lost_after_ms=600.0, search_after_ms=3000.0)
    c.on_state(at(1.0, *TRACKS), None)
    c.on_select(GazeSelect(t_capture_ns=1, track_id=4), None)
    change = c.on_state(at(1.2, *TRACKS[:3]), None)  # 4 ended; nobody continues it
    assert change is not None and change.target_id == 4 and not change.changed
    assert change.reason == "track 4 ended; held for its person where they were going"
    assert c.on_state(at(4.5, *TRACKS[:3]), None) is None  # still searched for: said once
    assert c.target_id == 4 and c.by_operator and c.counts["held_for_person"] == 1
    # held until the gaze would go back to search: `lost_after_ms` + `search_after_ms` after
    # 4's last detection
    change = c.on_state(at(4.7, *TRACKS[:3]), None)
    assert change is not None and change.target_id == 1 and not c.by_operator
    assert change.reason == "track 4 ended; rule first chose track 1"


def placed(id: int, xy: tuple[float, float], var_m2: float, *, coasting: bool = False) -> Track:
    """A confirmed track at ground point `xy` with covariance `var_m2` on each axis."""
    return track(id, 0.0, xy).model_copy(
        update={"ground_cov_m2": ((var_m2, 0.0), (0.0, var_m2)), "coasting": coasting}
    )


def test_a_choice_follows_its_person_to_their_new_track() -> None:
    c = choice(select_rule="first")
    c.on_state(state(placed(1, (0.0, 5.0), 0.01), placed(2, (1.0, 5.0), 0.01)), None)
    c.on_select(GazeSelect(t_capture_ns=1, track_id=2), None)
    # 2 is lost and coasts; 1, which existed all along, is beside it: not its person
    assert (
        c.on_state(
            state(placed(1, (1.2, 5.0), 0.01), placed(2, (1.3, 5.0), 0.2, coasting=True)), None
        )
        is None
    )
    assert c.target_id == 2
    # a new track where 2's person could be by now continues it, an operator's choice still
    change = c.on_state(
        state(
            placed(1, (1.2, 5.0), 0.01),
            placed(2, (1.4, 5.0), 0.3, coasting=True),
            placed(7, (2.0, 5.2), 0.05),
            placed(8, (6.0, 5.0), 0.05),  # new too, but too far for 2's person to have walked
        ),
        None,
    )
    assert change is not None and change.target_id == 7 and c.by_operator
    assert change.reason == "track 2 lost; its person continues as 7"
    assert c.counts["continued"] == 1


def test_a_chosen_track_merged_into_an_older_one_continues_as_it() -> None:
    c = choice(select_rule="first")
    c.on_state(state(placed(1, (0.0, 5.0), 0.05), placed(2, (0.3, 5.0), 0.05)), None)
    c.on_select(GazeSelect(t_capture_ns=1, track_id=2), None)
    change = c.on_state(state(placed(1, (0.2, 5.0), 0.05), placed(3, (5.0, 5.0), 0.01)), None)
    assert change is not None and change.target_id == 1 and c.by_operator
    assert change.reason == "track 2 lost; its person continues as 1"


def test_a_new_track_far_from_the_lost_one_does_not_continue_it() -> None:
    c = choice(select_rule="first")
    c.on_state(state(placed(1, (0.0, 5.0), 0.01), placed(2, (4.0, 5.0), 0.01)), None)
    c.on_state(state(placed(1, (0.0, 5.0), 0.01, coasting=True), placed(2, (4.0, 5.0), 0.01)), None)
    assert (
        c.on_state(
            state(
                placed(1, (0.1, 5.0), 0.05, coasting=True),
                placed(2, (4.0, 5.0), 0.01),
                placed(3, (3.0, 5.0), 0.02),
            ),
            None,
        )
        is None
    )
    change = c.on_state(state(placed(2, (4.0, 5.0), 0.01), placed(3, (3.0, 5.0), 0.02)), None)
    assert change is not None and change.reason == "track 1 ended; rule first chose track 2"


def test_a_ground_point_before_any_track_is_held_for_the_track_of_its_person() -> None:
    c = choice(select_rule="first")
    held = c.on_select(GazeSelect(t_capture_ns=1_000_000_000, ground_xy_m=(0.0, 5.0)), None)
    assert not held.changed and held.reason == "operator: no track yet; held for one at (0, 5) m"
    assert c.counts["refused_selections"] == 0

    walker = placed(5, (1.5, 5.0), 0.01).model_copy(update={"ground_velocity_m_s": (1.0, 0.0)})
    other = placed(4, (-4.0, 5.0), 0.01)  # confirmed first, but too far to have been there
    assert c.on_state(at(1.5, other, walker.model_copy(update={"confirmed": False})), None) is None
    assert c.target_id is None  # the rule waits while the operator's point is held
    # 1.5 s after the request: 5 walked 1.5 m at 1 m/s from the point
    change = c.on_state(at(2.5, other, walker), None)
    assert change is not None and change.target_id == 5 and c.by_operator
    assert change.reason == "operator chose track 5 at (0, 5) m"
    assert c.pending is None


def test_only_the_chosen_tracks_predictions_reach_pursuit() -> None:
    clock = Clock()
    controller = GazeController(RIG, clock.mono_s)
    mine = prediction(clock, 5.0, 0.0).model_copy(update={"track_id": 1})
    controller.on_prediction(mine)  # before any choice: taken
    assert controller.pursuit.prediction is mine
    controller.on_estimator_state(state(*TRACKS), clock.wall_ns)
    decision = controller.tick(clock.wall_ns, clock.mono_s)
    (announced,) = [s for s in decision.transitions if s.state == s.previous]
    assert announced.target_id == 1 and announced.reason == "rule first chose track 1"
    assert controller.pursuit.prediction is mine  # it was the chosen track's already
    other = prediction(clock, -5.0, 0.0).model_copy(update={"track_id": 2})
    controller.on_prediction(other)
    assert controller.pursuit.prediction is mine and controller.counts["other_tracks"] == 1
    controller.on_select(GazeSelect(t_capture_ns=1, track_id=2), clock.wall_ns)
    assert controller.pursuit.prediction is None  # another target: the old predictions go
    controller.on_prediction(other)
    assert controller.pursuit.prediction is other
    clock.advance(0.1)
    controller.on_odometry(odometry(clock, 0.0, 0.0))  # at the park pose: on to search
    chosen, parked = controller.tick(clock.wall_ns, clock.mono_s).transitions
    assert chosen.reason == "operator chose track 2 by id" and chosen.target_id == 2
    assert (parked.previous, parked.state, parked.target_id) == ("park", "search", 2)


def test_the_gaze_sees_the_chosen_tracks_mover() -> None:
    clock = Clock()
    near, far = Mover(u_px=320.0, v_px=240.0), Mover(u_px=100.0, v_px=240.0, du_px_s=-40.0)
    seen = detection(clock, 320.0, 240.0).model_copy(update={"movers": (near, far)})
    assert focus(seen, None, LENS, KINEMATICS) is seen  # no prediction: vision's target
    # the chosen track is predicted where `far` is: the pixel's angles from the head at (0, 0)
    angles = target_angles(CAMERA, KINEMATICS, 0.0, 0.0, far.u_px, far.v_px)
    chosen = prediction(clock, math.degrees(angles.pan_rad), math.degrees(angles.tilt_rad))
    focused = focus(seen, chosen, LENS, KINEMATICS)
    assert (focused.u_px, focused.v_px, focused.du_px_s) == (100.0, 240.0, -40.0)
    on_near = prediction(clock, 0.0, 0.0)
    assert focus(seen, on_near, LENS, KINEMATICS) is seen
    unseen = seen.model_copy(update={"found": False})
    assert focus(unseen, chosen, LENS, KINEMATICS) is unseen  # vision saw no target


def test_a_ground_point_is_not_taken_by_clutter_or_someone_far_from_it() -> None:
    c = choice(select_rule="first")
    far = placed(4, (-6.0, 5.0), 0.01)  # a person elsewhere
    newcomer = placed(7, (0.3, 5.0), 0.01).model_copy(update={"confirmed": False})
    c.on_state(state(far, newcomer), None)
    held = c.on_select(GazeSelect(t_capture_ns=1, ground_xy_m=(0.0, 5.0)), None)
    assert not held.changed and c.pending is not None and c.target_id == 4  # the rule's, so far
    confirmed = newcomer.model_copy(update={"confirmed": True})
    change = c.on_state(state(far, confirmed), None)
    assert change is not None and change.target_id == 7 and c.by_operator


def walker(id: int, xy: tuple[float, float], velocity: tuple[float, float]) -> Track:
    return placed(id, xy, 0.04).model_copy(update={"ground_velocity_m_s": velocity})


def test_a_held_choice_is_continued_only_where_its_person_can_have_walked() -> None:
    c = choice(select_rule="first")
    chosen = walker(2, (0.0, 5.0), (1.0, 0.0))
    beside = walker(1, (-1.0, 5.0), (0.0, 0.0))  # tracked all along: someone else
    c.on_state(at(1.0, beside, chosen), None)
    c.on_select(GazeSelect(t_capture_ns=1, track_id=2), None)
    c.on_state(at(1.1, beside, chosen.model_copy(update={"coasting": True})), None)
    change = c.on_state(at(1.2, beside), None)  # 2 ended, its person at about (0.1, 5)
    assert change is not None and change.target_id == 2 and c.holding
    # other tracks' predictions do not reach the pursuit while the choice is held
    assert not c.accepts(Prediction_for(1))
    # a new track behind where 2's person was going, and one too far on: neither is them
    behind, far = walker(5, (-1.6, 5.0), (1.0, 0.0)), walker(6, (4.5, 5.0), (1.0, 0.0))
    assert c.on_state(at(1.5, beside, behind, far), None) is None and c.target_id == 2
    # half a second on, a new track where 2's person has walked to (0.6, 5) continues it
    change = c.on_state(at(1.7, beside, behind, far, walker(7, (0.9, 5.1), (1.0, 0.0))), None)
    assert change is not None and change.target_id == 7 and c.by_operator and not c.holding
    assert change.reason == "track 2 lost; its person continues as 7"


PERSON_LOOK = np.random.default_rng(3).dirichlet(np.full(64, 0.5))


def look(away: float) -> TrackLook:
    """An appearance whose template is the share `away` of the way from a person's to another
    histogram; its movers lie at h² 0.05 of it (about the median of the PETS footage's people's
    own distances; a person near them lies at a median 0.26: docs/performance.md)."""
    elsewhere = np.random.default_rng(4).dirichlet(np.full(64, 0.5))
    template = (1.0 - away) * PERSON_LOOK + away * elsewhere
    return TrackLook(template=tuple(template.tolist()), h2_mean=0.05, h2_shape=4.0)


def looking(track: Track, away: float) -> Track:
    return track.model_copy(update={"look": look(away)})


def test_the_looks_lie_as_the_footages_people_do() -> None:
    h2 = hellinger_squared(
        np.array([look(0.0).template]), np.array([look(a).template for a in (0.25, 0.9)])
    )
    assert h2[0] == pytest.approx([0.03, 0.24], abs=0.01)


def test_a_continuation_is_not_someone_who_looks_different() -> None:
    c = choice(select_rule="first")
    chosen = looking(walker(2, (0.0, 5.0), (1.0, 0.0)), 0.0)
    c.on_state(at(1.0, chosen), None)
    c.on_select(GazeSelect(t_capture_ns=1, track_id=2), None)
    change = c.on_state(at(1.2), None)
    assert change is not None and change.target_id == 2 and c.holding
    # someone else is born where 2's person can have walked: not them, by their clothes
    other = looking(walker(5, (0.3, 5.0), (1.0, 0.0)), 0.9)
    assert c.on_state(at(1.4, other), None) is None and c.target_id == 2 and c.holding
    # 2's person comes back beside them, further from where they were going, and continues it
    back = looking(walker(7, (0.9, 5.6), (1.0, 0.0)), 0.25)
    change = c.on_state(at(1.6, other, back), None)
    assert change is not None and change.target_id == 7 and c.by_operator
    assert change.reason == "track 2 lost; its person continues as 7"


def test_of_two_new_tracks_the_one_that_looks_more_like_the_person_continues_it() -> None:
    c = choice(select_rule="first")
    c.on_state(at(1.0, looking(walker(2, (0.0, 5.0), (1.0, 0.0)), 0.0)), None)
    c.on_select(GazeSelect(t_capture_ns=1, track_id=2), None)
    c.on_state(at(1.2), None)  # ended: held for its person, at about (0.2, 5) by now
    # both within the gates: 5 nearer where the person was going, 7 dressed as they are
    nearer = looking(walker(5, (0.4, 5.1), (1.0, 0.0)), 0.6)
    alike = looking(walker(7, (0.6, 5.3), (1.0, 0.0)), 0.25)
    change = c.on_state(at(1.4, nearer, alike), None)
    assert change is not None and change.target_id == 7


def test_a_new_track_that_looked_like_someone_else_is_judged_again() -> None:
    c = choice(select_rule="first")
    c.on_state(at(1.0, looking(walker(2, (0.0, 5.0), (1.0, 0.0)), 0.0)), None)
    c.on_select(GazeSelect(t_capture_ns=1, track_id=2), None)
    c.on_state(at(1.2), None)
    # its first movers were of a blob with someone else; then its template learns the person
    young = walker(5, (0.3, 5.0), (1.0, 0.0))
    assert c.on_state(at(1.4, looking(young, 0.9)), None) is None and c.holding
    learnt = looking(young.model_copy(update={"ground_xy_m": (0.5, 5.0)}), 0.25)
    change = c.on_state(at(1.6, learnt), None)
    assert change is not None and change.target_id == 5 and not c.holding


def test_a_merge_into_someone_who_looks_different_is_not_a_continuation() -> None:
    c = choice(select_rule="first")
    beside = looking(walker(1, (0.3, 5.0), (0.0, 0.0)), 0.9)
    c.on_state(at(1.0, beside, looking(walker(2, (0.0, 5.0), (0.0, 0.0)), 0.0)), None)
    c.on_select(GazeSelect(t_capture_ns=1, track_id=2), None)
    change = c.on_state(at(1.1, beside), None)  # ended at once beside 1, who is not them
    assert change is not None and change.target_id == 2 and c.holding


def test_a_grown_gate_takes_no_track_held_before_the_loss() -> None:
    c = choice(select_rule="first")
    beside = walker(1, (2.0, 5.0), (0.0, 0.0))
    c.on_state(at(1.0, beside, walker(2, (0.0, 5.0), (0.0, 0.0))), None)
    c.on_select(GazeSelect(t_capture_ns=1, track_id=2), None)
    c.on_state(at(1.1, beside), None)  # ended at once: merged, but 1 is too far to be it
    assert c.holding and c.target_id == 2
    # later the lost person's region covers 1: still not theirs (not a merge any more)
    assert c.on_state(at(3.0, beside.model_copy(update={"ground_xy_m": (0.3, 5.0)})), None) is None
    assert c.target_id == 2


def test_walked_on_moves_along_the_velocity_and_grows_the_covariance() -> None:
    before = walker(2, (0.0, 5.0), (1.0, -0.5))
    gate_d2 = choice().continuation_d2
    after = walked_on(before, 2.0, gate_d2)
    assert after.ground_xy_m == pytest.approx((2.0, 4.0))
    # the gate's edge lies as far as a person walks in the time, beyond the track's own spread
    stray_m2 = np.diag(np.asarray(after.ground_cov_m2)) - 0.04
    assert np.sqrt(stray_m2 * gate_d2) == pytest.approx([WALK_MAX_M_S * 2.0] * 2)
    assert walked_on(before, 0.0, gate_d2) is before


def test_a_track_born_where_the_person_cannot_have_walked_never_continues_the_choice() -> None:
    c = choice(select_rule="first")
    chosen = walker(2, (0.0, 5.0), (1.0, 0.0))
    beside = walker(1, (-1.0, 5.0), (0.0, 0.0))
    c.on_state(at(1.0, beside, chosen), None)
    c.on_select(GazeSelect(t_capture_ns=1, track_id=2), None)
    c.on_state(at(1.1, beside, chosen.model_copy(update={"coasting": True})), None)
    c.on_state(at(1.2, beside), None)
    assert c.holding
    behind = walker(5, (-1.6, 5.0), (0.0, 0.0))  # born 2 m behind the walking person
    assert c.on_state(at(1.5, beside, behind), None) is None
    # a second on, the person's grown region covers it: still not them (born elsewhere)
    assert c.on_state(at(2.5, beside, behind), None) is None
    assert c.target_id == 2 and c.holding


def test_a_held_id_seen_again_is_followed_and_no_longer_held() -> None:
    c = choice(select_rule="first")
    chosen = walker(2, (0.0, 5.0), (1.0, 0.0))
    c.on_state(at(1.0, chosen), None)
    c.on_select(GazeSelect(t_capture_ns=1, track_id=2), None)
    c.on_state(at(1.2), None)
    assert c.holding
    assert c.on_state(at(1.4, chosen), None) is None and c.target_id == 2 and not c.holding


def test_a_held_point_outlasts_the_start_up_and_is_then_refused() -> None:
    rig = RIG.model_copy(update={"gaze": GazeSection(select_rule="first")})
    start_up_s = track_start_up_s(rig)
    frames = rig.vision.background_learning_frames + rig.estimator.confirm_frames
    assert (
        start_up_s > frames * rig.camera.frame_period_s + 0.999 * rig.estimator.coast_max_ms / 1e3
    )
    c = TargetChoice(rig, LENS, KINEMATICS)
    far = walker(4, (-40.0, 5.0), (0.0, 0.0))  # nobody who can have been at the point
    c.on_state(at(0.9, far), None)
    c.on_select(GazeSelect(t_capture_ns=900_000_000, track_id=4), None)
    assert c.by_operator
    c.on_select(GazeSelect(t_capture_ns=1_000_000_000, ground_xy_m=(0.0, 5.0)), None)
    assert c.on_state(at(1.0 + 0.99 * start_up_s, far), None) is None and c.pending is not None
    change = c.on_state(at(1.0 + 1.01 * start_up_s, far), None)
    assert change is not None and change.target_id == 4 and c.pending is None
    assert not change.changed  # the rule picks the track followed meanwhile
    assert change.reason.startswith("operator refused: no track at (0, 5) m in ")
    assert change.reason.endswith("s; back to rule first") and not c.by_operator
    assert c.counts["refused_selections"] == 1
    # the rule's track, not an operator's: when it ends, the rule picks at once
    other = walker(8, (3.0, 5.0), (0.0, 0.0))
    change = c.on_state(at(1.1 + 1.01 * start_up_s, other), None)
    assert change is not None and change.target_id == 8 and not c.holding


def test_a_digital_heads_start_up_counts_wide_frames() -> None:
    rig = RIG.model_copy(
        update={
            "camera": RIG.camera.model_copy(update={"source": "digital", "rate_hz": 25.0}),
            "wide": RIG.wide.model_copy(update={"rate_hz": 5.0}),
        }
    )
    frames = rig.vision.background_learning_frames + rig.estimator.confirm_frames
    expected_s = frames / 5.0 + rig.estimator.coast_max_ms / 1e3
    assert track_start_up_s(rig) == pytest.approx(expected_s)


def Prediction_for(track_id: int) -> Prediction:
    clock = Clock()
    return prediction(clock, 0.0, 0.0).model_copy(update={"track_id": track_id})


def test_a_nearer_tentative_track_is_waited_for() -> None:
    c = choice(select_rule="first")
    c.on_select(GazeSelect(t_capture_ns=1_000_000_000, ground_xy_m=(0.0, 5.0)), None)
    # 1 s on: a confirmed walker who can have been at the point, and a nearer newcomer
    someone = walker(4, (2.5, 5.0), (0.0, 0.0))
    newcomer = walker(9, (0.6, 5.0), (0.5, 0.0)).model_copy(update={"confirmed": False})
    assert c.on_state(at(2.0, someone, newcomer), None) is None and c.pending is not None
    confirmed = newcomer.model_copy(update={"confirmed": True})
    change = c.on_state(at(2.2, someone, confirmed), None)
    assert change is not None and change.target_id == 9 and c.by_operator
    # and a continuation waits for a nearer tentative new track as well
    c.on_state(at(2.3, someone), None)  # 9 ended at once; 4 is too far to be its merge
    assert c.holding and c.target_id == 9
    again = walker(11, (0.7, 5.0), (0.5, 0.0)).model_copy(update={"confirmed": False})
    other = walker(12, (1.8, 5.0), (0.0, 0.0))
    assert c.on_state(at(2.5, someone, again, other), None) is None and c.target_id == 9
    change = c.on_state(at(2.6, someone, again.model_copy(update={"confirmed": True}), other), None)
    assert change is not None and change.target_id == 11


def test_a_young_track_without_its_velocitys_covariance_is_taken_back_only_to_its_birth() -> None:
    c = choice(select_rule="first")
    c.on_select(GazeSelect(t_capture_ns=1_000_000_000, ground_xy_m=(0.0, 5.0)), None)
    # 1.6 s on: someone born 0.8 s ago 2.5 m from the point, and the person at the point,
    # born 0.3 s ago, whose velocity is still poor; taken back 1.6 s along it, it would be
    # 6 m off
    someone = walker(4, (2.5, 5.0), (0.0, 0.0)).model_copy(update={"age_s": 0.8})
    young = walker(9, (1.0, 5.0), (4.0, 2.5)).model_copy(update={"age_s": 0.3})
    change = c.on_state(at(2.6, someone, young), None)
    assert change is not None and change.target_id == 9


def sure_of(track: Track, velocity_var_m2_s2: float) -> Track:
    """`track` with its velocity's covariance (position and velocity uncorrelated)."""
    return track.model_copy(
        update={
            "ground_velocity_cov_m2_s2": ((velocity_var_m2_s2, 0.0), (0.0, velocity_var_m2_s2)),
            "ground_position_velocity_cov_m2_s": ((0.0, 0.0), (0.0, 0.0)),
        }
    )


def test_a_track_is_taken_back_along_its_velocity_to_the_request() -> None:
    """The point is given while nobody has a track; two are born 0.3 s before the choice, the
    one born nearer walking across, the other (the person at the point) walking away from it:
    taken back along their velocities over the 1.4 s since the request, only the second comes
    from the point."""
    c = choice(select_rule="first")
    c.on_select(GazeSelect(t_capture_ns=1_000_000_000, ground_xy_m=(0.0, 5.0)), None)
    across = sure_of(walker(4, (0.6, 5.7), (1.2, -0.9)), 0.09).model_copy(update={"age_s": 0.3})
    away = sure_of(walker(9, (0.0, 6.6), (0.0, 1.2)), 0.09).model_copy(update={"age_s": 0.3})
    change = c.on_state(at(2.4, across, away), None)
    assert change is not None and change.target_id == 9 and c.by_operator


def test_a_poorly_known_velocity_is_taken_back_with_its_uncertainty() -> None:
    """A young track's velocity, far off, moves its position back far from the point, but its
    covariance over the time widens the fit so much that the person at the point is taken."""
    c = choice(select_rule="first")
    c.on_select(GazeSelect(t_capture_ns=1_000_000_000, ground_xy_m=(0.0, 5.0)), None)
    someone = sure_of(walker(4, (2.5, 5.0), (0.0, 0.0)), 0.01).model_copy(update={"age_s": 0.8})
    young = sure_of(walker(9, (1.0, 5.0), (4.0, 2.5)), 16.0).model_copy(update={"age_s": 0.3})
    change = c.on_state(at(2.6, someone, young), None)
    assert change is not None and change.target_id == 9
    # as sure of that velocity as of the other's, it does not come from the point
    c = choice(select_rule="first")
    c.on_select(GazeSelect(t_capture_ns=1_000_000_000, ground_xy_m=(0.0, 5.0)), None)
    sure = sure_of(young, 0.01)
    assert c.on_state(at(2.6, someone, sure), None) is None and c.pending is not None


def test_the_controller_follows_no_other_track_while_the_choice_waits() -> None:
    clock = Clock()
    controller = GazeController(RIG, clock.mono_s)
    mine, other = walker(2, (0.0, 5.0), (1.0, 0.0)), walker(1, (-3.0, 5.0), (0.0, 0.0))
    controller.on_estimator_state(at(clock.wall_ns / 1e9, other, mine), clock.wall_ns)
    controller.on_select(GazeSelect(t_capture_ns=clock.wall_ns, track_id=2), clock.wall_ns)
    controller.on_prediction(prediction(clock, 5.0, 0.0).model_copy(update={"track_id": 2}))
    clock.advance(0.2)
    controller.on_estimator_state(at(clock.wall_ns / 1e9, other), clock.wall_ns)  # 2 ended
    decision = controller.tick(clock.wall_ns, clock.mono_s)
    held = [s for s in decision.transitions if "held for its person" in s.reason]
    assert len(held) == 1 and held[0].target_id == 2
    pursued = controller.pursuit.prediction
    controller.on_prediction(prediction(clock, -20.0, 0.0).model_copy(update={"track_id": 1}))
    assert controller.pursuit.prediction is pursued  # not the rule's first track
    assert controller.counts["other_tracks"] == 1 and controller.counts["held_for_person"] == 1


def test_a_track_long_in_range_does_not_take_a_point_across_from_it() -> None:
    """A track's covariance is long in range and narrow across: its range spread does not
    reach a point beside it, which waits for the track of the person who is there."""
    c = choice(select_rule="first")
    ranged = walker(4, (1.2, 5.0), (0.0, 0.0)).model_copy(
        update={"ground_cov_m2": ((0.01, 0.0), (0.0, 1.0)), "age_s": 2.0}
    )
    c.on_state(at(1.0, ranged), None)
    held = c.on_select(GazeSelect(t_capture_ns=1_000_000_000, ground_xy_m=(0.0, 5.0)), None)
    assert not held.changed and c.pending is not None and not c.by_operator
    mine = walker(9, (0.3, 5.0), (0.5, 0.0)).model_copy(update={"age_s": 0.4})
    change = c.on_state(at(1.5, ranged, mine), None)
    assert change is not None and change.target_id == 9 and c.by_operator


def test_a_track_that_explains_the_point_better_takes_it_over_within_the_start_up() -> None:
    """Nobody at the point has a track yet; someone walking near it is born where the person
    can have walked and takes it; the person's own track, confirmed later and far more likely,
    takes the choice over; each is judged once, so the first never takes it back."""
    c = choice(select_rule="first")
    c.on_select(GazeSelect(t_capture_ns=1_000_000_000, ground_xy_m=(0.0, 5.0)), None)
    # 1.4 s on: born 0.3 s ago 2.6 m off, where the person can just have walked (2.4 m/s)
    someone = walker(4, (2.6, 5.0), (0.0, 0.0)).model_copy(update={"age_s": 0.3})
    change = c.on_state(at(2.4, someone), None)
    assert change is not None and change.target_id == 4 and c.by_operator
    # the person's own track, 1 m from the point after 1.4 s of walking, now confirmed
    mine = walker(9, (-1.0, 5.0), (-0.7, 0.0)).model_copy(update={"age_s": 0.4})
    assert (
        c.on_state(
            at(
                2.8,
                someone.model_copy(update={"age_s": 0.7}),
                mine.model_copy(update={"confirmed": False}),
            ),
            None,
        )
        is None
    )
    change = c.on_state(at(3.0, someone.model_copy(update={"age_s": 0.9}), mine), None)
    assert change is not None and change.target_id == 9 and c.by_operator
    assert change.reason == "operator: track 9 explains (0, 5) m better than 4"
    assert c.counts["revised_selections"] == 1
    # judged once: 4 never takes it back, and past the start-up nothing revises it
    assert c.on_state(at(3.2, someone, mine), None) is None and c.target_id == 9
    late_s = 1.0 + 1.01 * track_start_up_s(RIG)
    exact = walker(11, (0.0, 5.0), (0.0, 0.0)).model_copy(update={"age_s": 0.1})
    assert c.on_state(at(late_s, mine, exact), None) is None and c.target_id == 9


def test_a_newcomer_is_held_to_the_fit_the_chosen_track_had_when_it_took_the_point() -> None:
    """The chosen track took the point close to it; later its fit, taken back along its velocity
    over a longer life, falls, but a newcomer born a walk away does not take the choice."""
    c = choice(select_rule="first")
    c.on_select(GazeSelect(t_capture_ns=1_000_000_000, ground_xy_m=(0.0, 5.0)), None)
    mine = walker(3, (0.2, 5.0), (0.0, 0.0)).model_copy(update={"age_s": 0.3})
    change = c.on_state(at(1.5, mine), None)
    assert change is not None and change.target_id == 3
    # 1.5 s on, its velocity says it came from 3 m away; a newcomer 1.5 m off is confirmed
    drifted = mine.model_copy(update={"age_s": 1.5, "ground_velocity_m_s": (2.0, 0.0)})
    newcomer = walker(8, (1.5, 5.0), (0.0, 0.0)).model_copy(update={"age_s": 0.3})
    assert c.on_state(at(2.7, drifted, newcomer), None) is None and c.target_id == 3


def test_the_continuation_gate_grows_with_the_walk_since_the_chosen_track_was_seen() -> None:
    c = choice(select_rule="first")
    chosen = walker(2, (0.0, 5.0), (0.0, 0.0))
    c.on_state(at(1.0, chosen), None)
    c.on_select(GazeSelect(t_capture_ns=1, track_id=2), None)
    # 2 coasts: the estimator's covariance grows little, but its person can walk 2.5 m in 1 s
    coasting = chosen.model_copy(update={"coasting": True, "ground_cov_m2": ((0.06, 0), (0, 0.06))})
    assert c.on_state(at(1.5, coasting), None) is None
    # a new track beyond where 2's person can have walked since its last detection: not them
    assert c.on_state(at(2.0, coasting, walker(8, (3.2, 5.0), (0.0, 0.0))), None) is None
    # one a walk away (1.5 m in 1.1 s), outside the coasting covariance's gate: continues it
    change = c.on_state(
        at(2.1, coasting, walker(8, (3.2, 5.0), (0.0, 0.0)), walker(7, (1.5, 5.0), (0.0, 0.0))),
        None,
    )
    assert change is not None and change.target_id == 7 and c.by_operator
    assert change.reason == "track 2 lost; its person continues as 7"
