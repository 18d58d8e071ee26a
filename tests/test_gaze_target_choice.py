"""Which track the gaze follows: the rig's rules (in a ground zone), an operator's choice by id,
ground point or pixel, a choice that holds until its track ends, and the gaze/state messages and
prediction filtering that follow from it in the controller."""

from __future__ import annotations

import math

import pytest
from test_gaze_controller import RIG, Clock, detection, odometry, prediction

from gazed.config import GazeSection
from gazed.gaze.controller import GazeController
from gazed.gaze.focus import focus
from gazed.gaze.target_choice import TargetChoice
from gazed.gaze.target_rule import GroundZone, rule_pick
from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.target_angles import target_angles
from gazed.geometry.zoom import ZoomLens
from gazed.messages import EstimatorState, GazeSelect, HeadPose, Mover, Track

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
    return TargetChoice(GazeSection(**gaze), LENS, KINEMATICS)


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


def test_an_operators_choice_ends_with_its_track() -> None:
    c = choice(select_rule="first")
    c.on_state(state(*TRACKS), None)
    c.on_select(GazeSelect(t_capture_ns=1, track_id=4), None)
    change = c.on_state(state(*TRACKS[:3]), None)
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

    def at(t_s: float, *tracks: Track) -> EstimatorState:
        return EstimatorState(
            t_capture_ns=round(t_s * 1e9), filter="imm", x=(), P=(), tracks=tracks
        )

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
