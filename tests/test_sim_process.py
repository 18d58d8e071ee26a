"""The `sim` process on the bus: frames after the visual latency stamped on arrival (the hidden
camera delay after their exposure), truth at every exposure, the head's pty where the rig's
[servo] port says."""

from __future__ import annotations

import signal
import subprocess
from pathlib import Path

import pytest
from conftest import PYTHON, child_env, poll_until, write_rig

from gazed.bus import Bus
from gazed.config import load_rig
from gazed.messages import SimTruth
from gazed.topics import SIM_FRAME, SIM_TRUTH
from gazed.wakeup import Wakeup

pytestmark = pytest.mark.e2e  # every test here starts the real processes


@pytest.mark.parametrize("camera_delay_ms", [0, 80])
def test_frames_truth_and_the_head_port(tmp_path: Path, camera_delay_ms: int) -> None:
    port = tmp_path / "head"
    body = (
        f'[servo]\nprotocol = "visca"\nport = "{port}"\n\n'
        "[camera]\nwidth_px = 320\nheight_px = 240\nrate_hz = 25\n\n"
        '[sim]\ntrajectory = "oval"\nvisual_latency_ms = 120\n'
        f"camera_delay_ms = {camera_delay_ms}\n"
        "camera_xyz_m = [0.0, -4.0, 2.5]\ncamera_yaw_deg = 90.0\n"
    )
    rig_path = write_rig(tmp_path, body)
    rig = load_rig(rig_path)
    with Bus(rig, "test", router=True) as bus, Wakeup() as wakeup:
        bus.on_arrival(wakeup.notify)
        frames = bus.subscribe(SIM_FRAME)
        truths = bus.subscribe(SIM_TRUTH)
        sim = subprocess.Popen(
            [PYTHON, "-m", "services.sim", "--rig", str(rig_path)], env=child_env()
        )
        try:
            received = []
            truth: dict[int, SimTruth] = {}

            def enough() -> bool:
                wakeup.wait(0.1)
                if (frame := frames.latest()) is not None:
                    received.append(frame)
                truth.update({t.seq: t for t in truths.take()})
                return len(received) >= 10

            poll_until(enough, 30.0, interval_s=0.0)
            assert port.is_symlink() and Path(port.resolve()).exists()
        finally:
            sim.send_signal(signal.SIGTERM)
            assert sim.wait(timeout=20) == 0
    seqs = [f.header.seq for f in received]
    assert seqs == sorted(seqs) and len(set(seqs)) == len(seqs)
    for frame in received:
        header = frame.header
        assert frame.pixels.shape == (240, 320, 3)
        ((stage, published_ns),) = header.stamps
        assert stage == "sim"
        assert published_ns - header.t_capture_ns >= 120e6  # never before the visual latency
        exposure_ns = header.t_capture_ns - camera_delay_ms * 1_000_000  # stamped on arrival
        assert truth[header.seq].t_capture_ns == exposure_ns  # truth of the same instant
    speeds = [abs(complex(*t.target_velocity_m_s)) for t in truth.values()]
    assert min(speeds) >= 0.4 - 1e-9 and max(speeds) <= 0.5 + 1e-9  # the oval's speeds
    assert all(t.target_height_m == rig.sim.target_height_m for t in truth.values())
    assert not port.exists()  # the emulator removed its link on the way out
