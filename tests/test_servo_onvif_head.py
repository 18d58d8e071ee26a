"""The ONVIF head against the emulated ONVIF camera on loopback (HTTP, SOAP, WS-Security), on a
virtual clock shared by both: connect reads the node's spaces, moves and GetStatus map to
degrees, park goes to a preset; the faults map onto the link's (a SOAP fault is a device error
and nothing moves, garbage a bad frame, a timeout a poll timeout, refused credentials or a dead
camera a link down and a reconnect); and a head link on it never leaves its limits."""

from __future__ import annotations

import logging
import math
import time
from pathlib import Path

import httpx
import pytest
from conftest import poll_until
from onvif_support import PASSWORD, Clock, onvif_rig
from servo_link_support import Demands, demand

from gazed.config import Rig
from gazed.servo.codec import CodecError, HandshakeError
from gazed.servo.driver import DeviceError, ServoTimeout
from gazed.servo.head_link import HeadLink
from gazed.servo.onvif_driver import camera_stream_uri, onvif_driver
from gazed.servo.onvif_head import OnvifHead, PasswordError, read_password
from gazed.servo.transport import LinkError
from gazed.sim.head_onvif import OnvifEmulator
from gazed.sim.onvif_device import fault

STEP_S = 0.02
SLOW_POLLS = {"odometry_rate_hz": 25.0, "command_rate_hz": 25.0}  # fewer requests: a fast test


def head_on(rig: Rig, clock: Clock, **kw: object) -> OnvifHead:
    return OnvifHead(rig.servo, password=PASSWORD, wall_ns=clock.now_ns, **kw)  # type: ignore[arg-type]


def test_connect_reads_the_spaces_and_moves_map_to_degrees(tmp_path: Path) -> None:
    rig, clock = onvif_rig(tmp_path), Clock()
    with OnvifEmulator(rig, clock=clock.now) as camera, head_on(rig, clock) as head:
        assert head.capabilities is not None and head.capabilities.absolute
        assert head.profile == "gazed_profile"
        head.set_position(math.radians(30.0), math.radians(-20.0))
        clock.sleep(2.0)
        position = head.query_position()
        assert math.degrees(position.pan_rad) == pytest.approx(30.0, abs=1e-6)
        assert math.degrees(position.tilt_rad) == pytest.approx(-20.0, abs=1e-6)
        assert position.t_pan_ns == clock.wall_ns and head.last_status == "IDLE"
        head.move_by(math.radians(-10.0), 0.0)
        clock.sleep(2.0)
        assert math.degrees(head.query_position().pan_rad) == pytest.approx(20.0, abs=1e-6)
        head.goto_preset("home")
        clock.sleep(2.0)
        assert head.query_position().pan_rad == pytest.approx(0.0, abs=1e-9)
        assert camera.device.requests["GetNodes"] == 1
        port = rig.servo.port.rsplit(":", 1)[1]
        assert head.stream_uri() == f"rtsp://admin:{PASSWORD}@127.0.0.1:{port}/gazed"
        assert camera_stream_uri(rig) == head.stream_uri()  # [camera] source = "onvif"


def test_the_http_client_logs_no_line_per_request(caplog: pytest.LogCaptureFixture) -> None:
    # at the odometry and command rates that would be a log line every few ms, in the loop
    with caplog.at_level(logging.INFO):
        transport = httpx.MockTransport(lambda _request: httpx.Response(200, text="ok"))
        with httpx.Client(transport=transport) as client:
            client.post("http://camera/onvif/ptz_service")
    assert not [r for r in caplog.records if r.name.startswith("httpx")]


def test_continuous_move_runs_until_its_timeout(tmp_path: Path) -> None:
    rig, clock = onvif_rig(tmp_path), Clock()
    with OnvifEmulator(rig, clock=clock.now), head_on(rig, clock) as head:
        head.set_speed(0.25, 0.0, timeout_s=0.5)  # 30 deg/s
        clock.sleep(0.3)
        moving = math.degrees(head.query_position().pan_rad)
        clock.sleep(2.0)
        stopped = math.degrees(head.query_position().pan_rad)
    assert 5.0 < moving < 9.0
    assert 12.0 < stopped < 18.0  # 0.5 s at 30 deg/s, then braking


def test_refused_credentials_and_a_missing_password(tmp_path: Path) -> None:
    rig, clock = onvif_rig(tmp_path), Clock()
    with OnvifEmulator(rig, clock=clock.now) as camera:
        with pytest.raises(LinkError, match="credentials refused"):
            OnvifHead(rig.servo, password="wrong").connect()
        assert camera.device.refused >= 1
    servo = rig.servo.model_copy(update={"password_file": None, "password_env": "GAZED_NO_SUCH"})
    with pytest.raises(HandshakeError, match="GAZED_NO_SUCH"):
        OnvifHead(servo).connect()
    with pytest.raises(PasswordError):
        read_password(rig.servo.model_copy(update={"password_file": str(tmp_path / "none")}))
    assert read_password(servo.model_copy(update={"password_env": "P"}), environ={"P": "x"}) == "x"


def scripted(rig: Rig, answer) -> httpx.MockTransport:
    """A camera that answers discovery and the profile like the emulator, then `answer(op)`."""
    camera = OnvifEmulator(rig, password=PASSWORD)

    def handle(request: httpx.Request) -> httpx.Response:
        body = request.content
        operation = body.split(b"<s:Body>")[1].split(b">")[0].split(b":")[-1].split(b"/")[0]
        special = answer(operation.decode())
        if special is not None:
            return special
        status, xml = camera.device.handle(body, 0.0)
        return httpx.Response(status, text=xml)

    return httpx.MockTransport(handle)


def soap_fault(_request: object = None) -> httpx.Response:
    return httpx.Response(400, text=fault("Sender", "ter:InvalidArgVal", "No such profile"))


def test_a_soap_fault_is_a_device_error_garbage_a_bad_frame_a_timeout_a_poll_timeout(
    tmp_path: Path,
) -> None:
    rig = onvif_rig(tmp_path)
    answers = {
        "AbsoluteMove": soap_fault(),
        "GetStatus": httpx.Response(200, content=b"\x00\xffnot xml"),
    }
    head = OnvifHead(rig.servo, password=PASSWORD, transport=scripted(rig, answers.get))
    head.connect()
    with pytest.raises(DeviceError, match="No such profile"):
        head.set_position(0.1, 0.1)
    with pytest.raises(CodecError):
        head.query_position()
    assert head.codec.bad_frames == 1

    def time_out(operation: str) -> httpx.Response | None:
        if operation == "GetStatus":
            raise httpx.ReadTimeout("no answer")
        return None

    head = OnvifHead(rig.servo, password=PASSWORD, transport=scripted(rig, time_out))
    head.connect()
    with pytest.raises(ServoTimeout):
        head.query_position()


def test_a_camera_without_absolute_moves_is_driven_by_speed(tmp_path: Path) -> None:
    rig = onvif_rig(tmp_path)

    def no_absolute(operation: str) -> httpx.Response | None:
        if operation not in ("GetNodes", "GetConfigurationOptions"):
            return None
        status, xml = OnvifEmulator(rig, password=PASSWORD).device.handle(_request(operation), 0.0)
        cut = xml.split("<tt:AbsolutePanTiltPositionSpace>")
        xml = cut[0] + cut[1].split("</tt:AbsolutePanTiltPositionSpace>")[1]
        return httpx.Response(status, text=xml)

    driver = onvif_driver(rig, password=PASSWORD, transport=scripted(rig, no_absolute))
    driver.connect()
    assert driver.by_speed


def _request(operation: str) -> bytes:
    from onveef import envelopes

    body = (
        envelopes.ptz_get_nodes()
        if operation == "GetNodes"
        else (envelopes.ptz_get_configuration_options(configuration_token="gazed_ptz"))
    )
    return envelopes.build_envelope(body, username="admin", password=PASSWORD).encode()


def link_on(rig: Rig, clock: Clock) -> tuple[HeadLink, Demands]:
    demands = Demands()
    link = HeadLink(
        rig,
        demands.take,
        lambda *_: None,
        mono_s=clock.now,
        wall_ns=clock.now_ns,
        sleep=clock.sleep,
    )
    return link, demands


def run(
    link: HeadLink, clock: Clock, seconds: float, camera: OnvifEmulator
) -> list[tuple[float, float]]:
    """Step the link for `seconds`; the camera's true joint angles (deg) at every step."""
    poses = []
    end_s = clock.mono_s + seconds
    while clock.mono_s < end_s:
        link.step(clock)
        pose = camera.pose_at(clock.mono_s)
        poses.append((math.degrees(pose.pan_rad), math.degrees(pose.tilt_rad)))
        clock.sleep(STEP_S)
    return poses


@pytest.mark.parametrize("mode", ["position", "speed"])
def test_a_link_on_the_camera_follows_demands_inside_its_limits_then_holds(
    tmp_path: Path, mode: str
) -> None:
    rig = onvif_rig(tmp_path, mode=f'"{mode}"', command_timeout_ms=300.0, **SLOW_POLLS)
    clock = Clock()
    head = rig.head
    with OnvifEmulator(rig, clock=clock.now) as camera:
        link, demands = link_on(rig, clock)
        run(link, clock, 0.2, camera)
        assert link.link == "connected"
        demands.put(demand(20.0, -10.0))
        run(link, clock, 1.0, camera)
        pan_deg, tilt_deg = run(link, clock, 0.05, camera)[-1]
        assert (pan_deg, tilt_deg) == pytest.approx((20.0, -10.0), abs=1.0)
        poses = []
        for _ in range(12):  # far past both limits, pursued at speed
            demands.put(demand(170.0, 80.0, kind="pursuit", pan_rate_deg_s=200.0))
            poses += run(link, clock, 0.1, camera)
        poses += run(link, clock, 1.2, camera)  # no demand: hold, then Stop in speed mode
        assert all(head.pan_min_deg - 1e-6 <= p <= head.pan_max_deg + 1e-6 for p, _ in poses)
        assert all(head.tilt_min_deg - 1e-6 <= t <= head.tilt_max_deg + 1e-6 for _, t in poses)
        assert max(p for p, _ in poses) > head.pan_max_deg - 2.0
        assert link.holding and camera.settled
        if mode == "speed":
            assert camera.device.requests.get("AbsoluteMove", 0) == 0
            assert camera.device.requests["Stop"] >= 1
        else:
            assert camera.device.requests.get("ContinuousMove", 0) == 0
        link.close()


def test_park_goes_to_the_preset_and_a_dead_camera_is_reconnected(tmp_path: Path) -> None:
    rig = onvif_rig(tmp_path, park_preset='"home"', reconnect_max_s=1.0, **SLOW_POLLS)
    clock = Clock()
    camera = OnvifEmulator(rig, clock=clock.now)
    with camera:
        link, demands = link_on(rig, clock)
        run(link, clock, 0.1, camera)
        demands.put(demand(30.0, 10.0))
        run(link, clock, 1.0, camera)
    run(link, clock, 0.3, camera)  # the camera is gone: polls fail, the link goes down
    assert link.link == "down" and link.counts["errors"] >= 1
    with camera:
        run(link, clock, 2.0, camera)
        assert link.link == "connected" and link.counts["reconnects"] == 1
        link.close()
        run_s = clock.mono_s
        pose = camera.pose_at(run_s + 2.0)
        assert camera.device.requests["GotoPreset"] == 1
        assert (pose.pan_rad, pose.tilt_rad) == pytest.approx((0.0, 0.0), abs=1e-9)


def test_jog_shows_the_cameras_units_and_refuses_moves_past_the_limits(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from gazed.cli import main

    rig = onvif_rig(tmp_path)
    jog = ["servo", "jog", "--rig", str(tmp_path / "rig.toml"), "--listen-ms", "0"]
    with OnvifEmulator(rig) as camera:
        assert main([*jog, "--pan-deg", "30", "--tilt-deg", "-10"]) == 0
        poll_until(lambda: camera.pose_at(time.monotonic()) and camera.settled, 5.0)
        assert main([*jog, "--query"]) == 0
        assert "pan 0.16667, tilt -0.11111 (camera units)" in capsys.readouterr().out
        assert main([*jog, "--pan-deg", "70", "--tilt-deg", "0", "--relative"]) == 2
        assert "outside [head]'s limits" in capsys.readouterr().out
        assert main([*jog, "--pan-deg", "-5", "--tilt-deg", "0", "--relative"]) == 0
        assert main([*jog, "--stop"]) == 0
        assert camera.device.requests["RelativeMove"] == 1
        assert camera.device.requests["Stop"] == 1
