"""The capture stamp moved from arrival to exposure: by the rig's told delay with the online
estimate off, by the estimate once the head has moved (a textured scene panned back and forth,
frames stamped 120 ms after exposure); a digital head's views pass as they are."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from gazed.config import CameraSection
from gazed.messages import HeadPose, Odometry
from gazed.vision.capture_stamp import CaptureStampCorrection
from gazed.vision.frames import CapturedFrame

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
