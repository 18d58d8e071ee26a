"""The digital head's camera in the vision process: each wide frame rendered at the head's pose
from odometry at its capture, held back by the frame delay; the detection reports that pose."""

from __future__ import annotations

import math
import time
from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import poll_until

from gazed import cli
from gazed.config import parse_rig
from gazed.geometry.camera import CameraModel
from gazed.messages import Odometry
from gazed.vision.digital_camera import (
    DigitalCamera,
    WideCapture,
    file_frame_count,
    open_digital_camera,
    wide_camera,
)
from gazed.vision.digital_view import DigitalView
from gazed.vision.frames import CapturedFrame
from gazed.vision.opencv_camera import OpenCvCamera
from gazed.vision.source import FrameSource, SourceError, SourceStatus
from gazed.vision.stage import VisionStage

MS = 1_000_000
RIG = """
[rig]
name = "digital"
[camera]
width_px = 160
height_px = 120
hfov_deg = 30
[servo]
protocol = "digital"
[wide]
source = "{source}"
width_px = 320
height_px = 240
fx_px = 300
distortion = [-0.1, 0.02, 0, 0, 0]
"""


class Frames(FrameSource):
    """Wide frames handed over by the test."""

    def __init__(self) -> None:
        self.waiting: list[CapturedFrame] = []
        self.connected = False

    @property
    def is_connected(self) -> bool:
        return self.connected

    def connect(self) -> None:
        self.connected = True

    def disconnect(self) -> None:
        self.connected = False

    def read(self) -> CapturedFrame | None:
        return self.waiting.pop(0) if self.waiting else None

    def status(self) -> SourceStatus:
        return SourceStatus("connected")


def wide_frame(t_ns: int, seq: int) -> CapturedFrame:
    rng = np.random.default_rng(seq)
    return CapturedFrame(rng.integers(0, 255, (240, 320), np.uint8), "gray8", t_ns, seq)


def odometry(t_ns: int, pan_deg: float, tilt_deg: float, rate_deg_s: float) -> Odometry:
    return Odometry(
        t_capture_ns=t_ns,
        stamps=(("servo", t_ns),),
        pan_rad=math.radians(pan_deg),
        tilt_rad=math.radians(tilt_deg),
        pan_rate_rad_s=math.radians(rate_deg_s),
        tilt_rate_rad_s=0.0,
    )


def setup(frame_delay_s: float = 0.0):
    rig = parse_rig(RIG.format(source="/absent.avi"))
    stage = VisionStage(rig, clock_ns=lambda: 0)
    view = DigitalView(wide_camera(rig.wide), CameraModel.from_section(rig.camera))
    clock = {"ns": 0}
    wide = Frames()
    camera = DigitalCamera(
        wide,
        view,
        stage.history.pose_at,
        frame_delay_s=frame_delay_s,
        clock_ns=lambda: clock["ns"],
    )
    camera.connect()
    return stage, view, clock, wide, camera


def test_the_view_is_rendered_at_the_odometry_pose_of_the_frames_capture():
    stage, view, clock, wide, camera = setup()
    for k in range(11):  # the head turning at 10°/s, read every 20 ms
        stage.add_odometry(odometry(k * 20 * MS, 0.2 * k, -1.0, 10.0), k * 20 * MS)
    frame = wide_frame(130 * MS, 1)
    wide.waiting.append(frame)
    clock["ns"] = 140 * MS
    rendered = camera.read()
    assert rendered is not None and rendered.t_capture_ns == frame.t_capture_ns
    expected = view.render(frame.pixels, math.radians(1.3), math.radians(-1.0))
    np.testing.assert_array_equal(rendered.pixels, expected)
    output = stage.process(rendered)
    assert output.detection is not None
    assert output.detection.head == rendered.head
    assert math.isclose(output.detection.head.pan_rad, math.radians(1.3), abs_tol=1e-12)


def test_frames_are_held_back_by_the_delay_and_need_a_pose():
    stage, _view, clock, wide, camera = setup(frame_delay_s=0.150)
    wide.waiting.append(wide_frame(100 * MS, 1))
    clock["ns"] = 120 * MS
    assert camera.read() is None
    assert camera.due_in_s() == pytest.approx(0.130)
    clock["ns"] = 250 * MS
    assert camera.read() is None  # due, but no odometry covers its capture
    assert camera.counters["wide_frames_without_pose"] == 1
    stage.add_odometry(odometry(90 * MS, 0.0, 0.0, 0.0), 250 * MS)
    stage.add_odometry(odometry(110 * MS, 0.0, 0.0, 0.0), 250 * MS)
    wide.waiting.append(wide_frame(200 * MS, 2))
    assert camera.read() is None
    clock["ns"] = 350 * MS
    assert camera.read() is None  # 200 ms: odometry ends at 110 ms
    assert camera.counters["wide_frames_without_pose"] == 2
    wide.waiting.append(wide_frame(405 * MS, 3))
    for t_ms in (390, 410, 430):
        stage.add_odometry(odometry(t_ms * MS, 0.0, 0.0, 0.0), 430 * MS)
    clock["ns"] = 560 * MS
    rendered = camera.read()
    assert rendered is not None and rendered.seq == 3


def test_a_digital_rig_whose_footage_is_absent_exits_2_naming_the_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rig_path = tmp_path / "rig.toml"
    rig_path.write_text(RIG.format(source="footage/absent.avi"))
    assert cli.main(["run", str(rig_path)]) == 2
    error = capsys.readouterr().err
    assert (
        "wide.source: no such file" in error and str(tmp_path / "footage" / "absent.avi") in error
    )


def test_a_file_plays_at_the_rigs_rate_not_its_containers(tmp_path: Path) -> None:
    path = tmp_path / "slow.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 2.0, (64, 48))
    for i in range(30):
        writer.write(np.full((48, 64, 3), 8 * i, np.uint8))
    writer.release()
    times_ns: list[int] = []
    source = OpenCvCamera(
        str(path),
        width_px=64,
        height_px=48,
        rate_hz=50.0,
        reopen_max_s=0.05,
        timeout_ms=2000.0,
        file_rate_hz=50.0,  # the container says 2 Hz: 0.5 s a frame
    )
    source.on_frame = lambda: times_ns.append(time.time_ns())
    with source:
        poll_until(lambda: len(times_ns) >= 11, 5.0)
    assert float(np.median(np.diff(times_ns[:11]))) < 0.2e9


def test_a_file_starts_at_its_start_frame_and_each_frame_is_numbered_by_its_index(
    tmp_path: Path,
) -> None:
    """Frame i of the file is grey 20·i; from start frame 8 of 12 the capture plays 8…11, then
    loops to 0…, each frame numbered by its index in the file."""
    path = tmp_path / "counted.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 7.0, (64, 48))
    for i in range(12):
        writer.write(np.full((48, 64, 3), 20 * i, np.uint8))
    writer.release()
    assert file_frame_count(str(path)) == 12
    source = WideCapture(
        str(path),
        start_frame=8,
        width_px=64,
        height_px=48,
        rate_hz=200.0,
        reopen_max_s=0.01,
        timeout_ms=2000.0,
        file_rate_hz=200.0,
    )
    taken: list[CapturedFrame] = []

    def take() -> bool:
        frame = source.read()
        if frame is not None:
            taken.append(frame)
        return len(taken) >= 10 and taken[-1].seq >= 9

    with source:
        poll_until(take, 5.0)
    indices = [f.seq for f in taken]
    assert indices == [round(float(f.pixels.mean()) / 20) for f in taken]
    assert 8 <= indices[0] <= 11 and min(indices) < 8  # the newest is taken: some are passed


def test_the_view_carries_its_footage_frame_and_a_start_past_the_end_is_refused(
    tmp_path: Path,
) -> None:
    stage, view, clock, wide, _ = setup()
    camera = DigitalCamera(
        wide,
        view,
        stage.history.pose_at,
        clock_ns=lambda: clock["ns"],
    )
    camera.connect()
    stage.add_odometry(odometry(0, 0.0, 0.0, 0.0), 0)
    stage.add_odometry(odometry(200 * MS, 0.0, 0.0, 0.0), 0)
    wide.waiting.append(wide_frame(100 * MS, 42))  # its index in the file (`WideCapture`)
    clock["ns"] = 150 * MS
    rendered = camera.read()
    assert rendered is not None and rendered.seq == 42
    path = tmp_path / "short.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 7.0, (320, 240))
    for _ in range(3):
        writer.write(np.zeros((240, 320, 3), np.uint8))
    writer.release()
    rig = parse_rig(RIG.format(source=path) + "start_frame = 3\n")
    with pytest.raises(SourceError, match=r"start_frame = 3: .* has 3 frames"):
        open_digital_camera(rig, stage.history.pose_at)
