"""Frame sources and frame checks: the OpenCV capture's lifecycle, newest-only delivery and
reopening with backoff; bad frames refused with a reason; the pipeline restarting on gaps."""

from __future__ import annotations

import itertools
import math
import threading
from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import poll_until

from gazed.backoff import Backoff
from gazed.config import VisionSection
from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.messages import ARRIVAL_STAGE
from gazed.vision.frames import CapturedFrame, FrameError, gray_frame
from gazed.vision.opencv_camera import OpenCvCamera, capture_target
from gazed.vision.pipeline import VisionPipeline
from gazed.vision.source import SourceNotConnectedError


def clip(
    path: Path, frames: int = 12, size: tuple[int, int] = (64, 48), fps: float = 200.0
) -> Path:
    """A small MJPG video whose frame i has mean grey level about 10 i."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, size)
    assert writer.isOpened()
    for i in range(frames):
        writer.write(np.full((size[1], size[0], 3), 10 * i, np.uint8))
    writer.release()
    return path


def camera(target: int | str, **overrides: float) -> OpenCvCamera:
    settings = {"reopen_max_s": 0.05, "timeout_ms": 2000.0} | overrides
    return OpenCvCamera(target, width_px=64, height_px=48, rate_hz=200.0, **settings)


def test_capture_target_parses_device_indices() -> None:
    assert capture_target("0") == 0
    assert capture_target("12") == 12
    assert capture_target("rtsp://cam.local/stream") == "rtsp://cam.local/stream"
    assert capture_target("/tmp/clip.mp4") == "/tmp/clip.mp4"


def test_read_before_connect_is_a_clear_error(tmp_path: Path) -> None:
    source = camera(str(clip(tmp_path / "a.avi")))
    with pytest.raises(SourceNotConnectedError, match="before connect"):
        source.read()


def test_file_frames_arrive_newest_only_and_the_file_loops(tmp_path: Path) -> None:
    arrived = threading.Event()
    source = camera(str(clip(tmp_path / "a.avi")), reopen_max_s=0.05)
    source.on_frame = arrived.set
    seen: list[CapturedFrame] = []
    with source:
        assert arrived.wait(10.0)

        def looped() -> bool:
            frame = source.read()
            if frame is not None:
                seen.append(frame)
            return source.status().reopens >= 2 and len(seen) >= 3

        poll_until(looped, 20.0, interval_s=0.002)
        status = source.status()
    assert not source.is_connected
    assert status.last_error == "file ended"
    assert status.frames > 12  # the 12-frame file was read more than once
    seqs = [f.seq for f in seen]
    assert seqs == sorted(set(seqs))  # each frame at most once, in order
    assert all(f.pixels.shape == (48, 64, 3) and f.encoding == "bgr8" for f in seen)
    assert all(b.t_capture_ns >= a.t_capture_ns for a, b in itertools.pairwise(seen))
    # read() returned it here: its arrival at vision is its capture as far as gazed can see
    assert all(f.stamps == ((ARRIVAL_STAGE, f.t_capture_ns),) for f in seen)


def test_unopenable_source_reports_down_and_keeps_retrying(tmp_path: Path) -> None:
    source = camera(str(tmp_path / "missing.mp4"))
    with source:
        poll_until(lambda: source.status().reopens >= 3, 20.0)
        assert source.read() is None
        status = source.status()
    assert status.link == "down"
    assert "cannot open" in (status.last_error or "")
    source.disconnect()  # twice is fine


def test_backoff_doubles_to_its_limit_and_resets() -> None:
    backoff = Backoff(0.5, 3.0)
    assert [backoff.next_delay_s() for _ in range(5)] == [0.5, 1.0, 2.0, 3.0, 3.0]
    backoff.reset()
    assert backoff.next_delay_s() == 0.5


def frame(pixels: np.ndarray, encoding: str = "bgr8") -> CapturedFrame:
    return CapturedFrame(pixels, encoding, t_capture_ns=1, seq=7)


@pytest.mark.parametrize(
    ("pixels", "encoding", "reason"),
    [
        (np.zeros((0, 0, 3), np.uint8), "bgr8", "empty"),
        (np.zeros((48, 64, 3), np.float32), "bgr8", "dtype"),
        (np.zeros((48, 64, 3), np.uint16), "bgr8", "dtype"),
        (np.zeros((40, 64, 3), np.uint8), "bgr8", "size"),
        (np.zeros((48, 64, 4), np.uint8), "bgr8", "channels"),
        (np.zeros((48, 64, 3), np.uint8), "gray8", "channels"),
        (np.zeros((48, 64), np.uint8), "rgb8", "channels"),
        (np.zeros((48, 64, 3), np.uint8), "yuv422", "encoding"),
    ],
)
def test_bad_frames_are_refused_with_a_reason(
    pixels: np.ndarray, encoding: str, reason: str
) -> None:
    with pytest.raises(FrameError) as caught:
        gray_frame(frame(pixels, encoding), 64, 48)
    assert caught.value.reason == reason
    assert "frame 7" in str(caught.value)


def test_good_frames_become_grey() -> None:
    rgb = np.random.default_rng(0).integers(0, 256, (48, 64, 3), dtype=np.uint8)
    np.testing.assert_array_equal(
        gray_frame(frame(rgb, "rgb8"), 64, 48), cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)
    )
    np.testing.assert_array_equal(
        gray_frame(frame(rgb, "bgr8"), 64, 48), cv2.cvtColor(rgb, cv2.COLOR_BGR2GRAY)
    )
    gray = rgb[:, :, 0]  # not contiguous
    converted = gray_frame(frame(gray, "gray8"), 64, 48)
    assert converted.flags.c_contiguous
    np.testing.assert_array_equal(converted, gray)


def test_pipeline_restarts_on_gaps_and_time_going_backwards() -> None:
    cam = CameraModel.from_fov(64, 48, math.radians(60))
    pipeline = VisionPipeline(
        cam, HeadKinematics(), VisionSection(frame_gap_max_ms=100.0), "pyramid"
    )
    gray = np.random.default_rng(1).integers(0, 256, (48, 64), dtype=np.uint8)
    t_ns = 10**9
    for dt_ms in (40, 40, 40):  # a normal stream
        t_ns += dt_ms * 10**6
        pipeline.process(gray, t_ns, None)
    assert pipeline.restarts == 0
    pipeline.process(gray, t_ns + 250 * 10**6, None)  # a 250 ms gap
    pipeline.process(gray, t_ns, None)  # back in time
    assert pipeline.restarts == 2
