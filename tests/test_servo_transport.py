"""The transport is a pyserial URL: loop://, socket:// and a pty all carry the same driver; I/O
before connect() and a port that is not there are clear errors."""

from __future__ import annotations

import select
import socket
import threading
import time

import pytest

from gazed.config import parse_rig
from gazed.servo import make_codec
from gazed.servo.driver import ServoDriver, ServoTimeout
from gazed.servo.transport import LinkError, NotConnectedError, SerialTransport
from gazed.sim.head_line import HeadLine


def test_io_before_connect_is_a_clear_error() -> None:
    transport = SerialTransport("loop://", 9600)
    with pytest.raises(NotConnectedError, match="connect"):
        transport.write(b"x")
    with pytest.raises(NotConnectedError):
        transport.read(0.01)


def test_a_missing_port_is_a_link_error(tmp_path) -> None:
    with pytest.raises(LinkError, match="cannot open"):
        SerialTransport(str(tmp_path / "ttyUSB9"), 9600).connect()


def test_loop_url_echoes_and_a_request_echoed_is_not_a_reply() -> None:
    with SerialTransport("loop://", 9600) as transport:
        t_ns = transport.write(b"\xff\x01\x00\x51\x00\x00\x52")
        assert abs(t_ns - time.time_ns()) < 1e9
        data, _ = transport.read(0.1)
        assert data == b"\xff\x01\x00\x51\x00\x00\x52"
    # a half-duplex adapter that echoes our own query back: the codec does not take it for
    # the camera's answer, and the driver times out instead of decoding nonsense
    driver = ServoDriver(make_codec("pelco-d"), SerialTransport("loop://", 9600), 0.05)
    with driver, pytest.raises(ServoTimeout, match="0 of 1 replies"):
        driver.query_position()
    assert driver.counters["timeouts"] == 1


class TcpHead:
    """A serial-over-TCP server (as an Ethernet serial bridge) with the emulated head behind it."""

    def __init__(self, rig) -> None:
        self.line = HeadLine(rig, time.monotonic())
        self.server = socket.create_server(("127.0.0.1", 0))
        self.port = self.server.getsockname()[1]
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self.serve, daemon=True)
        self.thread.start()

    def serve(self) -> None:
        self.server.settimeout(5.0)
        connection, _ = self.server.accept()
        with connection:
            while not self.stop.is_set():
                readable, _, _ = select.select([connection], [], [], 0.002)
                if readable:
                    data = connection.recv(4096)
                    if not data:
                        return
                    self.line.receive(data, time.monotonic())
                out = self.line.service(time.monotonic())
                if out:
                    connection.sendall(out)

    def close(self) -> None:
        self.stop.set()
        self.thread.join(5.0)
        self.server.close()


def test_socket_url_reaches_a_head_behind_a_serial_bridge() -> None:
    # a head as quick as the rig allows: the move is the bridge's check, not the head's
    quick = "pan_rate_max_deg_s = 3600\npan_accel_max_deg_s2 = 1000000\n"
    rig = parse_rig(
        f'[rig]\nname = "tcp"\n[servo]\nprotocol = "dynamixel"\nbaud = 1000000\n[head]\n{quick}'
    )
    head = TcpHead(rig)
    try:
        transport = SerialTransport(f"socket://127.0.0.1:{head.port}", rig.servo.baud)
        with ServoDriver(make_codec("dynamixel"), transport, 0.5) as driver:
            where = driver.query_position()
            assert (where.pan_rad, where.tilt_rad) == (0.0, 0.0)
            driver.set_position(0.5, -0.25)
            deadline = time.monotonic() + 5.0
            while abs(driver.query_position().pan_rad - 0.5) > 0.002:
                assert time.monotonic() < deadline
    finally:
        head.close()
