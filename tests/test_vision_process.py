"""The vision process: frames and odometry in, detections and candidates out, bad input dropped
and counted while it keeps going — driven step by step in-process, and as the real
`python -m services.vision` subprocess on its own bus (ports 17600-17699)."""

from __future__ import annotations

import math
from collections import deque
from pathlib import Path

import cv2
import numpy as np
import pytest
import zenoh
from conftest import poll_until, start_service, unique_rig_name, write_rig
from vision_scene import CAMERA_BODY, RATE_HZ, T0_NS, captured, odometry, scene

from gazed.bus import Bus
from gazed.config import load_rig
from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.messages import Candidates, Detection, FrameHeader, HeadPose, Health
from gazed.topics import SERVO_ODOMETRY, SIM_FRAME, VISION_CANDIDATES, VISION_DETECTION, health
from gazed.vision.frames import CapturedFrame
from gazed.vision.source import FrameSource, SourceStatus
from gazed.vision.synthetic import SyntheticScene
from services.runtime import Now
from services.vision import VisionService

RIG_BODY = (
    CAMERA_BODY
    + """
[vision]
detector = "flow"
fovea_deg = 10
"""
)


class ScriptedSource(FrameSource):
    """Hands out a prepared list of frames, one per read."""

    description = "scripted frames"

    def __init__(self, frames: list[CapturedFrame]) -> None:
        self.frames = deque(frames)
        self.connected = False

    @property
    def is_connected(self) -> bool:
        return self.connected

    def connect(self) -> None:
        self.connected = True

    def disconnect(self) -> None:
        self.connected = False

    def read(self) -> CapturedFrame | None:
        self._require_connected()
        return self.frames.popleft() if self.frames else None

    def status(self) -> SourceStatus:
        return SourceStatus("connected", frames=0)


def test_service_steps_publish_detections_and_count_bad_frames(tmp_path: Path) -> None:
    rig = load_rig(write_rig(tmp_path, RIG_BODY, port=17601))
    frames = [scene().render(i / RATE_HZ, i) for i in range(16)]
    script = [captured(image, truth, i) for i, (image, truth) in enumerate(frames[:8])]
    script += [
        CapturedFrame(np.zeros((120, 160, 3), np.uint8), "bgr8", T0_NS + 10**9, 100),
        CapturedFrame(np.zeros((240, 320, 3), np.float32), "bgr8", T0_NS + 10**9, 101),
        CapturedFrame(np.zeros((0, 0, 3), np.uint8), "bgr8", T0_NS + 10**9, 102),
        CapturedFrame(np.zeros((240, 320, 3), np.uint8), "gray8", T0_NS + 10**9, 103),
        captured(frames[3][0], frames[3][1], 104),  # older than the last frame processed
    ]
    script += [captured(image, truth, i) for i, (image, truth) in enumerate(frames[8:], start=8)]
    with Bus(rig, "test", router=True) as bus, Bus(rig, "listener") as listener:
        detections = listener.subscribe(VISION_DETECTION)
        candidates = listener.subscribe(VISION_CANDIDATES)
        service = VisionService(rig, bus, source=ScriptedSource(script))
        poll_until(lambda: service.detections.matched(), 5.0)
        for k in range(int(16 / RATE_HZ * 100) + 2):  # odometry at 100 Hz over the frames
            service.stage.history.add(odometry(k / 100.0))
        steps = 0
        while service.step(Now.read()) == 0.0:
            steps += 1
        got: list[Detection] = []
        poll_until(lambda: got.extend(detections.take()) or len(got) >= 16, 10.0)
        poll_until(candidates.take, 5.0)
        report = service.health()
        service.close()
    assert steps == len(script)
    assert [d.seq for d in got] == list(range(16))
    for reason in ("size", "dtype", "empty", "channels", "stale"):
        assert report.counters[f"dropped:{reason}"] == 1
    assert report.counters["frames"] == len(script)
    assert report.notes["compensation"] == "on"
    assert "older" in report.notes["last_drop"] or "not newer" in report.notes["last_drop"]
    # the pose at capture time is interpolated from odometry; compensation from frame 1 on
    for detection, (_, truth) in zip(got, frames, strict=True):
        assert detection.head is not None
        assert detection.head.pan_rad == pytest.approx(truth.head.pan_rad, abs=1e-9)
        assert detection.stamps[0] == ("sim", 1) and detection.stamps[1][0] == "vision"
    assert all(d.compensated for d in got[1:])
    found = [d for d in got[3:] if d.found]
    assert len(found) >= 10
    errors = [
        math.hypot(d.u_px - t.u_px, d.v_px - t.v_px) for d in found for _, t in [frames[d.seq]]
    ]
    assert np.median(errors) <= 2.0


@pytest.mark.e2e
def test_vision_process_end_to_end(tmp_path: Path) -> None:
    path = write_rig(tmp_path, RIG_BODY, name=unique_rig_name("vision"), port=17602)
    rig = load_rig(path)
    frames = [scene().render(i / RATE_HZ, i) for i in range(24)]
    with Bus(rig, "test", router=True) as bus:
        detections = bus.subscribe(VISION_DETECTION)
        candidates = bus.subscribe(VISION_CANDIDATES)
        healths = bus.subscribe(health("vision"))
        frame_out = bus.publisher(SIM_FRAME)
        odometry_out = bus.publisher(SERVO_ODOMETRY)
        child = start_service("vision", path)
        try:
            poll_until(lambda: "vision" in bus.alive(0.5), 30.0)
            poll_until(frame_out.matched, 10.0)
            got: list[Detection] = []
            sent_odometry = 0

            def send(i: int) -> None:
                nonlocal sent_odometry
                image, truth = frames[i]
                while sent_odometry <= round(truth.t_s * 100) + 1:
                    odometry_out.put(odometry(sent_odometry / 100.0))
                    sent_odometry += 1
                header = FrameHeader(
                    t_capture_ns=T0_NS + round(truth.t_s * 1e9),
                    seq=i,
                    width=320,
                    height=240,
                    stamps=(("sim", T0_NS + round(truth.t_s * 1e9) + 1000),),
                )
                # frames are sent with congestion control DROP: one lost under load is sent again
                # (were it only late, the repeat is dropped as stale)
                for _ in range(5):
                    frame_out.put_frame(header, image)
                    try:
                        poll_until(
                            lambda: (
                                got.extend(detections.take()) or (got[-1:] and got[-1].seq == i)
                            ),
                            2.0,
                        )
                        return
                    except AssertionError:
                        continue
                raise AssertionError(f"no detection for frame {i}")

            for i in range(12):
                send(i)

            # bad input: a header that lies about the size, a frame of the wrong size,
            # garbage odometry; none of it may stop the process
            def send_bad_input() -> None:
                key = SIM_FRAME.key(rig.name)
                lying = FrameHeader(t_capture_ns=T0_NS + 10**9, seq=500, width=320, height=240)
                bus.session.put(key, b"\0" * 1000, attachment=lying.to_json())
                small = FrameHeader(t_capture_ns=T0_NS + 10**9, seq=501, width=160, height=120)
                frame_out.put_frame(small, np.zeros((120, 160, 3), np.uint8))
                bus.session.put(
                    SERVO_ODOMETRY.key(rig.name),
                    b'{"t_capture_ns": "soon"}',
                    encoding=zenoh.Encoding("application/json").with_schema("gazed.Odometry/2"),
                )

            send_bad_input()
            for i in range(12, 24):
                send(i)

            def counted() -> Health | None:
                for report in healths.take():
                    c = report.counters
                    if c.get("dropped:size", 0) >= 1 and c.get("malformed", 0) >= 2:
                        return report
                    send_bad_input()  # what was dropped on the way (congestion) goes again
                return None

            report = poll_until(counted, 20.0)
            published_candidates: list[Candidates] = candidates.take()
        finally:
            child.terminate()
            output, _ = child.communicate(timeout=20)
    assert child.returncode == 0, output
    assert [d.seq for d in got] == list(range(24))
    assert report.notes["compensation"] == "on"
    assert report.notes["source"] == "sim (connected)"
    found = [d for d in got if d.found]
    assert len(found) >= 15
    for d in found:
        _, truth = frames[d.seq]
        assert d.head is not None and d.head.pan_rad == pytest.approx(truth.head.pan_rad, abs=1e-6)
        # the frame's publication, its arrival here, the detection's publication, in order
        assert [stage for stage, _ in d.stamps] == ["sim", "vision.arrival", "vision"]
        assert d.t_capture_ns <= d.stamps[0][1] <= d.stamps[1][1] <= d.stamps[2][1]
    errors = [
        math.hypot(d.u_px - frames[d.seq][1].u_px, d.v_px - frames[d.seq][1].v_px) for d in found
    ]
    assert np.median(errors) <= 2.0
    assert published_candidates and all(c.width_px == 320 for c in published_candidates)


@pytest.mark.e2e
def test_vision_process_reads_a_video_file_as_its_camera(tmp_path: Path) -> None:
    """An OpenCV source: the file is paced like a camera, loops when it ends (reported as a
    reopen), and its frames are detected; no odometry, so compensation is off."""
    clip = tmp_path / "walker.avi"
    camera = CameraModel.from_fov(320, 240, math.radians(60))
    walker = SyntheticScene(
        camera,
        HeadKinematics(),
        lambda t: HeadPose(pan_rad=0.0, tilt_rad=0.0),
        lambda t: (-0.1 + 0.15 * t, 0.0),
        seed=33,
        field_rad=0.8,
    )
    writer = cv2.VideoWriter(str(clip), cv2.VideoWriter_fourcc(*"MJPG"), 25.0, (320, 240))
    for i in range(20):
        writer.write(walker.render(i / 25.0, i)[0])
    writer.release()
    body = RIG_BODY.replace('source = "sim"', f'source = "{clip}"\nreopen_max_s = 0.2')
    body = body.replace('detector = "flow"', 'detector = "pyramid"')
    path = write_rig(tmp_path, body, name=unique_rig_name("file"), port=17603)
    rig = load_rig(path)
    with Bus(rig, "test", router=True) as bus:
        detections = bus.subscribe(VISION_DETECTION)
        healths = bus.subscribe(health("vision"))
        child = start_service("vision", path)
        try:
            got: list[Detection] = []
            poll_until(
                lambda: got.extend(detections.take()) or sum(d.found for d in got) >= 10, 30.0
            )

            def looped() -> Health | None:
                for report in healths.take():
                    if report.counters.get("source_reopens", 0) >= 1:
                        return report
                return None

            report = poll_until(looped, 20.0)
        finally:
            child.terminate()
            output, _ = child.communicate(timeout=20)
    assert child.returncode == 0, output
    assert not any(d.compensated for d in got)
    assert all(d.head is None and d.width_px == 320 for d in got)
    assert report.notes["compensation"] == "off (no odometry at the frames' capture times)"
    assert report.notes.get("source_error") == "file ended"
    assert report.counters["found"] >= 10
