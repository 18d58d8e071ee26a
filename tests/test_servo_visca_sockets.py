"""VISCA's two command sockets (PROTOCOLS.md §2, Sony SRG-300H technical manual p.28): the
codec keeps which sockets hold commands from the replies' own bytes, the driver never has more
commands in the camera than it has sockets, and a command refused with buffer full is sent again
once a socket frees. The emulated camera refuses a third command while two execute, as a camera
does; the driver runs against it here on a clock of the test's own."""

from __future__ import annotations

import math
from collections import Counter

import pytest

from gazed.config import parse_rig
from gazed.servo import make_codec
from gazed.servo.driver import DeviceError, ServoDriver
from gazed.servo.visca import ViscaCodec
from gazed.sim.head_line import HeadLine

H = bytes.fromhex
STEP_S = 0.0005
LATENCY_S = 0.020
DRIVE = H("81 01 06 01 0C 0A 02 03 FF")
MOVE_PAN_300 = H("81 01 06 02 18 14 00 01 02 0C 00 00 00 00 FF")  # pan +300 units
MOVE_PAN_0 = H("81 01 06 02 18 14 00 00 00 00 00 00 00 00 FF")
ZOOM_HALF = H("81 01 04 47 02 00 00 00 FF")
INQUIRY = H("81 09 06 12 FF")
IF_CLEAR = H("81 01 00 01 FF")


def rig_text() -> str:
    return (
        '[rig]\nname = "s"\n[servo]\nprotocol = "visca"\nbaud = 9600\n'
        "pan_deg_per_unit = 0.075\n"
        f"[sim]\nhead_latency_ms = {LATENCY_S * 1000:g}\n"
        "[head]\npan_min_deg = -180\npan_max_deg = 180\ntilt_max_deg = 90\n"
    )


# --- codec: sockets from golden bytes --------------------------------------------------------


def test_acks_fill_the_sockets_and_completions_free_them() -> None:
    codec = ViscaCodec()
    assert codec.has_room(DRIVE)
    codec.feed(H("90 41 FF 90 42 FF"))
    assert codec.sockets_busy == {1, 2}
    assert not codec.has_room(DRIVE)
    assert not codec.has_room(MOVE_PAN_0)
    # inquiries and IF_Clear use no socket
    assert codec.has_room(INQUIRY) and codec.has_room(IF_CLEAR)
    (done,) = codec.feed(H("90 52 FF"))
    assert (done.kind, done.socket, done.asynchronous) == ("completion", 2, True)
    assert codec.sockets_busy == {1}
    assert codec.has_room(DRIVE)


def test_not_executable_on_a_busy_socket_ends_its_command() -> None:
    codec = ViscaCodec()
    codec.feed(H("90 41 FF"))
    (ended,) = codec.feed(H("90 61 41 FF"))
    assert (ended.kind, ended.reason, ended.asynchronous) == (
        "error",
        "command not executable",
        True,
    )
    assert codec.sockets_busy == set()
    # with no command in that socket it answers the request in flight
    (refused,) = codec.feed(H("90 61 41 FF"))
    assert not refused.asynchronous


def test_buffer_full_leaves_no_room_until_a_socket_frees() -> None:
    codec = ViscaCodec()  # lost track: the codec thinks both sockets free
    (full,) = codec.feed(H("90 60 03 FF"))
    assert codec.refused_as_busy(full)
    assert not codec.has_room(DRIVE)
    codec.feed(H("90 51 FF"))
    assert codec.has_room(DRIVE)
    codec.feed(H("90 60 03 FF"))
    codec.reset()  # a timeout or a reconnect forgets the sockets
    assert codec.has_room(DRIVE)


def test_cancel_and_if_clear_free_sockets() -> None:
    codec = ViscaCodec()
    codec.feed(H("90 41 FF 90 42 FF 90 61 04 FF"))  # socket 1's command cancelled
    assert codec.sockets_busy == {2}
    codec.feed(H("90 41 FF 90 50 FF"))  # IF_Clear's answer empties both
    assert codec.sockets_busy == set()


def test_a_bad_reply_is_skipped_counted_and_takes_no_socket() -> None:
    codec = ViscaCodec()
    replies = codec.feed(H("13 37 90 47 FF 90 41 FF"))  # garbage, an ACK for socket 7, an ACK
    assert [(r.kind, r.socket) for r in replies] == [("ack", 1)]
    assert codec.discarded_bytes > 0
    assert codec.sockets_busy == {1}


# --- the emulated camera ---------------------------------------------------------------------


class Camera:
    """The emulated camera on a clock of the test's own."""

    def __init__(self) -> None:
        self.line = HeadLine(parse_rig(rig_text()), 0.0, serial=False)
        self.t_s = 0.0

    def ask(self, data: bytes, expect_bytes: int) -> bytes:
        self.line.receive(data, self.t_s)
        out = bytearray()
        while len(out) < expect_bytes:
            assert self.t_s < 5.0, bytes(out)
            self.t_s += STEP_S
            out += self.line.service(self.t_s)
        return bytes(out)


def test_emulator_refuses_a_third_command_while_two_execute() -> None:
    camera = Camera()
    assert camera.ask(MOVE_PAN_300, 3) == H("90 41 FF")
    assert camera.ask(ZOOM_HALF, 3) == H("90 42 FF")
    assert camera.ask(DRIVE, 4) == H("90 60 03 FF")  # both sockets busy, nothing changes
    assert camera.ask(b"", 3) == H("90 52 FF")  # the zoom completes when it takes effect
    # a move takes pan-tilt over: the move it supersedes completes after its ACK
    assert camera.ask(MOVE_PAN_0, 6) == H("90 42 FF 90 51 FF")
    m = camera.line.mechanics
    assert camera.ask(b"", 3) == H("90 52 FF")  # once the head has settled on it
    assert m.pan.settled and m.tilt.settled
    assert m.pan.target_rad == 0.0 and m.pan.velocity_rad_s == 0.0  # the drive never ran


# --- the driver against it -------------------------------------------------------------------


class CameraTransport:
    """The driver's transport onto the emulated camera: each read moves the clock one step."""

    url = "camera://"
    byte_time_s = 0.0
    line_s = 0.0

    def __init__(self, camera: Camera) -> None:
        self.camera = camera
        self.counters: Counter[str] = Counter()
        self.is_connected = False

    def connect(self) -> None:
        self.is_connected = True

    def disconnect(self) -> None:
        self.is_connected = False

    def write(self, data: bytes) -> int:
        self.camera.line.receive(data, self.camera.t_s)
        return round(self.camera.t_s * 1e9)

    def read(self, timeout_s: float) -> tuple[bytes, int]:
        if timeout_s > 0:
            self.camera.t_s += STEP_S
        return self.camera.line.service(self.camera.t_s), round(self.camera.t_s * 1e9)

    def line_busy_s(self) -> float:
        return 0.0


def driver_on_camera() -> tuple[ServoDriver, Camera]:
    camera = Camera()
    rig = parse_rig(rig_text())
    codec = make_codec(rig.servo.protocol, **rig.servo_params())
    driver = ServoDriver(codec, CameraTransport(camera), timeout_s=0.5)
    driver.connect()
    return driver, camera


def test_a_stream_of_demands_never_overfills_the_sockets() -> None:
    driver, camera = driver_on_camera()
    demands_deg = [0.5 * i for i in range(30)]
    for pan_deg in demands_deg:  # a zoom between moves: both sockets busy at times
        driver.set_position(math.radians(pan_deg), 0.0)
        driver.set_zoom(pan_deg / 30.0)
        assert len(driver.codec.sockets_busy) <= 2
    assert driver.counters["refused_as_busy"] == 0
    assert driver.counters["waits_for_room"] > 0
    camera.ask(b"", 0)
    while not camera.line.mechanics.settled:
        driver.query_position()
    assert math.degrees(camera.line.mechanics.pan.target_rad) == pytest.approx(
        demands_deg[-1], abs=0.075 / 2
    )


def test_buffer_full_is_counted_and_the_command_sent_again_when_a_socket_frees() -> None:
    driver, camera = driver_on_camera()
    driver.set_position(math.radians(10.0), 0.0)
    driver.set_zoom(0.5)
    driver.codec.reset()  # as after a timeout: the codec no longer knows both are busy
    driver.set_position(math.radians(30.0), 0.0)
    assert driver.counters["refused_as_busy"] == 1
    assert driver.counters["frames_written"] == 5  # IF_Clear, move, zoom, refused, resent
    while not camera.line.mechanics.settled:
        driver.query_position()
    assert math.degrees(camera.line.mechanics.pan.target_rad) == pytest.approx(30.0)


class StuckCamera(CameraTransport):
    """A camera whose two sockets never free: it acknowledges two commands, then answers
    every other with buffer full."""

    def __init__(self, camera: Camera) -> None:
        super().__init__(camera)
        self.answers = [H("90 50 FF"), H("90 41 FF"), H("90 42 FF")]

    def write(self, data: bytes) -> int:
        self.pending = self.answers.pop(0) if self.answers else H("90 60 03 FF")
        return 0

    def read(self, timeout_s: float) -> tuple[bytes, int]:
        data, self.pending = getattr(self, "pending", b""), b""
        return data, 0


def test_lost_completions_expire_and_a_second_refusal_raises() -> None:
    driver = ServoDriver(ViscaCodec(), StuckCamera(Camera()), timeout_s=0.01)
    driver.connect()
    driver.set_velocity(0.1, 0.0)
    driver.set_velocity(0.2, 0.0)
    with pytest.raises(DeviceError, match="buffer full"):
        driver.set_velocity(0.3, 0.0)
    assert driver.counters["room_waits_expired"] == 2  # before the first and the second try
    assert driver.counters["refused_as_busy"] == 2
    assert driver.counters["frames_written"] == 5
