"""The gaze state machine, driven by scripted messages and an injected clock."""

from __future__ import annotations

import itertools
import math

import pytest

from gazed.config import Rig, parse_rig
from gazed.gaze.aim import move_duration_s
from gazed.gaze.controller import GazeController
from gazed.gaze.sightings import CANDIDATE_VELOCITY_FRAMES
from gazed.geometry.camera import CameraModel
from gazed.messages import Candidate, Candidates, Detection, HeadPose, Odometry, Prediction

RIG_TEXT = (
    '[rig]\nname = "g"\n'
    "[head]\npan_max_deg = 60\npan_rate_max_deg_s = 100\npan_accel_max_deg_s2 = 400\n"
    "tilt_rate_max_deg_s = 100\ntilt_accel_max_deg_s2 = 400\n"
    "[gaze]\nsettle_ms = 100\nlost_after_ms = 300\nsearch_after_ms = 1000\nresidual_gain = 0\n"
)
RIG = parse_rig(RIG_TEXT)
CAMERA = CameraModel.from_section(RIG.camera)
F = CAMERA.K[0, 0]
LIMITS = (math.radians(100.0), math.radians(400.0))  # the rig's head: rate, acceleration
T0 = 1_000_000_000_000_000_000  # wall ns


class Clock:
    def __init__(self) -> None:
        self.wall_ns = T0
        self.mono_s = 100.0

    def advance(self, seconds: float) -> None:
        self.wall_ns += round(seconds * 1e9)
        self.mono_s += seconds


def odometry(clock: Clock, pan_deg: float, tilt_deg: float, rate_deg_s: float = 0.0) -> Odometry:
    return Odometry(
        t_capture_ns=clock.wall_ns,
        pan_rad=math.radians(pan_deg),
        tilt_rad=math.radians(tilt_deg),
        pan_rate_rad_s=math.radians(rate_deg_s),
    )


def detection(
    clock: Clock, u: float, v: float, head_deg=(0.0, 0.0), du: float = 0.0, age_s: float = 0.0
) -> Detection:
    return Detection(
        t_capture_ns=clock.wall_ns - round(age_s * 1e9),
        stamps=(("vision", clock.wall_ns),),
        seq=1,
        detector="flow",
        found=True,
        u_px=u,
        v_px=v,
        du_px_s=du,
        width_px=640,
        height_px=480,
        head=HeadPose(pan_rad=math.radians(head_deg[0]), tilt_rad=math.radians(head_deg[1])),
    )


def prediction(
    clock: Clock,
    pan_deg: float,
    tilt_deg: float,
    pan_rate_deg_s: float = 0.0,
    actuation_s: float = 0.02,
) -> Prediction:
    return Prediction(
        t_capture_ns=clock.wall_ns - 150_000_000,
        stamps=(("vision", clock.wall_ns), ("estimator", clock.wall_ns)),
        filter="imm",
        t_effect_ns=clock.wall_ns + round(actuation_s * 1e9),
        horizon_s=0.17,
        pan_rad=math.radians(pan_deg),
        tilt_rad=math.radians(tilt_deg),
        pan_rate_rad_s=math.radians(pan_rate_deg_s),
        tilt_rate_rad_s=0.0,
        visual_latency_s=0.15,
        actuation_latency_s=actuation_s,
    )


def run_up(c: GazeController, clock: Clock, u: float, v: float, **kwargs) -> None:
    """The detections of the frames before this one that, with this frame's, make the
    `reacquire_detections` in a row a detection is taken up after."""
    for k in range(RIG.gaze.reacquire_detections - 1, 0, -1):
        c.on_detection(detection(clock, u, v, age_s=0.04 * k, **kwargs))


def in_search(clock: Clock, rig: Rig = RIG) -> GazeController:
    c = GazeController(rig, clock.mono_s)
    c.on_odometry(odometry(clock, 0.0, 0.0))
    decision = c.tick(clock.wall_ns, clock.mono_s)
    assert decision.transition is not None and decision.transition.state == "search"
    assert decision.transition.reason == "head parked"
    assert decision.demand.kind == "park"
    clock.advance(0.02)
    return c


def in_pursuit(clock: Clock, rig: Rig = RIG) -> GazeController:
    c = in_search(clock, rig)
    run_up(c, clock, 330.0, 245.0)
    c.on_detection(detection(clock, 330.0, 245.0))
    decision = c.tick(clock.wall_ns, clock.mono_s)
    assert (
        decision.transition.state == "pursuit"
        and decision.transition.reason == "target in the fovea"
    )
    return c


def test_starts_parked_then_searches_holding_still() -> None:
    clock = Clock()
    c = GazeController(RIG, clock.mono_s)
    first = c.tick(clock.wall_ns, clock.mono_s)
    assert first.demand.kind == "park" and first.transition is None  # parking needs no odometry
    c.on_odometry(odometry(clock, 5.0, 0.0))
    assert c.tick(clock.wall_ns, clock.mono_s).demand.kind == "park"
    assert c.state == "park"  # not there yet
    clock = Clock()
    c = in_search(clock)
    hold = c.tick(clock.wall_ns, clock.mono_s).demand
    assert hold.kind == "hold" and hold.pan_rad == 0.0


def test_a_hold_stays_where_it_began_as_the_encoder_reading_flickers() -> None:
    """Holding still, the readings flicker by an encoder step (0.088°, late by a poll): the hold
    keeps the angles it began with, for demanding each reading would make the head hunt."""
    clock = Clock()
    c = in_search(clock)
    demanded = set()
    for k in range(20):
        clock.advance(0.02)
        c.on_odometry(odometry(clock, 0.088 * (k % 2), 0.0), clock.wall_ns)
        demand = c.tick(clock.wall_ns, clock.mono_s).demand
        assert demand.kind == "hold"
        demanded.add((demand.pan_rad, demand.tilt_rad))
    assert demanded == {(0.0, 0.0)}


def test_detection_outside_the_fovea_draws_a_saccade_to_where_the_target_will_be() -> None:
    clock = Clock()
    c = in_search(clock)
    # 200 px right of centre, moving right at 100 px/s: the saccade leads it by the move time
    run_up(c, clock, 519.5, 239.5, du=100.0)
    c.on_detection(detection(clock, 519.5, 239.5, du=100.0))
    decision = c.tick(clock.wall_ns, clock.mono_s)
    assert (
        decision.transition.state == "saccade"
        and decision.transition.reason == "detection outside the fovea"
    )
    seen_deg = math.degrees(math.atan(200.0 / F))
    rate_deg_s = math.degrees(100.0 / F * math.cos(math.atan(200 / F)) ** 2)
    lead_s = move_duration_s(math.radians(seen_deg), math.radians(100), math.radians(400)) + 0.1
    assert decision.demand.kind == "position"
    assert math.degrees(decision.demand.pan_rad) == pytest.approx(
        seen_deg + rate_deg_s * lead_s, abs=0.01
    )
    # detections during the move are ignored
    c.on_detection(detection(clock, 100.0, 100.0))
    assert c.counts["ignored_while_moving"] == 1
    goal_deg = math.degrees(decision.demand.pan_rad)
    clock.advance(0.2)
    c.on_odometry(odometry(clock, goal_deg, 0.0))
    assert c.tick(clock.wall_ns, clock.mono_s).transition is None  # at the goal, not yet settled
    clock.advance(0.11)
    c.on_odometry(odometry(clock, goal_deg, 0.0))
    settled = c.tick(clock.wall_ns, clock.mono_s)
    assert (
        settled.transition.state == "pursuit"
        and settled.transition.reason == "settled on the target"
    )


def measured_run(c: GazeController, clock: Clock, frame: Candidates) -> None:
    """CANDIDATE_VELOCITY_FRAMES frames of `frame`, each a frame period after the last, the last
    captured now: a velocity measured over the fit's window; no saccade before the last."""
    for k in range(CANDIDATE_VELOCITY_FRAMES):
        if k:
            assert c.tick(clock.wall_ns, clock.mono_s).transition is None
        clock.advance(0.04)
        c.on_candidates(frame.model_copy(update={"t_capture_ns": clock.wall_ns}))


def test_motion_candidate_draws_a_saccade_and_weak_ones_do_not() -> None:
    clock = Clock()
    c = in_search(clock)
    head = HeadPose(pan_rad=0.0, tilt_rad=0.0)
    weak = Candidates(
        t_capture_ns=clock.wall_ns,
        seq=2,
        width_px=640,
        height_px=480,
        head=head,
        candidates=(Candidate(u_px=100.0, v_px=239.5, area_px=50.0, energy=1.0, score=-1.0),),
    )
    c.on_candidates(weak)
    assert c.tick(clock.wall_ns, clock.mono_s).transition is None
    # moving down the image: a tilt rate only, at tilt 0
    strong = Candidate(u_px=100.0, v_px=239.5, dv_px_s=1.0, area_px=400.0, energy=9.0, score=3.0)
    measured_run(c, clock, weak.model_copy(update={"candidates": (strong,)}))
    decision = c.tick(clock.wall_ns, clock.mono_s)
    assert (
        decision.transition.state == "saccade" and decision.transition.reason == "motion candidate"
    )
    assert math.degrees(decision.demand.pan_rad) == pytest.approx(
        -math.degrees(math.atan(219.5 / F)), abs=0.01
    )


def test_candidates_seen_while_the_head_turns_are_not_searched() -> None:
    """A frame captured while the head still turned (say, braking after a lost scan) shows
    whatever the ego-rotation compensation missed as motion: no saccade to it."""
    clock = Clock()
    c = in_search(clock)
    candidate = Candidate(
        u_px=100.0, v_px=239.5, du_px_s=10.0, area_px=400.0, energy=9.0, score=3.0
    )
    turning = Candidates(
        t_capture_ns=clock.wall_ns,
        seq=2,
        width_px=640,
        height_px=480,
        head=HeadPose(pan_rad=0.0, tilt_rad=0.0, tilt_rate_rad_s=math.radians(20.0)),
        candidates=(candidate,),
    )
    c.on_candidates(turning)
    assert c.tick(clock.wall_ns, clock.mono_s).transition is None
    assert c.counts["ignored_while_moving"] == 1
    measured_run(c, clock, turning.model_copy(update={"head": HeadPose(pan_rad=0.0, tilt_rad=0.0)}))
    assert c.tick(clock.wall_ns, clock.mono_s).transition.state == "saccade"


def test_pursuit_demands_the_prediction_at_the_instant_it_acts() -> None:
    clock = Clock()
    c = in_pursuit(clock)
    clock.advance(0.04)
    c.on_detection(detection(clock, 320.0, 240.0))
    c.on_prediction(prediction(clock, 10.0, -5.0, pan_rate_deg_s=20.0, actuation_s=0.03))
    clock.advance(0.01)  # the tick comes 10 ms after the prediction was made
    demand = c.tick(clock.wall_ns, clock.mono_s).demand
    assert demand.kind == "pursuit"
    # predicted for t_effect = made + 30 ms; demanded for now + 30 ms: 10 ms further at 20°/s
    assert math.degrees(demand.pan_rad) == pytest.approx(10.0 + 20.0 * 0.01, abs=1e-6)
    assert math.degrees(demand.tilt_rad) == pytest.approx(-5.0, abs=1e-6)
    assert demand.stamps[-1][0] == "gaze" and [s for s, _ in demand.stamps[:-1]] == [
        "vision",
        "estimator",
    ]
    assert demand.t_capture_ns == clock.wall_ns - 10_000_000 - 150_000_000
    # feed-forward rate limited by the acceleration limit (400°/s² over one tick from 0)
    assert math.degrees(demand.pan_rate_rad_s) <= 20.0 + 1e-9


def test_pursuit_clamps_to_the_joint_limits() -> None:
    clock = Clock()
    c = in_pursuit(clock)
    c.on_prediction(prediction(clock, 75.0, 0.0))
    demand = c.tick(clock.wall_ns, clock.mono_s).demand
    assert math.degrees(demand.pan_rad) == pytest.approx(60.0)
    assert c.clamps == 1


def test_lost_coasts_searches_a_growing_region_then_gives_up() -> None:
    """Lost: the fovea stays on the prediction while the search region fits in it, then tours
    the region's edge in stops a fovea apart, holding each for a look; detections from the
    moves between stops are ignored, `reacquire_detections` in a look resume pursuit; after
    search_after_ms, back to search."""
    clock = Clock()
    fast = RIG.gaze.model_copy(
        update={
            "lost_search_growth_deg_s": 10.0,
            "search_after_ms": 3000,
            "lost_search_max_deg": 40.0,
        }
    )
    c = in_pursuit(clock, RIG.model_copy(update={"gaze": fast}))
    for _ in range(8):  # 320 ms without a detection, predictions still coming (coasting)
        clock.advance(0.04)
        c.on_prediction(prediction(clock, 5.0, -2.0))
        decision = c.tick(clock.wall_ns, clock.mono_s)
    assert (
        decision.transition.state == "lost"
        and decision.transition.reason == "no detection for 300 ms"
    )
    offsets: list[tuple[float, float]] = []
    starts: list[int] = []  # the ticks at which a stop on the ring begins
    while len(starts) < 3:  # a tick every 20 ms until the third stop begins
        clock.advance(0.02)
        c.on_prediction(prediction(clock, 5.0, -2.0))
        d = c.tick(clock.wall_ns, clock.mono_s).demand
        offsets.append((math.degrees(d.pan_rad) - 5.0, math.degrees(d.tilt_rad) + 2.0))
        if offsets[-1] != (offsets[-2] if len(offsets) > 1 else (0.0, 0.0)):
            starts.append(len(offsets) - 1)
    fovea_deg = RIG.gaze.fovea_half_angle_deg
    region_deg = [  # 10°/s without a covariance, up to the largest radius
        min(10.0 * 0.02 * (k + 1), fast.lost_search_max_deg) for k in range(len(offsets))
    ]
    inside = [k for k, r in enumerate(region_deg) if r <= fovea_deg]
    assert starts[0] == len(inside) > 0  # on the prediction while the region fits the fovea
    assert all(offsets[k] == pytest.approx((0.0, 0.0), abs=1e-9) for k in inside)
    look_s = fast.settle_ms / 1000 + (fast.reacquire_detections + 1) * 0.04 + 0.15
    for a, b in itertools.pairwise(starts):
        assert (b - a) * 0.02 >= look_s - 1e-9  # each stop held for a look
        ring = [math.hypot(*offsets[k]) for k in (a, b)]
        assert ring[0] == pytest.approx(region_deg[a] - fovea_deg, abs=1e-6)
        assert ring[1] == pytest.approx(region_deg[b] - fovea_deg, abs=1e-6)
        step = math.atan2(offsets[b][1], offsets[b][0]) - math.atan2(offsets[a][1], offsets[a][0])
        step = (step + math.pi) % (2 * math.pi) - math.pi
        assert step == pytest.approx(min(2 * math.pi / 3, 2 * fovea_deg / ring[1]), abs=1e-6)
    # a detection from the move to the third stop is ignored; one per frame after it counts
    ignored = c.counts["ignored_while_moving"]
    c.on_detection(detection(clock, 330.0, 240.0))
    assert c.counts["ignored_while_moving"] == ignored + 1
    move = [b - a for a, b in zip(offsets[starts[1]], offsets[starts[2]], strict=True)]
    settled_s = fast.settle_ms / 1000 + max(move_duration_s(math.radians(m), *LIMITS) for m in move)
    waited_s = 0.0
    while waited_s < settled_s:
        clock.advance(0.04)
        waited_s += 0.04
        c.on_prediction(prediction(clock, 5.0, -2.0))
        assert c.tick(clock.wall_ns, clock.mono_s).transition is None
    for k in range(RIG.gaze.reacquire_detections):  # one per frame, in a row
        clock.advance(0.04)
        c.on_detection(detection(clock, 330.0, 240.0))
        back = c.tick(clock.wall_ns, clock.mono_s)
        assert (back.transition is None) == (k < RIG.gaze.reacquire_detections - 1)
    assert back.transition.state == "pursuit" and back.transition.reason == "target seen again"
    # lost again, and for longer than search_after_ms this time
    for _ in range(100):
        clock.advance(0.04)
        c.on_prediction(prediction(clock, 5.0, -2.0))
        decision = c.tick(clock.wall_ns, clock.mono_s)
        if decision.transition is not None and decision.transition.state == "search":
            break
    assert c.state == "search" and decision.transition.reason.startswith("lost for 3.")


def test_lost_with_a_prediction_that_says_too_little_goes_back_to_search_at_once() -> None:
    """A track too young for a velocity coasts with a covariance wider than the largest search
    region: the gaze goes back to search (whole-frame motion from a still head) at once
    instead of coasting on it for search_after_ms."""
    rig = parse_rig(RIG_TEXT + "[calibration]\ncamera_xyz_m = [0.0, 0.0, 3.0]\n")
    clock = Clock()
    c = in_pursuit(clock, rig)
    vague = prediction(clock, 5.0, -2.0).model_copy(
        update={"ground_xy_m": (0.0, 5.0), "position_cov_m2": ((4.0, 0.0), (0.0, 4.0))}
    )
    states = []
    for _ in range(12):  # 480 ms without a detection
        clock.advance(0.04)
        c.on_prediction(vague.model_copy(update={"t_effect_ns": clock.wall_ns + 20_000_000}))
        decision = c.tick(clock.wall_ns, clock.mono_s)
        states.extend((t.state, t.reason) for t in decision.transitions)
    # 2 m at 5.8 m: a region of 19.7° against the largest, 10°
    assert states == [
        ("lost", "no detection for 300 ms"),
        ("search", "search region 20° wide after 0.0 s"),
    ]


def test_lost_with_no_prediction_to_coast_on_goes_back_to_search_at_once() -> None:
    """A target pursued on its detections alone (the estimator had no track of it yet) and
    then missed: there is nothing to coast on, so the gaze goes back to search (whole-frame
    motion from a still head) at once instead of holding still for search_after_ms."""
    clock = Clock()
    c = in_pursuit(clock)  # on detections only: no prediction ever came
    states = []
    for _ in range(12):  # 480 ms without a detection
        clock.advance(0.04)
        decision = c.tick(clock.wall_ns, clock.mono_s)
        states.extend((t.state, t.reason) for t in decision.transitions)
    assert states == [("lost", "no detection for 300 ms"), ("search", "no prediction to coast on")]


def test_a_camera_later_than_lost_after_ms_is_pursued_and_lost_after_its_frames_say() -> None:
    """Each frame reaches the gaze 500 ms after its capture, longer than `lost_after_ms`
    (300 ms): pursuit holds while the frames show the target, and goes lost only once 300 ms
    of frames have not, not on the wall clock's age of every sighting."""
    lag_s = 0.5
    clock = Clock()
    c = in_pursuit(clock)
    states = []
    for k in range(40):  # 25 frames show the target, then 15 do not
        clock.advance(0.04)
        frame = detection(clock, 330.0, 245.0, age_s=lag_s)
        if k >= 25:
            frame = frame.model_copy(update={"found": False})
        c.on_detection(frame, clock.wall_ns)
        decision = c.tick(clock.wall_ns, clock.mono_s)
        states.extend((k, t.state) for t in decision.transitions)
    # the eighth frame without it (k = 32) is 320 ms after frame 24, the last that showed it;
    # with no prediction to coast on, lost goes back to search at once
    assert states == [(32, "lost"), (32, "search")]


def test_lone_detections_while_lost_do_not_resume_pursuit() -> None:
    """False detections while the head scans (one every 0.3 s) never make `reacquire_detections`
    in a row: the controller stays lost and goes back to search, where the whole frame is looked
    at, instead of pursuing a phantom."""
    clock = Clock()
    c = in_pursuit(clock)
    states = []
    for k in range(60):  # 2.4 s at 25 Hz, predictions coasting
        clock.advance(0.04)
        c.on_prediction(prediction(clock, 5.0, -2.0))
        if k > 10 and k % 8 == 0:
            c.on_detection(detection(clock, 330.0, 240.0))
        decision = c.tick(clock.wall_ns, clock.mono_s)
        if decision.transition is not None:
            states.append(decision.transition.state)
    assert states == ["lost", "search"]


def test_look_and_move_moves_only_after_a_fresh_look() -> None:
    rig = RIG.model_copy(update={"gaze": RIG.gaze.model_copy(update={"control": "look-and-move"})})
    clock = Clock()
    c = GazeController(rig, clock.mono_s)
    c.on_odometry(odometry(clock, 0.0, 0.0))
    c.tick(clock.wall_ns, clock.mono_s)
    clock.advance(0.02)
    run_up(c, clock, 330.0, 240.0, du=50.0)
    c.on_detection(detection(clock, 330.0, 240.0, du=50.0))
    c.on_prediction(prediction(clock, 1.0, 0.0, pan_rate_deg_s=5.0))
    first = c.tick(clock.wall_ns, clock.mono_s)
    assert first.transition.state == "pursuit"
    move = first.demand  # the look that found it is fresh: move at once
    assert move.kind == "position"
    # to the prediction (1° at 5°/s for 20 ms from now: 0.9° now), led by the move and the settling
    lead_s = move_duration_s(math.radians(0.9), math.radians(100), math.radians(400)) + 0.1
    assert math.degrees(move.pan_rad) == pytest.approx(1.0 + 5.0 * (lead_s - 0.02), abs=1e-6)
    c.on_detection(detection(clock, 200.0, 240.0))  # captured while moving: ignored
    assert c.counts["ignored_while_moving"] == 1
    goal = math.degrees(move.pan_rad)
    for _ in range(4):  # arrive and settle (settle_ms = 100)
        clock.advance(0.04)
        c.on_odometry(odometry(clock, goal, 0.0))
        assert c.tick(clock.wall_ns, clock.mono_s).demand.kind == "position"
    assert c.look_and_move.looking
    clock.advance(0.01)
    hold = c.tick(clock.wall_ns, clock.mono_s).demand
    assert hold.kind == "hold"  # waiting for a frame taken after settling
    c.on_detection(detection(clock, 320.0, 240.0, head_deg=(goal, 0.0)))
    c.on_prediction(prediction(clock, goal, 0.0))
    assert c.tick(clock.wall_ns, clock.mono_s).demand.kind == "position"
    assert not c.look_and_move.looking


def test_a_restarted_controller_takes_up_a_target_in_view_instead_of_parking() -> None:
    clock = Clock()
    c = GazeController(RIG, clock.mono_s)
    c.on_odometry(odometry(clock, 20.0, -5.0))  # the head held where the last controller left it
    run_up(c, clock, 325.0, 242.0, head_deg=(20.0, -5.0))
    c.on_detection(detection(clock, 325.0, 242.0, head_deg=(20.0, -5.0)))
    decision = c.tick(clock.wall_ns, clock.mono_s)
    assert decision.transition.state == "pursuit" and decision.transition.previous == "park"
    assert decision.demand.kind == "pursuit"
    assert math.degrees(decision.demand.pan_rad) == pytest.approx(
        20.0 + math.degrees(math.atan(5.5 / F)), abs=0.05
    )


def test_move_wait_move_moves_to_where_the_target_was_seen_without_prediction() -> None:
    rig = RIG.model_copy(update={"gaze": RIG.gaze.model_copy(update={"control": "move-wait-move"})})
    clock = Clock()
    c = GazeController(rig, clock.mono_s)
    c.on_odometry(odometry(clock, 0.0, 0.0))
    c.tick(clock.wall_ns, clock.mono_s)
    clock.advance(0.02)
    run_up(c, clock, 330.0, 240.0, du=50.0)
    seen = detection(clock, 330.0, 240.0, du=50.0)
    c.on_detection(seen)
    c.on_prediction(prediction(clock, 1.0, 0.0, pan_rate_deg_s=5.0))  # not used
    move = c.tick(clock.wall_ns, clock.mono_s).demand
    assert move.kind == "position"
    where = c.sightings.aim(seen)
    assert (move.pan_rad, move.tilt_rad) == pytest.approx((where.pan_rad, where.tilt_rad))
    c.on_detection(detection(clock, 200.0, 240.0))  # captured while moving: ignored
    assert c.counts["ignored_while_moving"] == 1


def test_pid_control_drives_the_head_at_a_rate_towards_the_pixel_error() -> None:
    rig = RIG.model_copy(update={"gaze": RIG.gaze.model_copy(update={"control": "pid"})})
    clock = Clock()
    c = in_pursuit(clock, rig)
    clock.advance(0.04)
    c.on_detection(detection(clock, 400.0, 240.0, age_s=0.15))  # right of centre: pan on
    c.on_odometry(odometry(clock, 0.0, 0.0))
    demand = c.tick(clock.wall_ns, clock.mono_s).demand
    assert demand.kind == "pursuit" and demand.pan_rate_rad_s > 0
    assert demand.t_capture_ns == clock.wall_ns - 150_000_000  # it acts on that detection
    clock.advance(0.02)
    later = c.tick(clock.wall_ns, clock.mono_s).demand
    assert later.t_capture_ns == clock.wall_ns  # no new detection: stamped by the gaze alone
    error_rad = c.pid.last_error
    assert error_rad[0] > 0
    assert c.pid.rate_rad_s[0] == pytest.approx(rig.gaze.pid_kp_per_s * error_rad[0])
    # the head's acceleration limit shapes the step in rate
    assert demand.pan_rate_rad_s <= c.pid.rate_rad_s[0]


def settled_after_a_saccade(clock: Clock, held_deg: float) -> tuple[GazeController, float]:
    """A saccade to a detection 200 px right, a prediction `held_deg` in pan from its goal
    held when it settles; the controller in pursuit and the goal's pan (degrees)."""
    c = in_search(clock)
    run_up(c, clock, 519.5, 239.5)
    c.on_detection(detection(clock, 519.5, 239.5))
    goal_deg = math.degrees(c.tick(clock.wall_ns, clock.mono_s).demand.pan_rad)
    clock.advance(0.2)
    c.on_prediction(prediction(clock, goal_deg + held_deg, 0.0, actuation_s=0.0))
    c.on_odometry(odometry(clock, goal_deg, 0.0))
    c.tick(clock.wall_ns, clock.mono_s)
    clock.advance(0.11)
    c.on_odometry(odometry(clock, goal_deg, 0.0))
    settled = c.tick(clock.wall_ns, clock.mono_s)
    assert settled.transition.reason == "settled on the target"
    clock.advance(0.02)
    return c, goal_deg


def test_a_saccade_lands_without_pursuing_a_prediction_that_leaves_the_fovea() -> None:
    """Settled after a saccade, pursuit takes up a held prediction only where it puts the
    target in the fovea: one elsewhere is another target's (a track made before the move)
    and would send the head back; without it the head holds until a prediction comes."""
    clock = Clock()
    c, goal_deg = settled_after_a_saccade(clock, -15.0)  # back near where the head began
    demand = c.tick(clock.wall_ns, clock.mono_s).demand
    assert math.degrees(demand.pan_rad) == pytest.approx(goal_deg, abs=0.5)
    clock = Clock()
    c, goal_deg = settled_after_a_saccade(clock, 1.0)  # a degree from the landing: pursued
    demand = c.tick(clock.wall_ns, clock.mono_s).demand
    assert demand.kind == "pursuit"
    assert math.degrees(demand.pan_rad) == pytest.approx(goal_deg + 1.0, abs=0.1)


def test_predictions_still_coming_from_frames_before_the_landing_are_checked_too() -> None:
    """A track taken up during the move (from a frame the head's turn smeared, say) makes its
    predictions a loop latency later, after the landing: one that puts the target outside
    the fovea of the landing is not pursued, one inside is; the first made from a frame
    exposed after the landing is pursued wherever it puts the target."""
    clock = Clock()
    c, goal_deg = settled_after_a_saccade(clock, 1.0)
    landed_ns = clock.wall_ns - 20_000_000
    elsewhere = prediction(clock, goal_deg - 12.0, 0.0, actuation_s=0.0)
    assert elsewhere.t_capture_ns < landed_ns
    c.on_prediction(elsewhere)
    demand = c.tick(clock.wall_ns, clock.mono_s).demand
    assert math.degrees(demand.pan_rad) == pytest.approx(goal_deg + 1.0, abs=0.1)
    clock.advance(0.02)
    c.on_prediction(prediction(clock, goal_deg + 2.0, 0.0, actuation_s=0.0))
    demand = c.tick(clock.wall_ns, clock.mono_s).demand
    assert math.degrees(demand.pan_rad) == pytest.approx(goal_deg + 2.0, abs=0.1)
    clock.advance(0.2)  # frames exposed after the landing
    later = prediction(clock, goal_deg - 12.0, 0.0, actuation_s=0.0)
    assert later.t_capture_ns >= landed_ns
    c.on_prediction(later)
    demand = c.tick(clock.wall_ns, clock.mono_s).demand
    assert demand.kind == "pursuit"
    assert math.degrees(demand.pan_rad) == pytest.approx(goal_deg - 12.0, abs=0.1)


def test_lost_the_zoom_widens_with_the_search_region_and_search_goes_to_the_widest() -> None:
    """A zoom lens f = 500 + 4500 z held at 0.8 (f = 4100: the frame's 0.35 x 480 px inside its
    edge margin hold 2.35°). Lost, the search region grows at 2°/s from the prediction; the
    zoom stays while the frame holds it, then goes out at zoom_out_rate_s to the longest f
    that holds it; back in search, to the widest."""
    clock = Clock()
    zoomed = RIG.model_copy(
        update={
            "camera": RIG.camera.model_copy(
                update={"zoom_focal_px": ((0.0, 500.0), (1.0, 5000.0))}
            ),
            "gaze": RIG.gaze.model_copy(
                update={
                    "zoom_control": True,
                    "zoom_out_rate_s": 0.2,
                    "zoom_out_edge": 0.15,
                    "lost_search_growth_deg_s": 2.0,
                    "lost_search_max_deg": 40.0,
                    "search_after_ms": 3000,
                }
            ),
        }
    )
    c = in_search(clock, zoomed)
    c.on_odometry(odometry(clock, 0.0, 0.0).model_copy(update={"zoom": 0.8}))
    run_up(c, clock, 330.0, 245.0)
    c.on_detection(detection(clock, 330.0, 245.0))
    assert c.tick(clock.wall_ns, clock.mono_s).transition.state == "pursuit"
    zooms: list[float] = []
    lost_at = None
    for k in range(200):  # 20 ms ticks, predictions coasting, no detection
        clock.advance(0.02)
        c.on_prediction(prediction(clock, 5.0, -2.0))
        decision = c.tick(clock.wall_ns, clock.mono_s)
        if decision.transition is not None and decision.transition.state == "lost":
            lost_at = k
        if lost_at is not None:
            zooms.append(decision.demand.zoom)
        if c.state == "search":
            break
    assert lost_at is not None and c.state == "search"
    held_deg = math.degrees(math.atan(168.0 / 4100.0))
    # the region is 2°/s times the time lost, ticked every 20 ms from the entry into lost
    widen_at = math.ceil(held_deg / (2.0 * 0.02))
    assert all(z == pytest.approx(0.8) for z in zooms[:widen_at])
    assert zooms[widen_at] < 0.8
    for k in range(widen_at + 1, len(zooms) - 1):
        region_rad = math.radians(2.0 * 0.02 * k)
        holds = (168.0 / math.tan(region_rad) - 500.0) / 4500.0
        assert zooms[k] == pytest.approx(max(holds, zooms[k - 1] - 0.2 * 0.02), abs=1e-9)
    assert zooms[-2] > 0.24  # at 3 s a 6° region needs zoom 0.24 only: far from the widest
    assert zooms[-1] == pytest.approx(zooms[-2] - 0.2 * 0.02)  # search: out to the widest
