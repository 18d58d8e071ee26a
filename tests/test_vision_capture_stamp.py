"""The capture stamp moved from arrival to exposure: by the rig's told delay with the online
estimate off, by the estimate once the head has moved (a textured scene panned back and forth,
frames stamped 120 ms after exposure); a digital head's views pass as they are. Until the
estimate has its first fit, a frame seen while the head moved has no known pose."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import write_rig
from vision_scene import CAMERA_BODY, RATE_HZ, captured, odometry, scene

from gazed.config import CameraSection, load_rig
from gazed.messages import HeadPose, Odometry
from gazed.vision.capture_stamp import CaptureStampCorrection
from gazed.vision.frames import CapturedFrame
from gazed.vision.stage import VisionStage

T0_NS = 1_700_000_000_000_000_000
PERIOD_NS = 40_000_000
PX_PER_RAD = 500.0


def frame(k: int, pixels: np.ndarray, t_ns: int, head: HeadPose | None = None) -> CapturedFrame:
    return CapturedFrame(pixels, "gray8", t_ns, k, head=head)


def test_the_told_delay_with_the_estimate_off_and_a_digital_view_untouched() -> None:
    camera = CameraSection(width_px=64, height_px=48, delay_ms=100.0, delay_estimate=False)
    correction = CaptureStampCorrection(camera)
    gray = np.zeros((48, 64), np.uint8)
    assert correction.frame(frame(0, gray, T0_NS), gray).t_capture_ns == T0_NS - 100_000_000
    view = frame(1, gray, T0_NS + PERIOD_NS, head=HeadPose(pan_rad=0.0, tilt_rad=0.0))
    assert correction.frame(view, gray) is view
    assert "online estimate off" in correction.note()


def test_the_online_estimate_finds_the_delay_of_a_panning_camera() -> None:
    delay_ns = 120_000_000
    texture = cv2.GaussianBlur(
        np.random.default_rng(2).integers(0, 256, (300, 1400)).astype(np.uint8), (0, 0), 2.0
    )

    def pan_rad(t_s: float) -> float:
        return 0.35 * math.sin(2.0 * t_s) + 0.15 * math.sin(5.0 * t_s)

    correction = CaptureStampCorrection(
        CameraSection(width_px=320, height_px=240, delay_estimate=True)
    )
    for j in range(800):  # odometry at 100 Hz over 8 s
        t_ns = T0_NS + j * 10_000_000
        correction.add_odometry(Odometry(t_capture_ns=t_ns, pan_rad=pan_rad(j * 0.01), tilt_rad=0))
    corrected = []
    for k in range(150):  # frames exposed at 25 Hz from 0.5 s, stamped on arrival
        exposure_s = 0.5 + k * PERIOD_NS * 1e-9
        u0 = round(540 + PX_PER_RAD * pan_rad(exposure_s))
        gray = np.ascontiguousarray(texture[30:270, u0 : u0 + 320])
        arrival_ns = T0_NS + round(exposure_s * 1e9) + delay_ns
        corrected.append(
            arrival_ns - correction.frame(frame(k, gray, arrival_ns), gray).t_capture_ns
        )
    assert correction.estimator.fits >= 3
    assert corrected[-1] * 1e-9 == pytest.approx(delay_ns * 1e-9, abs=0.02)
    assert "online" in correction.note()
    times = correction.stage_ms()
    assert times["camera_delay"] == pytest.approx(corrected[-1] * 1e-6, abs=0.01)
    assert times["camera_delay_shift_median"] > 0 and times["camera_delay_fit_median"] > 0


def test_until_the_first_fit_a_moving_head_s_pose_is_unknown() -> None:
    """The delay not yet estimated, a frame's exposure may lie anywhere in the lag grid before
    its arrival: its pose is known only where the head stood still over all of it."""
    correction = CaptureStampCorrection(
        CameraSection(width_px=64, height_px=48, delay_estimate=True)
    )
    gray = np.zeros((48, 64), np.uint8)

    def pan_rad(t_s: float) -> float:  # still for 3 s, then a 0.2 rad saccade
        return 0.1 + 0.2 * min(max((t_s - 3.0) / 0.2, 0.0), 1.0)

    for j in range(600):  # odometry at 100 Hz over 6 s
        correction.add_odometry(
            Odometry(t_capture_ns=T0_NS + j * 10_000_000, pan_rad=pan_rad(j * 0.01), tilt_rad=0)
        )
    known = {}
    for arrival_s in (0.5, 2.5, 2.95, 3.1, 4.0, 4.3, 5.5):
        correction.frame(frame(0, gray, T0_NS + round(arrival_s * 1e9)), gray)
        known[arrival_s] = correction.pose_known
    # a frame processed after the saccade began but arriving before it: exposed still
    assert known == {
        0.5: False, 2.5: True, 2.95: True, 3.1: False, 4.0: False, 4.3: True, 5.5: True
    }  # fmt: skip
    told = CaptureStampCorrection(CameraSection(width_px=64, height_px=48, delay_ms=100.0))
    told.add_odometry(Odometry(t_capture_ns=T0_NS, pan_rad=0.0, tilt_rad=0.0))
    told.frame(frame(0, gray, T0_NS + 3_100_000_000), gray)
    assert told.pose_known


def test_the_vision_stage_gives_no_pose_to_a_frame_whose_exposure_is_unknown(
    tmp_path: Path,
) -> None:
    """A panning head and no delay estimate yet: the detection carries no head pose, so the
    estimator and the gaze leave it out; told the delay, it carries one."""
    poses = []
    for body in ("delay_estimate = true\n", "delay_estimate = false\n"):
        rig = load_rig(write_rig(tmp_path, CAMERA_BODY + body))
        stage = VisionStage(rig, clock_ns=lambda: T0_NS)
        for k in range(200):
            stage.add_odometry(odometry(k / 100.0), T0_NS + 10**10)
        synthetic = scene()
        shown = [captured(*synthetic.render(i / RATE_HZ, i), i) for i in range(8)]
        detections = [stage.process(f).detection for f in shown]
        poses.append([d.head for d in detections if d is not None])
    estimating, told = poses
    assert estimating and all(head is None for head in estimating)
    assert told and all(head is not None for head in told)


def test_a_frame_whose_image_did_not_move_since_a_still_one_has_the_still_pose() -> None:
    """The head's first move begun but not yet in the image (the frames of the delay after it
    were exposed before it): a frame whose background stands where a still frame's did has
    that frame's pose, read where it arrived; once the image moves, the pose is unknown."""
    correction = CaptureStampCorrection(
        CameraSection(width_px=320, height_px=240, delay_estimate=True)
    )
    texture = cv2.GaussianBlur(
        np.random.default_rng(3).integers(0, 256, (240, 400)).astype(np.uint8), (0, 0), 2.0
    )

    def pan_rad(t_s: float) -> float:  # still for 3 s, then a 0.2 rad saccade
        return 0.1 + 0.2 * min(max((t_s - 3.0) / 0.2, 0.0), 1.0)

    for j in range(600):  # odometry at 100 Hz over 6 s
        correction.add_odometry(
            Odometry(t_capture_ns=T0_NS + j * 10_000_000, pan_rad=pan_rad(j * 0.01), tilt_rad=0)
        )
    still = np.ascontiguousarray(texture[:, 40:360])
    moved = np.ascontiguousarray(texture[:, 60:380])  # the background 20 px on
    seen = []
    for k, (arrival_s, gray) in enumerate(
        [(2.96, still), (3.04, still), (3.08, still), (3.12, still), (3.16, moved), (3.2, moved)]
    ):
        correction.frame(frame(k, gray, T0_NS + round(arrival_s * 1e9)), gray)
        seen.append((correction.pose_known, correction.pose_ns))
    still_ns = T0_NS + 2_960_000_000
    assert seen == [(True, None)] + [(True, still_ns)] * 3 + [(False, None)] * 2
