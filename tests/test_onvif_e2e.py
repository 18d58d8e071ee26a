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

import importlib.util
import math
import subprocess
import threading
import time
from pathlib import Path

import cv2
import pytest
import tomlkit
from conftest import PYTHON, REPO, SUPPORT, RunningSupervisor, child_env, free_tcp_port, poll_until
from onveef import OnvifClient
from servo_link_support import demand

from gazed.bus import Bus
from gazed.config import load_rig
from gazed.eval.loop_metrics import LoopRecord, score
from gazed.eval.private_rig import private_rig
from gazed.geometry.pose import CameraPose
from gazed.servo.onvif_ptz import get_status, parse_status
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

USER, PASSWORD = "admin", "s3cret"
RANGE_DEG = 30.0  # the rig's degrees at ipycam's generic -1 and 1
RUN_S = 12.0


@pytest.fixture
def ipycam(shared_data: Path, tmp_path: Path):
    """ipycam on a free loopback port, zoomed to 0.5 (at zoom 0 its pan and tilt do nothing);
    yields (port, an onveef client of its own)."""
    if importlib.util.find_spec("ipycam") is None:
        pytest.skip("ipycam is not installed (CI: pip install --no-deps ipycam==1.3.0)")
    video = shared_data / "video" / "vtest_480x360.avi"
    port = free_tcp_port()
    process = subprocess.Popen(
        [PYTHON, str(SUPPORT / "ipycam_loopback.py"), str(video), str(port), USER, PASSWORD],
        cwd=tmp_path,  # ipycam writes its presets file to the working directory
        env=child_env(),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        assert process.stdout is not None
        lines = iter(process.stdout.readline, "")
        assert "READY" in (line.strip() for line in lines), "ipycam did not start"
        threading.Thread(target=lambda: list(lines), daemon=True).start()  # drain its log
        client = OnvifClient("127.0.0.1", port, USER, PASSWORD, retries=0, timeout_s=2.0)
        token = client.get_profiles()[0]["token"]
        client.ptz_absolute_move(profile_token=token, pan=0.0, tilt=0.0, zoom=0.5)
        yield port, client, token
        client.close()
    finally:
        process.terminate()
        process.wait(10)


def ipycam_position_deg(
    client: OnvifClient, token: str, range_deg: tuple[float, float] = (RANGE_DEG, RANGE_DEG)
) -> tuple[float, float]:
    """ipycam's own report of its pan and tilt, in the rig's degrees."""
    xml = client.call(service="ptz", operation="GetStatus", body_inner=get_status(token))
    status = parse_status(xml)
    return status.pan * range_deg[0], status.tilt * range_deg[1]


def ipycam_rig(tmp_path: Path, port: int, mode: str) -> Path:
    password_file = tmp_path / "password"
    password_file.write_text(PASSWORD + "\n")
    path = tmp_path / "ipycam.toml"
    path.write_text(
        f"""
[rig]
name = "ipycam{port}"
[bus]
listen = ["tcp/127.0.0.1:{free_tcp_port()}"]
[camera]
source = "http://{USER}:{PASSWORD}@127.0.0.1:{port}/stream.mjpeg"
[head]
pan_min_deg = -20
pan_max_deg = 20
tilt_min_deg = -15
tilt_max_deg = 15
pan_rate_max_deg_s = 30
tilt_rate_max_deg_s = 30
pan_accel_max_deg_s2 = 200
tilt_accel_max_deg_s2 = 200
[servo]
protocol = "onvif"
port = "onvif://127.0.0.1:{port}"
username = "{USER}"
password_file = "{password_file}"
pan_range_deg = [-{RANGE_DEG}, {RANGE_DEG}]
tilt_range_deg = [-{RANGE_DEG}, {RANGE_DEG}]
pan_speed_max_deg_s = {RANGE_DEG}
tilt_speed_max_deg_s = {RANGE_DEG}
mode = "{mode}"
timeout_ms = 1000
command_timeout_ms = 500
odometry_rate_hz = 20
command_rate_hz = 20
"""
    )
    return path


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
        servo = subprocess.Popen(
            [PYTHON, "-m", "services.servo", "--rig", str(rig_path)],
            cwd=REPO,
            env=child_env(),
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
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


def loop_rig(tmp_path: Path, port: int) -> Path:
    """configs/pets.toml's world (the PETS 2009 camera's calibration) seen through ipycam's
    digital PTZ: a 192x144 crop of the 480x360 footage at zoom 0.5, served at 480x360, whose
    pan and tilt of -1..1 move it 144 and 108 source pixels, about 11 and 8.2 degrees."""
    pets = tomlkit.parse((REPO / "configs" / "pets.toml").read_text())
    password_file = tmp_path / "password"
    password_file.write_text(PASSWORD + "\n")
    rig = tomlkit.parse(
        f"""
[rig]
name = "ipycamloop{port}"
[bus]
listen = ["tcp/127.0.0.1:{free_tcp_port()}"]
[camera]
source = "http://{USER}:{PASSWORD}@127.0.0.1:{port}/stream.mjpeg"
width_px = 480
height_px = 360
rate_hz = 10.0
fx_px = 1851.6
fy_px = 1866.6
[head]
pan_min_deg = -10
pan_max_deg = 10
tilt_min_deg = -7
tilt_max_deg = 7
pan_rate_max_deg_s = 20
tilt_rate_max_deg_s = 20
pan_accel_max_deg_s2 = 100
tilt_accel_max_deg_s2 = 100
[servo]
protocol = "onvif"
port = "onvif://127.0.0.1:{port}"
username = "{USER}"
password_file = "{password_file}"
pan_range_deg = [-11.0, 11.0]
tilt_range_deg = [-8.2, 8.2]
timeout_ms = 1000
command_timeout_ms = 500
odometry_rate_hz = 20
command_rate_hz = 20
[services.sim]
enabled = false
"""
    )
    for section in ("calibration", "vision", "estimator", "gaze"):
        rig[section] = pets[section]
    path = tmp_path / "ipycam-loop.toml"
    path.write_text(tomlkit.dumps(rig))
    return path


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
    parked = ipycam_position_deg(client, token, (11.0, 8.2))
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
