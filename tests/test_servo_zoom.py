"""Zoom on a VISCA head: CAM_Zoom Direct and the zoom position inquiry against bytes from the
specification and from an independent implementation, the emulated camera's lens, and the head
link driving the zoom from demands and reading it into odometry."""

from __future__ import annotations

import itertools
import math

import pytest
from servo_link_support import demand
from test_servo_head_link import Link, odometry

from gazed.config import HeadSection, SimSection, ViscaServo
from gazed.servo.codec import CodecError
from gazed.servo.visca import ViscaCodec
from gazed.servo.zoom_drive import ZOOM_STEP
from gazed.sim.head_mechanics import HeadMechanics
from gazed.sim.head_visca import ViscaDevice

ZOOM_LENS = """
[camera]
zoom_focal_px = [[0.0, 554.0], [1.0, 5540.0]]
"""


def test_zoom_direct_and_inquiry_match_chromiums_visca_webcam() -> None:
    # Chromium's extensions ViscaWebcamTest.Zoom: set 0x6253 -> 81 01 04 47 06 02 05 03 FF;
    # the inquiry 81 09 04 47 FF, answered with nibbles 01 02 03 04 (0x1234)
    codec = ViscaCodec(zoom_max_units=0x7FFF)
    assert codec.encode_set_zoom(0x6253 / 0x7FFF) == [bytes.fromhex("8101044706020503FF")]
    assert codec.encode_query_zoom() == [bytes.fromhex("81090447FF")]
    (reply,) = codec.feed(bytes.fromhex("905001020304FF"))
    assert reply.kind == "zoom" and reply.value == pytest.approx(0x1234 / 0x7FFF)


def test_zoom_positions_follow_the_sony_range_and_are_clamped() -> None:
    # Sony EVI-D70 / SRG: 8x 01 04 47 0p 0q 0r 0s FF, 0x0000 wide .. 0x4000 optical tele
    codec = ViscaCodec()
    assert codec.encode_set_zoom(0.0) == [bytes.fromhex("8101044700000000FF")]
    assert codec.encode_set_zoom(1.0) == [bytes.fromhex("8101044704000000FF")]
    assert codec.encode_set_zoom(2.0) == codec.encode_set_zoom(1.0)  # never past the tele end
    assert codec.encode_set_zoom(-1.0) == codec.encode_set_zoom(0.0)
    with pytest.raises(CodecError, match="not finite"):
        codec.encode_set_zoom(math.nan)
    assert codec.replies_expected(codec.encode_set_zoom(0.5)[0]) == 1  # its ACK
    assert codec.replies_expected(codec.encode_query_zoom()[0]) == 1


def test_a_zoom_reply_is_found_inside_garbage_and_a_pan_tilt_reply_is_not_taken_for_one() -> None:
    codec = ViscaCodec()
    replies = codec.feed(bytes.fromhex("1234FF90500200000 0FF".replace(" ", "")))
    assert [r.kind for r in replies] == ["zoom"]
    assert replies[0].value == pytest.approx(0.5)
    assert codec.discarded_bytes > 0
    (position,) = codec.feed(bytes.fromhex("90500000000000000000FF"))
    assert position.kind == "position"


def test_the_emulated_camera_moves_its_lens_and_answers_the_inquiry() -> None:
    servo = ViscaServo(protocol="visca", port="unused")
    mechanics = HeadMechanics(HeadSection(zoom_rate_max_s=0.5), SimSection(), t0_s=0.0)
    device = ViscaDevice(servo, mechanics)
    codec = ViscaCodec()
    assert [r.kind for r in codec.feed(device.receive(codec.encode_set_zoom(0.5)[0], 0.0))] == [
        "ack"
    ]
    # complete on arrival, long before the lens settles
    assert [r.kind for r in codec.feed(device.poll(0.2))] == ["completion"]
    (early,) = codec.feed(device.receive(codec.encode_query_zoom()[0], 0.5))
    assert 0.1 < early.value < 0.3  # moving at 0.5 of the range a second
    (settled,) = codec.feed(device.receive(codec.encode_query_zoom()[0], 3.0))
    assert settled.value == pytest.approx(0.5)
    (error,) = codec.feed(device.receive(bytes.fromhex("8101044705000000FF"), 3.0))
    assert error.kind == "error" and error.reason == "syntax error"  # past the tele end


def test_a_command_takes_its_mechanism_over_and_a_third_finds_the_buffer_full() -> None:
    """Sony's two sockets: a pan-tilt move executing in one and a zoom in the other; a third
    command is refused with buffer full until one completes, and a new command for either
    mechanism takes it over from the one executing there."""
    servo = ViscaServo(protocol="visca", port="unused")
    mechanics = HeadMechanics(HeadSection(zoom_rate_max_s=0.5), SimSection(), t0_s=0.0)
    device = ViscaDevice(servo, mechanics)
    codec = ViscaCodec()
    far = codec.encode_set_position(math.radians(60.0), 0.0)[0]
    back = codec.encode_set_position(0.0, 0.0)[0]
    assert device.receive(far, 0.0) == bytes.fromhex("9041FF")
    assert device.receive(codec.encode_set_zoom(0.5)[0], 0.0) == bytes.fromhex("9042FF")
    assert device.receive(back, 0.001) == bytes.fromhex("906003FF")  # both sockets busy
    assert device.poll(0.1) == bytes.fromhex("9052FF")  # the zoom completes on arrival
    # socket 2 takes the move back; socket 1's move, taken over, completes after its ACK
    assert device.receive(back, 0.1) == bytes.fromhex("9042FF 9051FF")
    assert device.receive(codec.encode_set_zoom(0.6)[0], 0.2) == bytes.fromhex("9041FF")
    # a cancelled zoom stops the lens, not the pan-tilt move
    assert device.receive(bytes.fromhex("8121FF"), 0.203) == bytes.fromhex("906104FF")
    device.poll(1.0)
    assert mechanics.zoom.velocity_rad_s == 0.0 and mechanics.pan.target_rad == 0.0


def test_the_link_drives_the_zoom_within_its_rate_and_reports_it_in_odometry() -> None:
    link = Link(baud=115200, protocol="visca", sections=ZOOM_LENS)
    assert link.link.zoom is not None
    first = link.step()
    assert first.odometry is not None and first.odometry.zoom == pytest.approx(0.0)
    zoom_in = demand(0.0, 0.0).model_copy(update={"zoom": 0.8})
    readings = odometry(link.run(1.0, keep_demanding=zoom_in))
    assert 0.3 < readings[-1].zoom < 0.6  # the rig's 0.5 a second, from 0
    zooms = [r.zoom for r in readings]
    assert all(b >= a - ZOOM_STEP for a, b in itertools.pairwise(zooms))
    readings = odometry(link.run(1.5, keep_demanding=zoom_in))
    assert readings[-1].zoom == pytest.approx(0.8, abs=1e-3)
    assert link.link.counters()["errors"] == 0
    writes = link.link.zoom.writes
    assert writes <= 2.5 / 0.1 + 2  # at most one zoom command per period
    link.link.close()
    assert link.line.line.mechanics.zoom.target_rad == 0.0  # parked at the widest view


def test_a_head_without_a_zoom_lens_reports_none_and_sends_no_zoom() -> None:
    link = Link(baud=115200, protocol="visca")
    assert link.link.zoom is None
    zoom_in = demand(0.0, 0.0).model_copy(update={"zoom": 0.8})
    readings = odometry(link.run(0.3, keep_demanding=zoom_in))
    assert readings and all(r.zoom is None for r in readings)
    assert not any(frame[1:4] == bytes.fromhex("010447") for frame in link.line.written)


def test_the_digital_head_zooms_its_view_and_reports_the_zoom() -> None:
    from gazed.config import DigitalServo
    from gazed.servo.digital_head import DigitalHead
    from gazed.servo.zoom_drive import ZoomDrive

    clock = [0.0]
    head = DigitalHead(
        HeadSection(zoom_rate_max_s=1.0),
        DigitalServo(protocol="digital", latency_ms=0.0),
        mono_s=lambda: clock[0],
        wall_ns=lambda: round(clock[0] * 1e9),
    )
    head.connect()
    drive = ZoomDrive(head, rate_max_s=0.5)
    drive.reset(head.query_zoom())
    drive.demand(0.4)
    for _ in range(200):  # 2 s of the link's steps
        clock[0] += 0.01
        drive.write(clock[0])
    assert drive.read() == pytest.approx(0.4, abs=1e-6)
    assert drive.writes <= 2.0 / 0.1 + 1


def test_pelco_d_zoom_frames_follow_the_extended_command_table() -> None:
    from gazed.servo.pelco_d import PelcoDCodec

    # FF addr 00 4F MSB LSB ck (PROTOCOLS.md §1, C466M-E §5.2.4); ck = sum of bytes 2-6 mod 256
    codec = PelcoDCodec()
    assert codec.zooms
    assert codec.encode_set_zoom(0.5) == [bytes.fromhex("FF01004F8000D0")]
    assert codec.encode_query_zoom() == [bytes.fromhex("FF010055000056")]
    assert codec.replies_expected(codec.encode_query_zoom()[0]) == 1
    (reply,) = codec.feed(bytes.fromhex("00FF01005D4000 9E".replace(" ", "")))
    assert reply.kind == "zoom" and reply.value == pytest.approx(0x4000 / 0xFFFF)
    assert not PelcoDCodec(position_feedback=False).zooms


@pytest.mark.parametrize("protocol", ["visca", "pelco-d"])
def test_the_link_zooms_each_protocol_on_its_emulated_head(protocol: str) -> None:
    link = Link(baud=115200, protocol=protocol, sections=ZOOM_LENS)
    link.step()
    zoom_in = demand(0.0, 0.0).model_copy(update={"zoom": 0.3})
    readings = odometry(link.run(1.5, keep_demanding=zoom_in))
    assert readings[-1].zoom == pytest.approx(0.3, abs=2e-3)
    assert link.link.counters()["errors"] == 0
