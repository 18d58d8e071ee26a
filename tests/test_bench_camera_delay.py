"""The hidden-delay bench's figure of the head's first move: where it lands against the target."""

from __future__ import annotations

import math

import numpy as np
import pytest
from bench.camera_delay import first_move, stamp_errors_ms

from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.pose import CameraPose
from gazed.messages import Detection, HeadPose, SimTruth

POSE = CameraPose(
    np.array([0.0, -5.0, 3.0]), math.radians(90), math.radians(-25), head=HeadKinematics("pan-tilt")
)
PERIOD_S = 0.04
SPEED_M_S = 1.0


def walker(t_s: float) -> np.ndarray:
    """A target walking along x through (0, 1) m; its middle 0.2 m up."""
    return np.array([-1.0 + SPEED_M_S * t_s, 1.0, 0.2])


def run(lag_s: float) -> list[SimTruth]:
    """The head still, 3 m off the target, until 0.4 s, a fast move (0.4-0.6 s) onto where the
    target was `lag_s` before, then following that point: behind it by `lag_s` of its motion."""
    still = np.array(POSE.gaze_angles(walker(0.0) + np.array([3.0, 0.0, 0.0])))
    frames = []
    for k in range(75):
        t_s = k * PERIOD_S
        followed = np.array(POSE.gaze_angles(walker(t_s - lag_s)))
        share = min(max((t_s - 0.4) / 0.2, 0.0), 1.0)
        pan, tilt = still + share * (followed - still)
        frames.append(
            SimTruth(
                t_capture_ns=round(t_s * 1e9),
                seq=k,
                target_xy_m=tuple(walker(t_s)[:2]),
                target_velocity_m_s=(SPEED_M_S, 0.0),
                target_height_m=0.4,
                head=HeadPose(pan_rad=float(pan), tilt_rad=float(tilt)),
            )
        )
    return frames


def test_a_move_that_lands_behind_the_target_says_by_how_much() -> None:
    move = first_move(run(0.2), POSE)["first_move"]
    t0, t1 = np.array(POSE.gaze_angles(walker(0.9))), np.array(POSE.gaze_angles(walker(1.1)))
    rate_deg_s = math.degrees(float(np.linalg.norm(t1 - t0))) / 0.2
    assert move["started_s"] == pytest.approx(0.4, abs=PERIOD_S + 1e-9)
    assert move["landed_s"] == pytest.approx(0.6, abs=2 * PERIOD_S + 1e-9)
    assert move["behind_deg"] == pytest.approx(0.2 * rate_deg_s, rel=0.25)
    assert move["rms_from_landing_deg"] > 0.5 * move["behind_deg"]


def test_a_move_onto_the_target_lands_on_it() -> None:
    move = first_move(run(0.0), POSE)["first_move"]
    assert abs(move["behind_deg"]) < 0.1
    assert move["rms_from_landing_deg"] < 0.1


def test_a_head_that_never_moves_has_no_first_move() -> None:
    frames = [f.model_copy(update={"head": run(0.0)[0].head}) for f in run(0.0)]
    assert first_move(frames, POSE) == {"first_move": None}


def test_the_stamps_converge_when_their_error_stays_within_a_frame() -> None:
    """Stamps 200 ms late until the frame exposed at 0.8 s, right from then on: they come
    within a frame period at 0.8 s from the first truth frame, whichever frame was first
    detected."""
    truth = run(0.0)
    detections = [
        Detection(
            t_capture_ns=t.t_capture_ns + (200_000_000 if t.t_capture_ns < 800_000_000 else 0),
            seq=t.seq,
            detector="flow",
            found=True,
            width_px=640,
            height_px=480,
        )
        for t in truth[5:]
    ]
    result = stamp_errors_ms(detections, truth, 40.0)
    assert result["converged_after_s"] == pytest.approx(0.8)
    assert result["stamp_error_ms"] == {"median": 0.0, "p95_abs": 0.0}
