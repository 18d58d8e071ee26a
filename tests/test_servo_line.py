"""The serial line's own time: a write keeps the line busy ten bit times a byte; a reply is
awaited from when its request has left the line, not from when the port took it; a position is
dated when the head read it, each axis by the reply that carried it."""

from __future__ import annotations

import math
import os
import time
from collections import Counter
from pathlib import Path

import pytest

from gazed.config import parse_rig
from gazed.servo import make_codec
from gazed.servo.driver import ServoDriver
from gazed.servo.transport import SerialTransport
from gazed.sim.head_emulator import HeadEmulator
from gazed.sim.head_line import HeadLine


def pelco_rig(port: str | Path, baud: int):
    return parse_rig(
        f"""
[rig]
name = "line"
[servo]
protocol = "pelco-d"
port = "{port}"
baud = {baud}
[head]
pan_min_deg = -170
pan_max_deg = 170
pan_rate_max_deg_s = 120
pan_accel_max_deg_s2 = 100000
[sim]
head_latency_ms = 0
head_reply_delay_ms = 1
"""
    )


def test_a_write_keeps_the_line_busy_ten_bit_times_a_byte() -> None:
    controller, device = os.openpty()
    try:
        with SerialTransport(os.ttyname(device), 9600) as transport:
            assert transport.line_busy_s() == 0.0
            started = time.monotonic()
            transport.write(bytes(14))
            busy_s, elapsed_s = transport.line_busy_s(), time.monotonic() - started
            assert 14 * 10 / 9600 - elapsed_s <= busy_s <= 14 * 10 / 9600
            transport.write(bytes(7))  # behind the first, not beside it
            assert transport.line_busy_s() > busy_s + 7 * 10 / 9600 - (time.monotonic() - started)
    finally:
        os.close(controller)
        os.close(device)
    # no serial line behind these: their bytes take no time
    assert SerialTransport("loop://", 9600).byte_time_s == 0.0
    assert SerialTransport("socket://ptu:4000", 9600).byte_time_s == 0.0


def test_a_reply_is_awaited_from_when_the_request_has_left_the_line(tmp_path: Path) -> None:
    """Five set-points (70 bytes, 73 ms at 9600 baud) then a position query with a 40 ms
    timeout: the pan query leaves after them and its answer comes 89 ms after it was handed
    to the port, in time all the same."""
    rig = pelco_rig(tmp_path / "head", 9600)
    with HeadEmulator(rig):
        codec = make_codec("pelco-d", **rig.servo_params())
        with ServoDriver(codec, SerialTransport(rig.servo.port, 9600), 0.040) as driver:
            for k in range(5):
                driver.set_position(math.radians(k), 0.0)
            driver.query_position()
            assert driver.counters["timeouts"] == 0


class VirtualLine:
    """A `SerialTransport` stand-in on the emulated line and a clock of its own: the host's
    bytes reach the head at the baud rate, its answers come back when their last byte would."""

    url = "virtual://head"

    def __init__(self, rig, t0_s: float = 100.0) -> None:
        self.line = HeadLine(rig, t0_s)
        self.baud = rig.servo.baud
        self.byte_time_s = self.line.byte_time_s
        self.line_s = 0.0
        self.counters: Counter[str] = Counter()
        self.now_s = t0_s
        self.is_connected = False
        self.written: list[bytes] = []
        self._free_s = t0_s

    def wall_ns(self) -> int:
        """The line's clock as a wall clock."""
        return round(self.now_s * 1e9)

    def connect(self) -> None:
        self.is_connected = True

    def disconnect(self) -> None:
        self.is_connected = False

    def write(self, data: bytes) -> int:
        self.line.receive(data, self.now_s)
        self.written.append(data)
        self._free_s = max(self._free_s, self.now_s) + len(data) * self.byte_time_s
        self.line_s += len(data) * self.byte_time_s
        return self.wall_ns()

    def line_busy_s(self) -> float:
        return max(0.0, self._free_s - self.now_s)

    def read(self, timeout_s: float) -> tuple[bytes, int]:
        """Blocks as a port does: until the next byte is due, or for the whole timeout."""
        due = self.line.next_due_s()
        until_s = self.now_s + max(0.0, timeout_s)
        self.now_s = max(self.now_s, due) if due is not None and due <= until_s else until_s
        data = self.line.service(self.now_s)
        self.line_s += len(data) * self.byte_time_s
        return data, self.wall_ns()

    def run_until(self, t_s: float) -> None:
        self.now_s = t_s
        self.line.service(t_s)


def test_each_axis_is_dated_when_the_head_read_it() -> None:
    """A head panning at 60°/s and tilting at 30°/s on a 9600 baud Pelco-D line: pan and tilt
    come in two exchanges 16 ms apart, each answer 7 ms on the line; each reading is where the
    head was at its own date, within the device's 1 ms to answer."""
    rig = pelco_rig("unused", 9600)
    transport = VirtualLine(rig)
    codec = make_codec("pelco-d", **rig.servo_params())
    driver = ServoDriver(codec, transport, 0.1, lambda: transport.now_s)  # type: ignore[arg-type]
    driver.connect()
    driver.set_velocity(math.radians(60.0), math.radians(30.0))
    transport.run_until(101.0)  # up to speed
    where = driver.query_position()
    reply_s = 7 * 10 / 9600
    assert (where.t_tilt_ns - where.t_pan_ns) / 1e9 == pytest.approx(2 * reply_s + 1e-3, abs=1e-6)
    for angle, rate_deg_s, t_ns in (
        (where.pan_rad, 60.0, where.t_pan_ns),
        (where.tilt_rad, 30.0, where.t_tilt_ns),
    ):
        pose = transport.line.mechanics.pose_at(t_ns / 1e9)
        true = pose.pan_rad if rate_deg_s == 60.0 else pose.tilt_rad
        # read 1 ms before it began to answer; dated by its last byte it would be 7 ms off
        assert math.degrees(true - angle) == pytest.approx(rate_deg_s * 1e-3, abs=0.011)
        assert abs(math.degrees(true - angle)) < rate_deg_s * reply_s / 3
