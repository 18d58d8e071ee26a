"""Scores of a closed-loop run from recorded messages (gazed eval loop)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gazed.eval.loop import servo_summary
from gazed.eval.loop_metrics import (
    ACQUIRED_FRAMES,
    LoopRecord,
    acquisition_index,
    gaze_errors_rad,
    ground_rmse_m,
    latencies_ms,
    reachable,
    score,
)
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.pose import CameraPose
from gazed.messages import (
    EstimatorState,
    GazeDemand,
    GazeState,
    HeadPose,
    ServoStatus,
    SimTruth,
)
from gazed.sim.reach import FieldOfRegard

POSE = CameraPose(
    np.array([0.0, -5.0, 3.0]), math.radians(90), math.radians(-25), head=HeadKinematics("pan-tilt")
)


def truth(k: int, off_deg: float) -> SimTruth:
    """A target at (0, 1) m, 0.4 m tall, and the head `off_deg` to the right of its middle."""
    pan, tilt = (float(a) for a in POSE.gaze_angles(np.array([0.0, 1.0, 0.2])))
    return SimTruth(
        t_capture_ns=k * 40_000_000,
        seq=k,
        target_xy_m=(0.0, 1.0),
        target_velocity_m_s=(0.0, 0.0),
        target_height_m=0.4,
        head=HeadPose(pan_rad=pan + math.radians(off_deg), tilt_rad=tilt),
    )


def test_gaze_error_is_the_angle_to_the_targets_middle() -> None:
    errors = np.degrees(gaze_errors_rad([truth(0, 0.0), truth(1, 2.0)], POSE))
    assert errors[0] == pytest.approx(0.0, abs=1e-9)
    assert errors[1] == pytest.approx(2.0 * math.cos(math.radians(15)), rel=0.1)  # pan at a tilt


def test_acquisition_needs_a_run_in_the_fovea() -> None:
    fovea = math.radians(3.0)
    errors = np.radians([5.0, 1.0, 5.0] + [1.0] * ACQUIRED_FRAMES + [4.0])
    assert acquisition_index(errors, fovea) == 3
    assert acquisition_index(np.radians([1.0] * (ACQUIRED_FRAMES - 1)), fovea) is None


def test_score_counts_from_acquisition() -> None:
    frames = [truth(k, 10.0) for k in range(5)] + [
        truth(k, 0.5 if k % 2 else 1.5) for k in range(5, 40)
    ]
    states = [
        GazeState(
            t_capture_ns=0, state="saccade", reason="candidate"
        ),  # before acquisition: not counted
        GazeState(t_capture_ns=30 * 40_000_000, state="saccade", reason="candidate"),
        GazeState(  # the target changed during that saccade: not another one
            t_capture_ns=31 * 40_000_000,
            state="saccade",
            previous="saccade",
            reason="operator's choice",
            target_id=2,
        ),
    ]
    estimates = [
        EstimatorState(
            t_capture_ns=k * 40_000_000,
            filter="imm",
            x=(0.0,),
            P=((1.0,),),
            ground_xy_m=(0.0, 1.0 + d),
        )
        for k, d in ((2, 5.0), (10, 0.3), (20, 0.4))
    ]
    result = score(LoopRecord(frames, states, [], estimates), POSE, 3.0)
    assert result["acquired_after_s"] == pytest.approx(5 * 0.04)
    assert result["fovea_fraction"] == 1.0
    assert result["saccades_after_acquisition"] == 1
    assert result["ground_rmse_m"] == pytest.approx(
        math.sqrt((0.3**2 + 0.4**2) / 2), abs=1e-4
    )  # rounded
    assert result["gaze_error_deg"]["rms"] == pytest.approx(
        math.sqrt((0.5**2 + 1.5**2) / 2), rel=0.1
    )


REACH = FieldOfRegard(
    POSE,
    (math.radians(-90), math.radians(90)),
    (math.radians(-50), math.radians(40)),
    (math.radians(-3), math.radians(-3)),  # widened by the fovea, as for scoring
    0.2,
)


def truth_at(k: int, xy_m: tuple[float, float], off_deg: float) -> SimTruth:
    """The target at `xy_m`, and the head `off_deg` above its middle, at the tilt limit if it
    cannot reach."""
    pan, tilt = (float(a) for a in POSE.gaze_angles(np.array([*xy_m, 0.2])))
    tilt = max(tilt + math.radians(off_deg), math.radians(-50))
    return SimTruth(
        t_capture_ns=k * 40_000_000,
        seq=k,
        target_xy_m=xy_m,
        target_velocity_m_s=(0.0, 0.0),
        target_height_m=0.4,
        head=HeadPose(pan_rad=pan, tilt_rad=tilt),
    )


def test_a_frame_is_reachable_when_the_head_can_foveate_it() -> None:
    # below the camera's foot the target needs a tilt of about -61°: 11° beyond the limit
    frames = [truth_at(0, (0.0, 1.0), 0.0), truth_at(1, (0.0, -4.8), 0.0)]
    assert reachable(frames, REACH).tolist() == [True, False]
    limit = POSE.centre_m[2] - 0.2  # the ground distance at which the tilt is 3° past its limit
    edge_y = -5.0 + limit / math.tan(math.radians(25 + 50 + 3))
    near = [truth_at(0, (0.0, edge_y + 0.02), 0.0), truth_at(1, (0.0, edge_y - 0.02), 0.0)]
    assert reachable(near, REACH).tolist() == [True, False]


def test_score_splits_the_frames_out_of_reach_from_the_rest() -> None:
    frames = (
        [truth_at(k, (0.0, 1.0), 0.0) for k in range(10)]
        + [truth_at(k, (0.0, -4.8), 0.0) for k in range(10, 20)]  # beyond the tilt limit
        + [truth_at(k, (0.0, 1.0), 4.0 if k % 2 else 0.0) for k in range(20, 30)]
    )
    record = LoopRecord(frames, [], [], [])
    result = score(record, POSE, 3.0, REACH)
    assert result["acquired_after_s"] == 0.0
    assert result["fovea_fraction"] == pytest.approx(15 / 30, abs=1e-4)
    assert result["out_of_reach_fraction"] == pytest.approx(10 / 30, abs=1e-4)
    assert result["fovea_fraction_reachable"] == pytest.approx(15 / 20, abs=1e-4)
    assert "out_of_reach_fraction" not in score(record, POSE, 3.0)
    # scored from acquisition: frames before it count in neither share
    late = [truth_at(k, (0.0, -4.8), 0.0) for k in range(5)] + [
        truth_at(k, (0.0, 1.0), 0.0) for k in range(5, 20)
    ]
    result = score(LoopRecord(late, [], [], []), POSE, 3.0, REACH)
    assert result["out_of_reach_fraction"] == 0.0
    assert result["fovea_fraction_reachable"] == 1.0


def test_latency_counts_the_first_write_of_each_capture() -> None:
    """Processing from the frame's arrival at vision (the sim -> vision transport, 2 ms here,
    is not gazed's); end to end from capture."""

    def written(capture: int, processing_ms: float) -> GazeDemand:
        t_sim = capture + 148_000_000
        t_arrival = t_sim + 2_000_000
        stamps = (
            ("sim", t_sim),
            ("vision.arrival", t_arrival),
            ("vision", t_arrival + 1),
            ("servo", t_arrival + round(processing_ms * 1e6)),
        )
        return GazeDemand(
            t_capture_ns=capture, stamps=stamps, kind="pursuit", pan_rad=0.0, tilt_rad=0.0
        )

    commands = [
        written(0, 10.0),
        written(0, 30.0),
        written(40_000_000, 12.0),
        written(80_000_000, 14.0),
    ]
    latency = latencies_ms(commands)
    assert latency["processing_p50"] == 12.0
    assert latency["end_to_end_p50"] == 162.0
    # vision took 1 ns, the rest of each first write's processing is the servo hop here
    assert latency["hops_p50"] == {"vision": 0.0, "servo": 12.0}


def test_servo_summary_of_a_run() -> None:
    def status(load: float | None, timeouts: int, lag_s: float | None) -> ServoStatus:
        return ServoStatus(
            t_capture_ns=1,
            protocol="pelco-d",
            port="/dev/ttyUSB0",
            link="connected",
            timeouts=timeouts,
            line_load=load,
            response_lag_s=lag_s,
        )

    summary = servo_summary([status(None, 2, None), status(0.5, 3, 0.08), status(0.9, 7, 0.09)])
    assert summary == {
        "line_load_mean": 0.7,
        "line_load_max": 0.9,
        "timeouts": 5,
        "response_lag_ms": 90.0,
    }
    assert servo_summary([])["line_load_mean"] is None


def test_ground_error_takes_the_capture_nearest_an_estimates_stamp() -> None:
    frames = [truth(k, 0.0) for k in range(10)]  # every 40 ms, the target at (0, 1) m

    def estimate(t_ns: int, y_m: float) -> EstimatorState:
        return EstimatorState(
            t_capture_ns=t_ns, filter="imm", x=(0.0,), P=((1.0,),), ground_xy_m=(0.0, y_m)
        )

    # vision moved the stamps by a few ms (its estimate of the camera's delay): still matched
    moved = [estimate(3 * 40_000_000 - 2_000_000, 1.3), estimate(6 * 40_000_000 + 3_000_000, 1.4)]
    assert ground_rmse_m(frames, moved) == pytest.approx(math.sqrt((0.3**2 + 0.4**2) / 2), abs=1e-4)
    # past the last capture by more than half an interval: no frame it was made from
    assert ground_rmse_m(frames, [estimate(9 * 40_000_000 + 30_000_000, 5.0)]) is None
