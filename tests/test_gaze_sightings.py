"""Sightings (gazed.gaze.sightings): the run of detections in a row, which detection is recent,
and which motion candidate is worth a saccade."""

from __future__ import annotations

import math

import pytest
from test_gaze_controller import T0, Clock, detection

from gazed.config import parse_rig
from gazed.gaze.sightings import CANDIDATE_VELOCITY_FRAMES, Sightings
from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.zoom import ZoomLens
from gazed.messages import Candidate, Candidates, Detection, HeadPose

RIG = parse_rig(
    '[rig]\nname = "s"\n[camera]\nrate_hz = 25\n[gaze]\nlost_after_ms = 300\n'
    "candidate_min_score = 1.0\n"
)
CAMERA = CameraModel.from_section(RIG.camera)
F = CAMERA.K[0, 0]
MS = 1_000_000


def sightings() -> Sightings:
    kinematics = HeadKinematics.from_section(RIG.head)
    return Sightings(RIG.gaze, RIG.camera.frame_period_s, ZoomLens.fixed(CAMERA), kinematics)


def seen(t_ns: int, u_px: float = 319.5) -> Detection:
    """A detection captured at t_ns from a head at rest at (0, 0)."""
    return detection(Clock(), u_px, 239.5, age_s=(T0 - t_ns) / 1e9)


def candidates(
    t_ns: int,
    scores: tuple[float, ...],
    tilt_rate_deg_s: float = 0.0,
    du_px_s: float = 0.0,
) -> Candidates:
    """Candidates 100 px apart from the centre rightwards, each moving `du_px_s` (0: regions
    seen for the first time)."""
    return Candidates(
        t_capture_ns=t_ns,
        seq=1,
        width_px=640,
        height_px=480,
        head=HeadPose(pan_rad=0.0, tilt_rad=0.0, tilt_rate_rad_s=math.radians(tilt_rate_deg_s)),
        candidates=tuple(
            Candidate(
                u_px=319.5 + 100.0 * k,
                v_px=239.5,
                du_px_s=du_px_s,
                area_px=100.0,
                energy=1.0,
                score=s,
            )
            for k, s in enumerate(scores)
        ),
    )


def test_a_run_counts_frames_a_frame_or_two_apart() -> None:
    s = sightings()
    s.take(seen(T0), count=True)
    assert s.in_a_row == 1
    s.take(seen(T0 + 40 * MS), count=True)
    s.take(seen(T0 + 120 * MS), count=True)  # a frame missed: 2 periods, still a run
    assert s.in_a_row == 3
    s.take(seen(T0 + 120 * MS), count=True)  # the same frame again counts nothing
    assert s.in_a_row == 3
    s.take(seen(T0 + 230 * MS), count=True)  # 2.75 periods: a new run
    assert s.in_a_row == 1
    s.take(seen(T0 + 270 * MS), count=False)  # taken, not counted
    assert s.in_a_row == 1 and s.found is not None and s.found.t_capture_ns == T0 + 270 * MS
    s.restart_run()
    assert s.in_a_row == 0


def test_recent_means_since_the_state_began_and_within_lost_after_ms() -> None:
    s = sightings()
    assert s.recent(T0, since_ns=0) is None
    s.take(seen(T0), count=True)
    assert s.recent(T0 + 300 * MS, since_ns=T0) is not None
    assert s.recent(T0 + 301 * MS, since_ns=T0) is None  # too old
    assert s.recent(T0 + 10 * MS, since_ns=T0 + 1) is None  # from before the state began
    assert s.recent(T0 - 600 * MS, since_ns=0) is None  # half a second in the future: bogus
    s.forget()
    assert s.found is None and s.recent(T0, since_ns=0) is None


def test_a_sightings_age_is_counted_in_the_frames_vision_has_reported_on() -> None:
    """Frames reach the gaze their pipeline's lag after capture (here 700 ms, past
    `lost_after_ms`): a sighting is as old as the frames since it, not as the wall clock says;
    while vision is silent its age still grows with the wall clock."""
    s = sightings()
    lag_ns = 700 * MS
    s.arrived(T0, T0 + lag_ns)
    s.take(seen(T0), count=True)
    assert s.recent(T0 + lag_ns, since_ns=0) is not None  # just in: 0 ms old, not 700
    assert s.age_ns(T0, T0 + lag_ns) == 0
    for k in range(1, 8):  # frames without the target, 40 ms apart, each 700 ms late
        s.arrived(T0 + k * 40 * MS, T0 + k * 40 * MS + lag_ns)
    assert s.recent(T0 + 280 * MS + lag_ns, since_ns=0) is not None  # 280 ms of frames
    s.arrived(T0 + 320 * MS, T0 + 320 * MS + lag_ns)
    assert s.recent(T0 + 320 * MS + lag_ns, since_ns=0) is None  # 320 ms: lost_after_ms past
    s.arrived(T0 + 200 * MS, T0 + 900 * MS)  # an older frame late: the lag stays the newest's
    assert s.frame_lag_ns == lag_ns
    s.arrived(T0 + 60_000 * MS, T0 + 400 * MS)  # stamped a minute ahead: a bad clock, ignored
    assert (s.newest_frame_ns, s.frame_lag_ns) == (T0 + 320 * MS, lag_ns)
    # vision silent after a frame 100 ms after the sighting: the age runs on the wall clock
    s = sightings()
    s.take(seen(T0), count=True)
    s.arrived(T0 + 100 * MS, T0 + 100 * MS + lag_ns)
    assert s.recent(T0 + 300 * MS + lag_ns, since_ns=0) is not None
    assert s.recent(T0 + 301 * MS + lag_ns, since_ns=0) is None


def measured(s: Sightings, last_ns: int, scores: tuple[float, ...], du_px_s: float = 0.0) -> None:
    """A run of CANDIDATE_VELOCITY_FRAMES frames ending at `last_ns` whose best candidate has a
    measured velocity (the last `du_px_s`)."""
    for k in range(CANDIDATE_VELOCITY_FRAMES - 1, 0, -1):
        s.on_candidates(candidates(last_ns - 40 * MS * k, scores, du_px_s=1.0))
    s.on_candidates(candidates(last_ns, scores, du_px_s=du_px_s or 1.0))


def test_the_best_candidate_is_the_strongest_from_a_head_at_rest() -> None:
    s = sightings()
    measured(s, T0, (2.0, 5.0, 0.5))
    aim = s.best_candidate(T0 + 40 * MS, since_ns=T0)
    assert aim is not None and aim.t_ns == T0
    assert aim.pan_rad == pytest.approx(math.atan(100.0 / F))  # the second: 100 px right
    assert s.best_candidate(T0 + 301 * MS, since_ns=T0) is None  # too old
    assert s.best_candidate(T0, since_ns=T0 + 1) is None  # from before the state began
    measured(s, T0, (0.9,))
    assert s.best_candidate(T0, since_ns=0) is None  # too weak
    s.candidates = candidates(T0, (5.0,), tilt_rate_deg_s=3.0)
    assert s.best_candidate(T0, since_ns=0) is None  # seen from a turning head: counted
    assert s.turning_candidates == 1


def test_a_candidate_draws_a_saccade_once_its_velocity_is_measured_over_the_fit_window() -> None:
    """A region seen for the first time has no velocity, and one over a frame or two is far off:
    a saccade aiming with it over the latency and the move would land behind the target."""
    s = sightings()
    s.on_candidates(candidates(T0, (5.0,)))  # first seen: no velocity
    assert s.measured_in_a_row == 0 and s.best_candidate(T0, since_ns=0) is None
    for k in range(1, CANDIDATE_VELOCITY_FRAMES):
        s.on_candidates(candidates(T0 + 40 * MS * k, (5.0,), du_px_s=10.0))
        s.on_candidates(candidates(T0 + 40 * MS * k, (5.0,), du_px_s=10.0))  # a repeat
        assert s.measured_in_a_row == k
        assert s.best_candidate(T0 + 40 * MS * k, since_ns=0) is None
    last_ns = T0 + 40 * MS * CANDIDATE_VELOCITY_FRAMES
    s.on_candidates(candidates(last_ns, (5.0,), du_px_s=10.0))
    aim = s.best_candidate(last_ns, since_ns=0)
    assert aim is not None and aim.pan_rate_rad_s == pytest.approx(10.0 / F)
    s.on_candidates(candidates(last_ns + 40 * MS, (5.0,), tilt_rate_deg_s=3.0, du_px_s=10.0))
    assert s.measured_in_a_row == 0  # seen from a turning head: the run starts again
    measured(s, last_ns + 400 * MS, (5.0,))
    s.on_candidates(candidates(last_ns + 440 * MS, (5.0,)))  # a new region: no velocity
    assert s.best_candidate(last_ns + 440 * MS, since_ns=0) is None


def test_a_detection_aims_from_its_head_pose() -> None:
    aim = sightings().aim(seen(T0, u_px=319.5 + 200.0))
    assert aim.t_ns == T0 and aim.pan_rad == pytest.approx(math.atan(200.0 / F))
