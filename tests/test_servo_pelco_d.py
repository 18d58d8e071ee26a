"""Pelco-D codec against the frames of PROTOCOLS.md §1 (Pelco D manual v2.1, C466M-E, vendor
tables), not against our own encoder."""

from __future__ import annotations

import math

import pytest

from gazed.servo import CodecError, make_codec
from gazed.servo.pelco_d import (
    checksum,
    pan_deg_from_raw,
    pan_raw_from_deg,
    tilt_deg_from_raw,
    tilt_raw_from_deg,
)

H = bytes.fromhex


@pytest.fixture
def codec():
    return make_codec("pelco-d", address=1)


def test_checksum_wraps_modulo_256() -> None:
    frame = H("FF FE 00 12 3F 3F 8E")
    assert checksum(frame[1:6]) == frame[6]


def test_set_position_is_the_pan_frame_then_the_tilt_frame(codec) -> None:
    pan_frame, tilt_frame = codec.encode_set_position(math.radians(123.45), math.radians(-30.0))
    assert pan_frame == H("FF 01 00 4B 30 39 B5")  # 123.45° -> 12345 = 0x3039
    assert tilt_frame == H("FF 01 00 4D 0B B8 11")  # 30° down -> 3000


def test_tilt_convention_up_is_36000_minus() -> None:
    assert tilt_raw_from_deg(10.0) == 35000  # 88 B8
    assert tilt_raw_from_deg(-30.0) == 3000
    assert tilt_raw_from_deg(0.0) == 0  # pyptzcontroller sends 36000 here
    assert tilt_raw_from_deg(-0.0) == 0
    assert tilt_deg_from_raw(35000) == pytest.approx(10.0)
    assert tilt_deg_from_raw(9000) == pytest.approx(-90.0)
    assert tilt_deg_from_raw(0) == 0.0


def test_angles_are_rounded_not_truncated() -> None:
    assert pan_raw_from_deg(0.29) == 29  # int(0.29*100) is 28
    assert pan_raw_from_deg(0.006) == 1
    assert pan_raw_from_deg(0.004) == 0
    assert tilt_raw_from_deg(-0.29) == 29


def test_pan_is_a_circle() -> None:
    assert pan_raw_from_deg(-10.0) == 35000
    assert pan_raw_from_deg(359.999) == 0  # rounds to 36000, which is 0
    assert pan_deg_from_raw(35000) == pytest.approx(-10.0)
    assert pan_deg_from_raw(35000, center_deg=180.0) == pytest.approx(350.0)
    assert pan_deg_from_raw(18000) == pytest.approx(-180.0)


def test_query_and_replies(codec) -> None:
    assert codec.encode_query_position() == [H("FF 01 00 51 00 00 52"), H("FF 01 00 53 00 00 54")]
    (pan,) = codec.feed(H("FF 01 00 59 30 39 C3"))
    assert pan.kind == "position"
    assert math.degrees(pan.pan_rad) == pytest.approx(123.45)
    assert pan.tilt_rad is None
    (tilt,) = codec.feed(H("FF 01 00 5B 88 B8") + bytes([(1 + 0x5B + 0x88 + 0xB8) & 0xFF]))
    assert math.degrees(tilt.tilt_rad) == pytest.approx(10.0)
    assert tilt.pan_rad is None


def test_bad_checksum_and_other_addresses_are_not_replies(codec) -> None:
    assert codec.feed(H("FF 01 00 59 30 39 C4")) == []
    assert codec.feed(H("FF 02 00 59 30 39 C4")) == []  # camera 2's valid reply
    assert codec.discarded_bytes == 14  # skipped as garbage, byte by byte
    (reply,) = codec.feed(H("FF 01 00 59 30 39 C3"))
    assert math.degrees(reply.pan_rad) == pytest.approx(123.45)


def test_stop_and_drive_frames(codec) -> None:
    assert codec.encode_stop() == [H("FF 01 00 00 00 00 01")]
    tilt_max = math.radians(90.0)
    pan_max = math.radians(120.0)
    # speeds are steps 0..0x3F of the rig's pan/tilt_speed_max_deg_s
    assert codec.encode_set_velocity(0.0, tilt_max * 0x20 / 0x3F) == [H("FF 01 00 08 00 20 29")]
    assert codec.encode_set_velocity(-pan_max * 0x20 / 0x3F, 0.0) == [H("FF 01 00 04 20 00 25")]
    up_left = codec.encode_set_velocity(-pan_max * 0x10 / 0x3F, tilt_max * 0x18 / 0x3F)
    assert up_left == [H("FF 01 00 0C 10 18 35")]
    assert codec.encode_set_velocity(10.0, 0.0)[0][4] == 0x3F  # faster than 0x3F: capped


def test_replies_expected_only_for_queries(codec) -> None:
    for frame in codec.encode_set_position(0.1, 0.1) + codec.encode_stop():
        assert codec.replies_expected(frame) == 0
    for frame in codec.encode_query_position():
        assert codec.replies_expected(frame) == 1
    blind = make_codec("pelco-d", address=1, position_feedback=False)
    assert not blind.can_report_position
    assert all(blind.replies_expected(f) == 0 for f in blind.encode_query_position())


def test_bad_parameters_are_clear_errors() -> None:
    with pytest.raises(CodecError, match="unknown protocol"):
        make_codec("pelco-p")
    with pytest.raises(CodecError, match="pelco-d"):
        make_codec("pelco-d", adress=1)
    with pytest.raises(CodecError, match="address"):
        make_codec("pelco-d", address=0)
