"""The vision stage without a bus: stale and malformed frames dropped with their reason, the
gaze state choosing between edge, detection with candidates and detection alone, a result that
is not finite dropped, odometry from the future refused, and the health figures."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from conftest import write_rig
from vision_scene import CAMERA_BODY, RATE_HZ, T0_NS, captured, odometry, scene

from gazed.config import load_rig
from gazed.vision.detector import DetectorOutput, FramePair
from gazed.vision.frames import CapturedFrame, FrameError, FrameIntake
from gazed.vision.stage import VisionStage

STAMP_NS = 42


def frames(count: int) -> list[CapturedFrame]:
    synthetic = scene()
    return [captured(*synthetic.render(i / RATE_HZ, i), i) for i in range(count)]


def stage_for(tmp_path: Path, body: str = "") -> VisionStage:
    stage = VisionStage(
        load_rig(write_rig(tmp_path, CAMERA_BODY + body)), clock_ns=lambda: STAMP_NS
    )
    for k in range(100):  # odometry at 100 Hz over the first second
        stage.add_odometry(odometry(k / 100.0), T0_NS + 10**9)
    return stage


def test_the_intake_drops_stale_and_malformed_frames_with_their_reason() -> None:
    intake = FrameIntake(320, 240)
    good = CapturedFrame(np.zeros((240, 320, 3), np.uint8), "bgr8", T0_NS, 1)
    assert intake.take(good).shape == (240, 320)
    bad = CapturedFrame(np.zeros((120, 160, 3), np.uint8), "bgr8", T0_NS + 2, 2)
    with pytest.raises(FrameError) as refused:
        intake.take(bad)
    assert refused.value.reason == "size"
    later = CapturedFrame(good.pixels, "bgr8", T0_NS + 1, 3)  # older than the bad one: taken
    assert intake.take(later).shape == (240, 320)
    for t_ns in (T0_NS + 1, T0_NS):
        with pytest.raises(FrameError) as refused:
            intake.take(CapturedFrame(good.pixels, "bgr8", t_ns, 4))
        assert refused.value.reason == "stale"


def test_the_gaze_state_chooses_what_a_frame_yields(tmp_path: Path) -> None:
    stage = stage_for(tmp_path)
    stream = frames(6)
    first = stage.process(stream[0])  # searching (no gaze state yet): detection and candidates
    assert first.detection is not None and first.regions is not None and first.edge is None
    candidates = stage.candidates(first)
    assert candidates is not None
    assert candidates.stamps == first.detection.stamps == (("sim", 1), ("vision", STAMP_NS))
    assert candidates.seq == 0 and candidates.head == first.detection.head
    for state, frame in zip(("pursuit", "saccade"), stream[1:3], strict=True):
        stage.gaze_state = state
        output = stage.process(frame)
        assert output.detection is not None and output.regions is None
        assert stage.candidates(output) is None
    stage.gaze_state = "trace"
    traced = stage.process(stream[3])
    assert traced.edge is not None and traced.detection is None and traced.regions is None
    assert traced.edge.stamps[-1] == ("vision", STAMP_NS) and traced.edge.head is not None
    stage.gaze_state = "search"
    assert stage.process(stream[4]).regions is not None
    assert stage.counters["frames"] == 5 and stage.compensation_note() == "on"
    assert set(stage.times_ms()) == {"detector_median", "detector_max", "candidates_median"}


def test_candidates_off_in_the_rig_give_none(tmp_path: Path) -> None:
    stage = stage_for(tmp_path, "\n[vision]\ncandidates = false\ncompensate_ego_motion = false\n")
    output = stage.process(frames(1)[0])
    assert output.detection is not None and stage.candidates(output) is None
    assert stage.compensation_note().startswith("off ([vision]")
    assert set(stage.times_ms()) == {"detector_median", "detector_max"}


class NotFinite:
    name = "flow"
    needs_energy = False

    def detect(self, pair: FramePair) -> DetectorOutput:
        return DetectorOutput(found=True, u_px=math.nan, v_px=1.0)

    def reset(self) -> None:
        pass


def test_a_result_that_is_not_finite_is_dropped_and_counted(tmp_path: Path) -> None:
    stage = stage_for(tmp_path)
    stage.pipeline.detector = NotFinite()
    output = stage.process(frames(1)[0])
    assert output.detection is None and output.regions is None
    assert stage.counters["dropped:nonfinite"] == 1
    assert stage.compensation_note() == "no frame yet"
    assert "not finite" in (stage.last_drop or "")


def test_odometry_from_the_future_is_refused(tmp_path: Path) -> None:
    stage = stage_for(tmp_path)
    ahead = odometry(5.0)  # stamped four seconds after "now"
    stage.add_odometry(ahead, T0_NS + 10**9)
    assert stage.counters["dropped:odometry_from_the_future"] == 1
    assert stage.history.pose_at(ahead.t_capture_ns) is None
    assert stage.last_drop is not None and "ahead of now" in stage.last_drop


def test_a_told_camera_delay_moves_the_capture_stamp_before_the_pose_is_looked_up(
    tmp_path: Path,
) -> None:
    stage = VisionStage(
        load_rig(write_rig(tmp_path, CAMERA_BODY + "delay_ms = 100\ndelay_estimate = false\n")),
        clock_ns=lambda: STAMP_NS,
    )
    for k in range(100):
        stage.add_odometry(odometry(k / 100.0), T0_NS + 10**9)
    frame = frames(6)[5]
    detection = stage.process(frame).detection
    assert detection is not None
    assert detection.t_capture_ns == frame.t_capture_ns - 100_000_000
    assert detection.delay_ms == 100.0  # the estimator re-times its tracks when it changes
    assert detection.head == stage.history.pose_at(detection.t_capture_ns)
    assert detection.head != stage.history.pose_at(frame.t_capture_ns)
