"""ONVIF end to end. The real `servo` process drives ipycam, a virtual ONVIF camera nobody here
wrote, over ONVIF on loopback while its MJPEG stream is read: the servo's odometry follows the
position ipycam reports, in position and in speed mode, and it parks on SIGTERM. The whole loop
(`gazed run`) follows walkers in the PETS footage through ipycam's digital PTZ and stream. And
the whole loop runs on the sim ONVIF rig (the emulated camera) and holds the target in the
fovea.

ipycam needs opencv-python, which clashes with the headless build gazed uses; CI installs it
next to it without its dependencies: `pip install --no-deps ipycam==1.3.0`.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import cv2
import pytest
import tomlkit
from conftest import REPO, RunningSupervisor, poll_until, start_service
from onvif_support import (
    LOOP_RANGE_DEG,
    ipycam_installed,
    ipycam_position_deg,
    ipycam_rig,
    loop_rig,
    running_ipycam,
)
from servo_link_support import demand

from gazed.bus import Bus
from gazed.config import load_rig
from gazed.eval.loop_metrics import LoopRecord, score
from gazed.eval.private_rig import private_rig
from gazed.geometry.pose import CameraPose
from gazed.topics import (
    ESTIMATOR_STATE,
    GAZE_DEMAND,
    GAZE_STATE,
    SERVO_COMMAND,
    SERVO_ODOMETRY,
    SERVO_STATUS,
    SIM_TRUTH,
)

pytestmark = pytest.mark.e2e

RUN_S = 12.0


@pytest.fixture
def ipycam(shared_data: Path, tmp_path: Path):
    """ipycam on the shared footage (`running_ipycam`): its port, a client, its profile."""
    if not ipycam_installed():
        pytest.skip("ipycam is not installed (CI: pip install --no-deps ipycam==1.3.0)")
    with running_ipycam(shared_data / "video" / "vtest_480x360.avi", tmp_path) as camera:
        yield camera


@pytest.mark.parametrize("mode", ["position", "speed"])
def test_the_servo_drives_ipycam_and_its_odometry_follows_ipycams_position(
    ipycam, tmp_path: Path, mode: str
) -> None:
    port, client, token = ipycam
    rig_path = ipycam_rig(tmp_path, port, mode)
    rig = load_rig(rig_path)
    stream = cv2.VideoCapture(rig.camera.source)
    with Bus(rig, "test", router=True) as bus:
        demands = bus.publisher(GAZE_DEMAND)
        odometry = bus.subscribe(SERVO_ODOMETRY)
        statuses = bus.subscribe(SERVO_STATUS)
        servo = start_service("servo", rig_path)
        newest: list = []

        def reached(pan_deg: float, tilt_deg: float) -> bool:
            demands.put(demand(pan_deg, tilt_deg))
            newest.extend(odometry.take())
            time.sleep(0.05)
            return (
                len(newest) >= 3
                and all(  # there, and at rest
                    abs(math.degrees(r.pan_rad) - pan_deg) < 0.5
                    and abs(math.degrees(r.tilt_rad) - tilt_deg) < 0.5
                    and abs(math.degrees(r.pan_rate_rad_s)) < 0.5
                    for r in newest[-3:]
                )
            )

        try:
            for target in ((10.0, -5.0), (-12.0, 8.0)):
                poll_until(lambda t=target: reached(*t), 20.0, interval_s=0.0)
                time.sleep(0.3)  # at rest: ipycam's report and the odometry agree
                newest.extend(odometry.take())
                seen = ipycam_position_deg(client, token)
                last = newest[-1]
                assert seen == pytest.approx(target, abs=0.6)
                assert (math.degrees(last.pan_rad), math.degrees(last.tilt_rad)) == pytest.approx(
                    seen, abs=0.3
                )
                ok, frame = stream.read()  # the camera's stream is read meanwhile
                assert ok and frame.shape == (360, 480, 3)
        finally:
            servo.terminate()
            out, _ = servo.communicate(timeout=20)
            stream.release()
        assert servo.returncode == 0, out
        status = [s for s in statuses.take() if s.link == "connected"][-1]
        assert status.errors == 0, status.last_error
    parked = ipycam_position_deg(client, token)
    assert parked == pytest.approx(rig.head.park_rad, abs=0.6)


def test_the_whole_loop_follows_a_walker_through_ipycam(ipycam, tmp_path: Path) -> None:
    port, client, token = ipycam
    supervisor = RunningSupervisor(loop_rig(tmp_path, port), tmp_path)
    states = supervisor.bus.subscribe(GAZE_STATE, capacity=10000)
    odometry = supervisor.bus.subscribe(SERVO_ODOMETRY, capacity=100000)
    seen_states, readings = [], []
    try:
        supervisor.wait_ready(60.0)
        started = time.monotonic()
        while time.monotonic() - started < 25.0:
            supervisor.wakeup.wait(0.5)
            seen_states.extend(states.take())
            readings.extend(odometry.take())
        ended_ns = time.time_ns()
    finally:
        code = supervisor.stop()
    assert code == 0
    # states are published on each change: the time in pursuit from the first acquisition on
    changes = [(s.t_capture_ns, s.state) for s in seen_states]
    first = next(t for t, state in changes if state == "pursuit")
    spans = zip(changes, [*changes[1:], (ended_ns, "")], strict=True)
    pursuing_s = sum((b - a) / 1e9 for (a, state), (b, _) in spans if state == "pursuit")
    assert pursuing_s >= 0.6 * (ended_ns - first) / 1e9
    pans = [math.degrees(r.pan_rad) for r in readings]
    assert max(pans) - min(pans) > 1.0  # the head followed someone
    parked = ipycam_position_deg(client, token, LOOP_RANGE_DEG)
    assert parked == pytest.approx((0.0, 0.0), abs=0.3)


@pytest.mark.parametrize("mode", ["position", "speed"])
def test_the_sim_onvif_rig_holds_the_target(tmp_path: Path, mode: str) -> None:
    rig_path = private_rig(
        REPO / "configs" / "sim-onvif.toml", tmp_path, "oval", None, None, 3, None
    )
    document = tomlkit.parse(rig_path.read_text())
    document["servo"]["mode"] = mode
    rig_path.write_text(tomlkit.dumps(document))
    supervisor = RunningSupervisor(rig_path, tmp_path)
    rig, bus = supervisor.rig, supervisor.bus
    truth = bus.subscribe(SIM_TRUTH, capacity=100000)
    states = bus.subscribe(GAZE_STATE, capacity=1000)
    commands = bus.subscribe(SERVO_COMMAND, capacity=100000)
    estimates = bus.subscribe(ESTIMATOR_STATE, capacity=100000)
    record = LoopRecord([], [], [], [])
    try:
        supervisor.wait_ready(60.0)
        started = time.monotonic()
        while time.monotonic() - started < RUN_S:
            supervisor.wakeup.wait(0.5)
            record.truth.extend(truth.take())
            record.states.extend(states.take())
            record.commands.extend(commands.take())
            record.estimates.extend(estimates.take())
        result = score(record, CameraPose.from_rig(rig), rig.gaze.fovea_half_angle_deg)
        print(mode, result)
        assert result["acquired_after_s"] is not None and result["acquired_after_s"] < 6.0
        assert result["fovea_fraction"] >= 0.9
    finally:
        code = supervisor.stop()
    assert code == 0
