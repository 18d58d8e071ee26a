"""VISCA codec against the packets of PROTOCOLS.md §2 (Sony EVI-D70 / SRG-300H manuals)."""

from __future__ import annotations

import math

import pytest

from gazed.servo import CodecError, make_codec
from gazed.servo.visca import from_nibbles, to_nibbles

H = bytes.fromhex


@pytest.fixture
def codec():
    return make_codec("visca", address=1, pan_deg_per_unit=0.075, tilt_deg_per_unit=0.075)


def test_signed_nibbles() -> None:
    assert to_nibbles(-1) == H("0F 0F 0F 0F")
    assert to_nibbles(2267) == H("00 08 0D 0B")
    assert to_nibbles(-2267) == H("0F 07 02 05")
    assert from_nibbles(H("0F 0F 0F 0F")) == -1  # pyvisca returns 65535
    assert from_nibbles(H("0F 07 02 05")) == -2267
    assert from_nibbles(H("08 00 00 00")) == -32768
    with pytest.raises(CodecError):
        to_nibbles(32768)


def test_absolute_position_packet(codec) -> None:
    (packet,) = codec.encode_set_position(math.radians(-2267 * 0.075), math.radians(1200 * 0.075))
    assert packet == H("81 01 06 02 18 14 0F 07 02 05 00 04 0B 00 FF")
    assert codec.replies_expected(packet) == 1
    assert all(b != 0xFF for b in packet[:-1])


def test_position_out_of_16_bits_is_refused(codec) -> None:
    with pytest.raises(CodecError):
        codec.encode_set_position(math.radians(0.075 * 40000), 0.0)


def test_query_and_reply(codec) -> None:
    assert codec.encode_query_position() == [H("81 09 06 12 FF")]
    (reply,) = codec.feed(H("90 50 0F 07 02 05 00 04 0B 00 FF"))
    assert reply.kind == "position"
    assert math.degrees(reply.pan_rad) == pytest.approx(-2267 * 0.075)
    assert math.degrees(reply.tilt_rad) == pytest.approx(1200 * 0.075)


def test_ack_completion_and_errors(codec) -> None:
    replies = codec.feed(
        H("90 41 FF 90 51 FF 90 42 FF 90 52 FF 90 60 02 FF 90 60 03 FF 90 61 04 FF")
        + H("90 62 05 FF 90 61 41 FF 90 60 01 FF 90 50 FF 90 38 FF")
    )
    kinds = [(r.kind, r.socket, r.reason, r.asynchronous) for r in replies]
    assert kinds == [
        ("ack", 1, None, False),
        ("completion", 1, None, True),
        ("ack", 2, None, False),
        ("completion", 2, None, True),
        ("error", 0, "syntax error", False),
        ("error", 0, "command buffer full", False),
        ("error", 1, "command cancelled", False),
        ("error", 2, "no socket", False),
        ("error", 1, "command not executable", False),
        ("error", 0, "message length error", False),
        ("completion", 0, None, False),  # IF_Clear's answer
        ("ok", None, "network change", True),
    ]


def test_replies_of_other_cameras_are_skipped(codec) -> None:
    assert codec.feed(H("A0 41 FF")) == []  # camera 2
    assert [r.kind for r in codec.feed(H("90 41 FF"))] == ["ack"]


def test_drive_and_stop(codec) -> None:
    pan_max, tilt_max = math.radians(120.0), math.radians(90.0)
    # up-left, pan speed 3, tilt speed 4: the manual's example
    (drive,) = codec.encode_set_velocity(-pan_max * 3 / 24, tilt_max * 4 / 20)
    assert drive == H("81 01 06 01 03 04 01 01 FF")
    (right_down,) = codec.encode_set_velocity(pan_max, -tilt_max)
    assert right_down == H("81 01 06 01 18 14 02 02 FF")
    (stop,) = codec.encode_stop()
    assert stop[:4] == H("81 01 06 01") and stop[6:] == H("03 03 FF")  # speeds: don't care
    (still,) = codec.encode_set_velocity(0.0, 0.0)
    assert still[6:] == H("03 03 FF")


def test_if_clear(codec) -> None:
    assert codec.encode_if_clear() == [H("81 01 00 01 FF")]


def test_address_and_speed_bounds() -> None:
    with pytest.raises(CodecError):
        make_codec("visca", address=8)
    with pytest.raises(CodecError):
        make_codec("visca", pan_speed=25)
    camera3 = make_codec("visca", address=3)
    assert camera3.encode_query_position() == [H("83 09 06 12 FF")]
    assert [r.kind for r in camera3.feed(H("B0 41 FF"))] == ["ack"]
