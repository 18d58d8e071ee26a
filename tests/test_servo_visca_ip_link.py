"""VISCA over IP on a loopback UDP port against the head emulator's VISCA-over-IP camera: RESET
on connect, a lost command or ACK resent under the same sequence number (a lost ACK then
answered `0F 01` and recovered by a RESET), a reply to another sequence number dropped and
counted, garbage datagrams passed over, a VISCA error reply reported in the status with no move,
and a silent camera taking the link down until it answers again (backoff)."""

from __future__ import annotations

import math
import subprocess
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from conftest import PYTHON, child_env, poll_until
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from servo_link_support import Demands, demand, link_rig

from gazed.config import Rig, load_rig
from gazed.servo import make_codec, visca_ip
from gazed.servo.driver import DeviceError, ServoDriver
from gazed.servo.head_link import HeadLink, LinkStep
from gazed.servo.visca_ip_transport import (
    MAX_RESENDS,
    LinkError,
    ViscaIpTransport,
    is_completion,
)
from gazed.sim.head_emulator import EmulatorError, HeadEmulator
from gazed.sim.head_visca_ip import ViscaIpSession
from services.runtime import Now

REPO = Path(__file__).resolve().parents[1]
TIMEOUT_S = 0.3  # resends after 0.1 s: the tests hold on a loaded machine
Filter = Callable[[bytes], list[bytes]]


def free_udp_port() -> int:
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def udp_rig(tmp_path: Path, timeout_s: float = TIMEOUT_S, **servo: object) -> Rig:
    """configs/sim-visca-ip.toml on a free loopback port, with `servo` keys added."""
    text = (REPO / "configs" / "sim-visca-ip.toml").read_text()
    text = text.replace("127.0.0.1:52381", f"127.0.0.1:{free_udp_port()}")
    text = text.replace("timeout_ms = 100.0", f"timeout_ms = {timeout_s * 1000}")
    for key, value in servo.items():
        text = text.replace("[servo]\n", f"[servo]\n{key} = {value}\n")
    path = tmp_path / "rig.toml"
    path.write_text(text)
    return load_rig(path)


class RecordingSession(ViscaIpSession):
    """The camera's framing, with what it received kept and `incoming` deciding what arrives."""

    def __init__(self) -> None:
        super().__init__()
        self.received: list[bytes] = []
        self.incoming: Filter = lambda d: [d]

    def receive(self, datagram: bytes) -> tuple[bytes, list[bytes]]:
        data, replies = b"", []
        for d in self.incoming(datagram):
            self.received.append(d)
            more, out = super().receive(d)
            data, replies = data + more, replies + out
        return data, replies


class FaultyCamera(HeadEmulator):
    """The emulated camera; `outgoing` decides what of each reply datagram reaches the host."""

    def __init__(self, rig: Rig) -> None:
        super().__init__(rig)
        self.session = RecordingSession()
        self.outgoing: Filter = lambda d: [d]

    def _send_datagram(self, datagram: bytes) -> None:
        for d in self.outgoing(datagram):
            super()._send_datagram(d)


def once(match: Callable[[visca_ip.Message], bool], then: Filter) -> Filter:
    """A filter that applies `then` to the first datagram `match` accepts, passes the rest."""
    done = [False]

    def apply(datagram: bytes) -> list[bytes]:
        message = visca_ip.parse(datagram)
        if not done[0] and message is not None and match(message):
            done[0] = True
            return then(datagram)
        return [datagram]

    return apply


def is_ack(message: visca_ip.Message) -> bool:
    return message.payload_type == visca_ip.PAYLOAD_TYPE["reply"] and message.payload[1] == 0x41


def driver_on(rig: Rig) -> ServoDriver:
    transport = ViscaIpTransport(rig.servo.port, TIMEOUT_S)
    return ServoDriver(make_codec("visca", **rig.servo_params()), transport, TIMEOUT_S)


def test_connect_resets_and_messages_are_numbered_from_one(tmp_path: Path) -> None:
    rig = udp_rig(tmp_path)
    with FaultyCamera(rig) as camera, driver_on(rig) as driver:
        driver.query_position()
        received = [visca_ip.parse(d) for d in camera.session.received]
    assert received[0] == visca_ip.Message(visca_ip.PAYLOAD_TYPE["control"], 0, visca_ip.RESET)
    assert [m.sequence for m in received[1:] if m] == [1, 2]  # IF_Clear, the inquiry
    assert driver.transport.counters["resets"] == 1


def test_a_lost_command_is_resent_under_the_same_number_and_executed(tmp_path: Path) -> None:
    rig = udp_rig(tmp_path)
    with FaultyCamera(rig) as camera, driver_on(rig) as driver:
        first_command = once(lambda m: m.payload[1:3] == b"\x01\x06", lambda d: [])
        camera.session.incoming = first_command
        driver.set_position(math.radians(10.0), 0.0)
        commands = [d for d in camera.session.received if d[8:11] == bytes.fromhex("81 01 06")]
        pan_deg = poll_until(lambda: _pan_deg_if_settled(driver, 10.0), 5.0)
    assert len(commands) == 1 and commands[0][4:8] == (2).to_bytes(4, "big")
    assert driver.transport.counters["resends"] == 1
    assert driver.transport.counters["sequence_errors"] == 0
    assert pan_deg == pytest.approx(10.0, abs=0.1)


def test_a_lost_ack_is_resent_refused_as_a_repeat_and_recovered_by_a_reset(
    tmp_path: Path,
) -> None:
    rig = udp_rig(tmp_path)
    with FaultyCamera(rig) as camera, driver_on(rig) as driver:
        camera.outgoing = once(is_ack, lambda d: [])
        driver.set_position(math.radians(-8.0), math.radians(4.0))
        received = [visca_ip.parse(d) for d in camera.session.received]
        pan_deg = poll_until(lambda: _pan_deg_if_settled(driver, -8.0), 5.0)
    moves = [m for m in received if m and m.payload[1:3] == b"\x01\x06"]
    # sent, resent under the same number (refused 0F 01), then RESET and sent again as number 1
    assert [m.sequence for m in moves] == [2, 2, 1]
    assert received[-len(moves) :][-2].payload_type == visca_ip.PAYLOAD_TYPE["control"]
    assert driver.transport.counters["sequence_errors"] == 1
    assert driver.transport.counters["resets"] == 2
    assert camera.session.counters["repeated_sequences"] == 1
    assert pan_deg == pytest.approx(-8.0, abs=0.1)


def test_a_command_acked_before_a_reset_frees_its_socket_when_it_completes(
    tmp_path: Path,
) -> None:
    """A RESET (a lost reply, resent, refused as a repeat) renumbers the messages to come; the
    move ACKed before it completes under its own number, and the codec frees its socket."""
    rig = udp_rig(tmp_path)
    held: list[bytes] = []  # a completion before the RESET's ACK, let through right after it
    reset = [False]

    def completion_after_reset(datagram: bytes) -> list[bytes]:
        message = visca_ip.parse(datagram)
        if message is not None and message.payload == visca_ip.RESET_ACK:
            reset[0] = True
            return [datagram, *held]
        if message is not None and is_completion(message.payload) and not reset[0]:
            held.append(datagram)
            return []
        return [datagram]

    with FaultyCamera(rig) as camera, driver_on(rig) as driver:
        driver.set_position(math.radians(30.0), 0.0)
        assert driver.codec.sockets_busy == {1}
        lose_position = once(lambda m: len(m.payload) == 11, lambda d: [])
        camera.outgoing = lambda d: [
            x for kept in lose_position(d) for x in completion_after_reset(kept)
        ]
        poll_until(lambda: _pan_deg_if_settled(driver, 30.0), 5.0)
        poll_until(lambda: _sockets_busy_after_a_poll(driver) == set(), 5.0)
    assert driver.transport.counters["sequence_errors"] == 1
    assert driver.transport.counters["foreign_replies"] == 0


def _sockets_busy_after_a_poll(driver: ServoDriver) -> set[int]:
    """The sockets the codec counts busy once the replies in by a position poll are read."""
    driver.query_position()
    return set(driver.codec.sockets_busy)


def _pan_deg_if_settled(driver: ServoDriver, target_deg: float) -> float | None:
    pan_deg = math.degrees(driver.query_position().pan_rad)
    return pan_deg if abs(pan_deg - target_deg) < 0.1 else None


def test_a_reply_under_another_number_is_dropped_and_counted(tmp_path: Path) -> None:
    rig = udp_rig(tmp_path)

    def misnumbered_first(datagram: bytes) -> list[bytes]:
        message = visca_ip.parse(datagram)
        assert message is not None
        wrong = visca_ip.frame(message.payload_type, message.sequence + 7, message.payload)
        return [wrong, datagram]

    with FaultyCamera(rig) as camera, driver_on(rig) as driver:
        camera.outgoing = once(lambda m: len(m.payload) == 11, misnumbered_first)
        driver.query_position()
    assert driver.transport.counters["foreign_replies"] == 1
    assert driver.counters["stale_replies"] == 0


@pytest.fixture(scope="module")
def camera_and_driver(tmp_path_factory: pytest.TempPathFactory):
    rig = udp_rig(tmp_path_factory.mktemp("garbage"))
    with FaultyCamera(rig) as camera, driver_on(rig) as driver:
        yield camera, driver


@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(st.lists(st.binary(min_size=1, max_size=24), min_size=1, max_size=4))
def test_garbage_datagrams_before_a_reply_are_passed_over(camera_and_driver, garbage) -> None:
    camera, driver = camera_and_driver
    before = driver.transport.counters.copy()
    camera.outgoing = once(lambda m: len(m.payload) == 11, lambda d: [*garbage, d])
    position = driver.query_position()
    assert math.isfinite(position.pan_rad)
    counted = driver.transport.counters - before
    # each one is garbage, a reply to another number, or a control message it acts on
    assert sum(counted.values()) >= len(garbage) - sum(
        1 for g in garbage if (m := visca_ip.parse(g)) and m.payload_type in visca_ip.CONTROL_TYPES
    )


class LinkOnCamera:
    """A head link (real clocks) on the emulated camera."""

    def __init__(self, rig: Rig) -> None:
        self.demands = Demands()
        self.link = HeadLink(rig, self.demands.take, lambda *_: None)
        self.last: LinkStep | None = None

    def run_until(self, done: Callable[[], bool], timeout_s: float, *demands) -> None:
        deadline = time.monotonic() + timeout_s
        while not done():
            assert time.monotonic() < deadline, "condition not met"
            self.demands.put(*demands)
            self.last = self.link.step(Now.read())
            time.sleep(min(self.last.wait_s, 0.005))


def test_a_refused_command_is_a_clear_status_error_and_the_camera_stays(tmp_path: Path) -> None:
    host_rig = udp_rig(tmp_path, tilt_speed_max_code=24, tilt_speed=24)
    camera_rig = host_rig.model_copy(
        update={"servo": host_rig.servo.model_copy(update={"tilt_speed_max_code": 20})}
    )
    with FaultyCamera(camera_rig) as camera:
        head = LinkOnCamera(host_rig)
        head.run_until(lambda: head.link.counts["errors"] > 0, 5.0, demand(20.0, 10.0))
        status = head.link.close()
        assert "syntax error" in (status.last_error or "")
        assert camera.settled
        assert math.degrees(camera.device_pose_at(time.monotonic()).pan_rad) == pytest.approx(0.0)


def test_a_silent_camera_takes_the_link_down_and_it_reconnects_with_backoff(
    tmp_path: Path,
) -> None:
    rig = udp_rig(tmp_path, timeout_s=0.06)
    with FaultyCamera(rig) as camera:
        head = LinkOnCamera(rig)
        head.run_until(lambda: head.link.link == "connected", 5.0)
        camera.outgoing = lambda d: []
        head.run_until(lambda: head.link.link == "down", 5.0)
        assert head.link.counts["timeouts"] == 3
        assert "position polls unanswered" in (head.link.last_error or "")
        assert head.link.driver.transport.counters["resends"] >= 3 * MAX_RESENDS
        resets = camera.session.counters["resets"]
        head.run_until(lambda: camera.session.counters["resets"] > resets + 1, 10.0)
        assert head.link.link == "down"  # each attempt RESETs; none is answered
        camera.outgoing = lambda d: [d]
        head.run_until(lambda: head.link.link == "connected", 10.0)
        assert head.link.counts["reconnects"] == 1
        head.link.close()


def test_a_command_refused_by_the_camera_raises_a_device_error(tmp_path: Path) -> None:
    rig = udp_rig(tmp_path)

    def not_executable(datagram: bytes) -> list[bytes]:
        sequence = int.from_bytes(datagram[4:8], "big")
        return [visca_ip.frame(visca_ip.PAYLOAD_TYPE["reply"], sequence, b"\x90\x61\x41\xff")]

    with FaultyCamera(rig) as camera, driver_on(rig) as driver:
        camera.outgoing = once(is_ack, not_executable)
        with pytest.raises(DeviceError, match="not executable"):
            driver.set_position(math.radians(5.0), 0.0)


@pytest.mark.e2e
def test_the_emulator_alone_serves_a_visca_over_ip_rig(tmp_path: Path) -> None:
    rig = udp_rig(tmp_path)
    emulator = subprocess.Popen(
        [PYTHON, "-m", "gazed.sim.head_emulator", "--rig", str(tmp_path / "rig.toml")],
        cwd=REPO,
        env=child_env(),
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert "visca head on udp ('127.0.0.1'" in emulator.stdout.readline()
        with driver_on(rig) as driver:
            driver.set_position(math.radians(3.0), math.radians(-2.0))
            assert poll_until(lambda: _pan_deg_if_settled(driver, 3.0), 5.0) == pytest.approx(
                3.0, abs=0.1
            )
    finally:
        emulator.terminate()
        assert emulator.wait(10) == 0


def test_the_emulator_refuses_a_udp_port_for_another_protocol(tmp_path: Path) -> None:
    rig = udp_rig(tmp_path)
    pelco = rig.model_copy(update={"servo": link_rig(protocol="pelco-d").servo})
    with pytest.raises(EmulatorError, match="carries VISCA"):
        HeadEmulator(pelco, link=rig.servo.port)


def test_no_camera_at_the_port_is_a_link_error_and_the_port_stays_closed(tmp_path: Path) -> None:
    rig = udp_rig(tmp_path)
    transport = ViscaIpTransport(rig.servo.port, TIMEOUT_S)
    with pytest.raises(LinkError, match=r"RESET|refused"):
        transport.connect()
    assert not transport.is_connected
