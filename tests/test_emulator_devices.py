"""The head emulator's device side, on a clock of the test's own (no pty, no sleeping): each
protocol answered byte-exactly as PROTOCOLS.md says, silence where the device is silent, VISCA
ACK/completion timing, PTU `*`/`!`, Dynamixel status packets, and the line's timing at its baud
rate."""

from __future__ import annotations

import math

import pytest

from gazed.config import parse_rig
from gazed.servo import make_codec
from gazed.servo.dynamixel_packets import crc16, le, packet, status_packet
from gazed.servo.pelco_d import frame as pelco_frame
from gazed.sim.head_line import HeadLine

H = bytes.fromhex
STEP_S = 0.0005


def make_line(servo: str, sim: str = "", head: str = "") -> HeadLine:
    rig = parse_rig(
        f'[rig]\nname = "e"\n[servo]\n{servo}\n[sim]\nhead_latency_ms = 20\n{sim}\n[head]\n{head}\n'
    )
    return HeadLine(rig, 0.0)


class Host:
    """Writes bytes to the line and collects what comes back, on a fake clock."""

    def __init__(self, line: HeadLine) -> None:
        self.line = line
        self.t_s = 0.0

    def run(self, duration_s: float) -> bytes:
        out = bytearray()
        end = self.t_s + duration_s
        while self.t_s < end:
            self.t_s += STEP_S
            out += self.line.service(self.t_s)
        return bytes(out)

    def until(self, predicate, limit_s: float = 5.0) -> bytes:
        out = bytearray()
        end = self.t_s + limit_s
        while not predicate(bytes(out)):
            assert self.t_s < end, f"nothing matching within {limit_s} s: {bytes(out)!r}"
            self.t_s += STEP_S
            out += self.line.service(self.t_s)
        return bytes(out)

    def ask(self, data: bytes, expect_bytes: int, limit_s: float = 1.0) -> bytes:
        """Send `data`, return the first `expect_bytes` and anything after them that arrived
        with them."""
        self.line.receive(data, self.t_s)
        return self.until(lambda out: len(out) >= expect_bytes, limit_s)

    def check(self, data: bytes, expected: bytes) -> None:
        assert self.ask(data, len(expected)) == expected

    def settle(self) -> None:
        self.until(lambda _: self.line.mechanics.settled)


# --- Pelco-D -------------------------------------------------------------------------------


def pelco(**keys: object) -> Host:
    extra = "\n".join(f"{k} = {str(v).lower()}" for k, v in keys.items())
    return Host(make_line(f'protocol = "pelco-d"\nbaud = 9600\n{extra}'))


def test_pelco_answers_queries_and_nothing_else() -> None:
    host = pelco()
    host.line.receive(H("FF 01 00 4B 30 39 B5") + H("FF 01 00 4D 0B B8 11"), host.t_s)
    assert host.run(0.2) == b""  # motion commands: silence
    host.settle()
    assert host.ask(H("FF 01 00 51 00 00 52"), 7) == H("FF 01 00 59 30 39 C3")  # 123.45°
    assert host.ask(H("FF 01 00 53 00 00 54"), 7) == H("FF 01 00 5B 0B B8 1F")  # 30° down


def test_pelco_ignores_bad_checksums_and_other_cameras() -> None:
    host = pelco()
    host.line.receive(H("FF 01 00 4B 30 39 B6") + pelco_frame(2, 0, 0x4B, 0x30, 0x39), host.t_s)
    host.run(0.3)
    assert host.line.mechanics.pan.target_rad == 0.0
    host.line.receive(pelco_frame(2, 0, 0x51), host.t_s)
    assert host.run(0.1) == b""


def test_pelco_without_position_feedback_is_silent() -> None:
    host = pelco(position_feedback=False)
    host.line.receive(H("FF 01 00 51 00 00 52"), host.t_s)
    assert host.run(0.2) == b""


def test_pelco_drive_and_stop() -> None:
    host = pelco(pan_speed_max_deg_s=63)
    host.line.receive(H("FF 01 00 02 20 00 23"), host.t_s)  # right at 0x20 = 32 deg/s
    host.run(1.0)
    assert math.degrees(host.line.mechanics.pan.velocity_rad_s) == pytest.approx(32.0)
    host.line.receive(H("FF 01 00 00 00 00 01"), host.t_s)
    host.settle()
    assert host.line.mechanics.pan.velocity_rad_s == 0.0


def test_line_timing_at_9600_baud() -> None:
    """7 bytes out, 1 ms turn-around, 7 bytes back: 2 × 7.29 ms + 1 ms."""
    host = pelco()
    host.ask(H("FF 01 00 51 00 00 52"), 7)
    assert host.t_s == pytest.approx(2 * 7 * 10 / 9600 + 0.001, abs=STEP_S)


# --- VISCA ---------------------------------------------------------------------------------


def visca() -> Host:
    """An EVI-D70: ±170° pan, -30..90° tilt, 0.075° a unit."""
    return Host(
        make_line(
            'protocol = "visca"\nbaud = 9600\npan_deg_per_unit = 0.075',
            head="pan_min_deg = -180\npan_max_deg = 180\ntilt_max_deg = 90",
        )
    )


def test_visca_ack_now_completion_when_the_move_ends() -> None:
    host = visca()
    m = host.line.mechanics
    command = H("81 01 06 02 18 14 0F 07 02 05 00 04 0B 00 FF")  # pan -2267, tilt +1200 units
    assert host.ask(command, 3) == H("90 41 FF")
    t_ack = host.t_s
    assert not m.settled
    assert host.until(lambda out: len(out) >= 3) == H("90 51 FF")
    # the completion came when the axes settled: the longer (pan, 170°) move at 120°/s, 600°/s²
    move_s = (
        math.radians(170.025) / m.pan.rate_max_rad_s + m.pan.rate_max_rad_s / m.pan.accel_max_rad_s2
    )
    assert host.t_s - t_ack == pytest.approx(0.020 + move_s, abs=0.01)
    assert m.settled
    assert host.ask(H("81 09 06 12 FF"), 11) == H("90 50 0F 07 02 05 00 04 0B 00 FF")


def test_visca_a_new_move_supersedes_the_one_executing() -> None:
    host = visca()
    assert host.ask(H("81 01 06 02 18 14 00 04 00 00 00 00 00 00 FF"), 3) == H("90 41 FF")
    # the second move goes into socket 2; socket 1's move is over: its completion follows
    assert host.ask(H("81 01 06 02 18 14 00 00 00 00 00 00 00 00 FF"), 6) == H("90 42 FF 90 51 FF")
    assert host.until(lambda out: len(out) >= 3) == H("90 52 FF")


def test_visca_errors_and_housekeeping() -> None:
    host = visca()
    assert host.ask(H("81 01 04 07 02 FF"), 4) == H("90 60 02 FF")  # zoom: not this head's
    assert host.ask(H("81 01 06 02 19 14 00 00 00 00 00 00 00 00 FF"), 4) == H("90 60 02 FF")
    assert host.ask(H("81 22 FF"), 4) == H("90 62 05 FF")  # nothing to cancel in socket 2
    host.ask(H("81 01 06 02 18 14 00 04 00 00 00 00 00 00 FF"), 3)
    assert host.ask(H("81 21 FF"), 4) == H("90 61 04 FF")
    assert host.run(2.0) == b""  # cancelled: no completion
    assert host.ask(H("81 01 00 01 FF"), 3) == H("90 50 FF")  # IF_Clear
    host.line.receive(H("82 09 06 12 FF"), host.t_s)  # camera 2's inquiry
    assert host.run(0.1) == b""


def test_visca_drive_completes_at_once() -> None:
    host = visca()
    assert host.ask(H("81 01 06 01 0C 0A 02 03 FF"), 6) == H("90 41 FF 90 51 FF")
    host.run(1.0)
    assert math.degrees(host.line.mechanics.pan.velocity_rad_s) == pytest.approx(60.0)  # 12/24


# --- PTU -----------------------------------------------------------------------------------


def ptu() -> Host:
    return Host(
        make_line(
            'protocol = "flir-ptu"\nbaud = 9600\npan_arcsec_per_position = 92.5714',
            head="pan_min_deg = -90\npan_max_deg = 90\npan_rate_max_deg_s = 60",
        )
    )


def test_ptu_echo_verbose_then_terse() -> None:
    host = ptu()
    host.check(b"PP ", b"PP * Current Pan position is 0\r\n")  # power-up: echo, verbose
    host.check(b"PR ", b"PR * 92.5714 seconds arc per position\r\n")
    host.check(b"ED ", b"ED *\r\n")
    host.check(b"FT ", b"*\r\n")
    host.check(b"PR ", b"* 92.5714\r\n")
    host.check(b"PN ", b"* -3501\r\n")  # -90° is -3500.0x positions: rounded outwards
    host.check(b"PX ", b"* 3501\r\n")
    host.check(b"PU ", b"* 2333\r\n")  # 60°/s


def test_ptu_moves_and_refuses() -> None:
    host = ptu()
    host.check(b"ED FT ", b"ED *\r\n*\r\n")
    host.check(b"PP828 ", b"*\r\n")
    host.settle()
    host.check(b"PP ", b"* 828\r\n")
    host.check(b"PP3502 ", b"! Maximum allowable Pan position is 3501\r\n")
    host.check(b"PS3000 ", b"! Pan speed cannot exceed 2333 positions/sec\r\n")
    host.check(b"XY ", b"! Illegal Command\r\n")
    host.check(b"pp ", b"* 828\r\n")  # case-insensitive


def test_ptu_await_and_limit_notices() -> None:
    host = ptu()
    host.check(b"ED FT ", b"ED *\r\n*\r\n")
    host.line.receive(b"PP-1000 A ", host.t_s)
    assert host.until(lambda out: len(out) >= 3) == b"*\r\n"
    t_first = host.t_s
    assert host.until(lambda out: len(out) >= 3) == b"*\r\n"  # A: once the move is done
    assert host.line.mechanics.settled and host.t_s - t_first > 0.3
    host.line.receive(b"CV PS2000 ", host.t_s)  # run into the pan limit
    assert host.until(lambda out: b"!P" in out) == b"*\r\n*\r\n!P\r\n"


# --- Dynamixel -----------------------------------------------------------------------------


def dynamixel() -> Host:
    return Host(make_line('protocol = "dynamixel"\nbaud = 57600'))


def test_dynamixel_ping_read_write_status_packets() -> None:
    host = dynamixel()
    ping = packet(1, 0x01)
    assert host.ask(ping, 14) == status_packet(1, 0, H("24 04 2E"))  # model 1060, firmware 46
    read = H("FF FF FD 00 01 07 00 02 84 00 04 00 1D 15")  # Present Position, e-manual example
    assert host.ask(read, 15) == status_packet(1, 0, le(2048, 4))
    torque_on = packet(1, 0x03, H("40 00 01"))
    assert host.ask(torque_on, 11) == status_packet(1, 0)
    goal = H("FF FF FD 00 01 09 00 03 74 00 00 02 00 00 CA 89")  # Goal Position 512
    assert host.ask(goal, 11) == status_packet(1, 0)
    host.settle()
    assert host.ask(read, 15) == status_packet(1, 0, le(512, 4))


def test_dynamixel_sync_write_is_silent_and_sync_read_answers_in_order() -> None:
    host = dynamixel()
    codec = make_codec("dynamixel")
    host.line.receive(codec.encode_sync_write("torque_enable", {1: 1, 2: 1}), host.t_s)
    host.line.receive(codec.encode_sync_write("goal_position", {1: 1500, 2: 2100}), host.t_s)
    assert host.run(0.1) == b""
    host.settle()
    (query,) = codec.encode_query_position()
    host.check(query, status_packet(1, 0, le(1500, 4)) + status_packet(2, 0, le(2100, 4)))


def test_dynamixel_errors() -> None:
    host = dynamixel()
    host.ask(packet(1, 0x03, H("40 00 01")), 11)  # torque on
    mode = packet(1, 0x03, H("0B 00 01"))  # Operating Mode is EEPROM
    assert host.ask(mode, 11) == status_packet(1, 7)  # access error
    assert host.ask(packet(1, 0x03, H("74 00 00 10 00 00")), 11) == status_packet(1, 6)  # 4096
    assert host.ask(packet(1, 0x55 - 1), 11) == status_packet(1, 2)  # no such instruction
    corrupt = bytearray(packet(2, 0x01))
    corrupt[-1] ^= 0xFF
    assert host.ask(bytes(corrupt), 11) == status_packet(2, 3)  # CRC error
    assert crc16(status_packet(2, 3)[:-2]) == int.from_bytes(status_packet(2, 3)[-2:], "little")
    host.line.receive(packet(0xFE, 0x03, H("40 00 00")), host.t_s)  # broadcast write
    assert host.run(0.1) == b""


# --- the mechanism -------------------------------------------------------------------------


def test_latency_rate_and_acceleration_limits() -> None:
    line = make_line(
        'protocol = "visca"\nbaud = 115200',
        head="pan_rate_max_deg_s = 50\npan_accel_max_deg_s2 = 200",
    )
    host = Host(line)
    host.line.receive(H("81 01 06 02 18 14 00 01 00 00 00 00 00 00 FF"), 0.0)  # +256 units
    samples = []
    for _ in range(4000):
        host.t_s += STEP_S
        line.service(host.t_s)
        samples.append(line.mechanics.pose_at(host.t_s))
    received_s = 15 * 10 / 115200
    started = next(s.t_s for s in samples if s.pan_rad != 0.0)
    assert started == pytest.approx(received_s + 0.020, abs=2 * STEP_S)  # head_latency_ms
    assert max(s.pan_rate_rad_s for s in samples) == pytest.approx(math.radians(50), rel=1e-6)
    rates = [s.pan_rate_rad_s for s in samples]
    accels = [abs(b - a) / (20 * STEP_S) for a, b in zip(rates[::20], rates[20::20], strict=False)]
    assert max(accels) <= math.radians(200) * 1.1
    assert math.degrees(samples[-1].pan_rad) == pytest.approx(256 * 0.075)


def test_encoder_resolution_and_backlash() -> None:
    line = make_line(
        'protocol = "flir-ptu"\nbaud = 115200\npan_arcsec_per_position = 3.6',  # 0.001°
        sim="head_encoder_resolution_deg = 0.1\nhead_backlash_deg = 0.5",
    )
    host = Host(line)
    host.check(b"ED FT ", b"ED *\r\n*\r\n")
    host.check(b"PP10040 ", b"*\r\n")  # 10.04°
    host.settle()
    assert host.ask(b"PP ", 9) == b"* 10000\r\n"  # the encoder's 0.1° steps
    camera = line.mechanics.pose_at(host.t_s)
    # the camera trails the motor by half the play (1e-5° for the last step's overshoot)
    assert math.degrees(camera.pan_rad) == pytest.approx(10.04 - 0.25, abs=1e-5)
    host.check(b"PP9940 ", b"*\r\n")  # back 0.1°: the motor turns, the camera does not
    host.settle()
    assert math.degrees(line.mechanics.pose_at(host.t_s).pan_rad) == pytest.approx(
        10.04 - 0.25, abs=1e-5
    )
    assert math.degrees(line.mechanics.pan.position_rad) == pytest.approx(9.94)
