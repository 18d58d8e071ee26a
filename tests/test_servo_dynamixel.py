"""Dynamixel 2.0 codec against PROTOCOLS.md §4 (ROBOTIS e-manual examples), CRC and stuffing."""

from __future__ import annotations

import math

import pytest

from gazed.servo import CodecError, Reply, make_codec
from gazed.servo.dynamixel_packets import (
    crc16,
    decode_packet,
    le,
    packet,
    split_packets,
    status_packet,
    stuff,
    unstuff,
)

H = bytes.fromhex


@pytest.fixture
def codec():
    return make_codec("dynamixel", pan_id=1, tilt_id=2, center=2048, units_per_rev=4096)


def test_crc_check_value() -> None:
    assert crc16(b"123456789") == 0xFEE8


def test_write_goal_position_example() -> None:
    assert packet(1, 0x03, H("74 00 00 02 00 00")) == H(
        "FF FF FD 00 01 09 00 03 74 00 00 02 00 00 CA 89"
    )


def test_sync_write_example(codec) -> None:
    frame = codec.encode_sync_write("goal_position", {1: 150, 2: 170})
    assert frame == H("FF FF FD 00 FE 11 00 83 74 00 04 00 01 96 00 00 00 02 AA 00 00 00 82 87")
    assert codec.replies_expected(frame) == 0  # Sync Write gets no status


def test_set_position_is_one_sync_write_of_both_ids(codec) -> None:
    (frame,) = codec.encode_set_position(
        (150 - 2048) * 2 * math.pi / 4096, (170 - 2048) * 2 * math.pi / 4096
    )
    assert frame == H("FF FF FD 00 FE 11 00 83 74 00 04 00 01 96 00 00 00 02 AA 00 00 00 82 87")


def test_read_present_position_example_and_status() -> None:
    assert packet(1, 0x02, H("84 00 04 00")) == H("FF FF FD 00 01 07 00 02 84 00 04 00 1D 15")
    assert status_packet(1, 0, H("A6 00 00 00")) == H(
        "FF FF FD 00 01 08 00 55 00 A6 00 00 00 8C C0"
    )


def test_sync_read_replies_one_status_per_id(codec) -> None:
    (query,) = codec.encode_query_position()
    p = decode_packet(query)
    assert (p.device_id, p.instruction, p.params) == (0xFE, 0x82, H("84 00 04 00 01 02"))
    assert codec.replies_expected(query) == 2
    replies = codec.feed(
        H("FF FF FD 00 01 08 00 55 00 A6 00 00 00 8C C0") + status_packet(2, 0, le(-1, 4))
    )
    assert [r.kind for r in replies] == ["position", "position"]
    assert replies[0].pan_rad == pytest.approx((166 - 2048) * 2 * math.pi / 4096)
    assert replies[0].tilt_rad is None
    # signed int32: -1, which the SDK returns as 4294967295
    assert replies[1].tilt_rad == pytest.approx((-1 - 2048) * 2 * math.pi / 4096)


def test_goal_velocity_is_signed() -> None:
    codec = make_codec("dynamixel")
    frames = codec.encode_set_velocity(-150 * 0.229 * 2 * math.pi / 60, 0.0)
    # torque off, operating mode 1 (velocity), torque on, then Goal Velocity
    modes = [decode_packet(f).params for f in frames[:3]]
    assert modes[1] == H("0B 00 01 00 01 01 02 01")
    goal = decode_packet(frames[3]).params
    assert goal[:4] == H("68 00 04 00") and goal[4:9] == H("01 6A FF FF FF")


def test_byte_stuffing_round_trip() -> None:
    params = H("FF FF FD 00 FF FF FD FD")
    assert stuff(params) == H("FF FF FD FD 00 FF FF FD FD FD")
    assert unstuff(stuff(params)) == params
    frame = packet(1, 0x03, H("74 00") + params)
    # LEN counts the inserted bytes; the CRC covers the stuffed packet
    instruction_and_address = 3
    assert int.from_bytes(frame[5:7], "little") == instruction_and_address + 10 + 2
    assert crc16(frame[:-2]) == int.from_bytes(frame[-2:], "little")
    split = split_packets(bytearray(frame))
    assert (len(split.frames), split.discarded_bytes, split.rejected) == (1, 0, [])
    assert split.frames[0].params == H("74 00") + params


def test_stuffed_goal_positions_encode_and_decode(codec) -> None:
    # Goal 0xFDFFFF00 (-33554688 as int32) for id 1 puts FF FF FD into the parameters
    frame = codec.encode_sync_write("goal_position", {1: -33554688, 2: 0})
    assert H("FF FF FD FD") in frame[7:]
    p = decode_packet(frame)
    assert p.params[5:9] == H("00 FF FF FD")


def test_status_errors(codec) -> None:
    (reply,) = codec.feed(status_packet(1, 0x84))
    assert reply.kind == "error"
    assert (
        reply.reason == "data range error; hardware alert (read Hardware Error Status, address 70)"
    )
    (crc_error,) = codec.feed(status_packet(2, 3))
    assert crc_error.reason == "CRC error"


def test_corrupt_packets_are_counted_not_decoded(codec) -> None:
    good = H("FF FF FD 00 01 08 00 55 00 A6 00 00 00 8C C0")
    bad = good[:-1] + bytes([good[-1] ^ 1])
    assert codec.feed(bad) == []
    assert codec.bad_frames == 1
    assert [r.kind for r in codec.feed(good)] == ["position"]


def test_handshake_pings_sets_position_mode_and_torque(codec) -> None:
    table = {1: {"mode": 1}, 2: {"mode": 4}}
    sent = []

    def exchange(frame: bytes) -> list[Reply]:
        p = decode_packet(frame)
        sent.append((p.device_id, p.instruction, p.params))
        if p.instruction == 0x01:
            answer = status_packet(p.device_id, 0, le(1060, 2) + b"\x2e")
        elif p.instruction == 0x02:
            answer = status_packet(p.device_id, 0, bytes([table[p.device_id]["mode"]]))
        else:
            if p.params[:2] == H("0B 00"):
                table[p.device_id]["mode"] = p.params[2]
            answer = status_packet(p.device_id, 0)
        return codec.feed(answer)

    codec.handshake(exchange)
    assert table == {1: {"mode": 3}, 2: {"mode": 4}}  # velocity -> position; extended kept
    assert (1, 0x03, H("40 00 00")) in sent  # torque off before the EEPROM write
    assert sent[-1] == (2, 0x03, H("40 00 01"))  # torque on
    assert codec.model_numbers == {1: 1060, 2: 1060}
    assert codec.position_mode == 3  # not both extended: 0..4095


def test_stop_needs_a_position_in_position_mode(codec) -> None:
    with pytest.raises(CodecError, match="position reply"):
        codec.encode_stop()
    codec.encode_query_position()
    codec.feed(status_packet(1, 0, le(2000, 4)) + status_packet(2, 0, le(2100, 4)))
    (stop,) = codec.encode_stop()
    assert decode_packet(stop).params == H("74 00 04 00 01 D0 07 00 00 02 34 08 00 00")


def test_goal_outside_position_mode_is_refused(codec) -> None:
    with pytest.raises(CodecError, match="position mode"):
        codec.encode_set_position(math.radians(190.0), 0.0)


def test_a_request_encoded_and_not_sent_takes_no_reply(codec) -> None:
    codec.encode_read(1, "operating_mode")  # encoded, never written (a timeout came first)
    codec.encode_ping(2)
    for frame in codec.encode_query_position():
        codec.sent(frame)
    replies = codec.feed(status_packet(1, 0, le(166, 4)) + status_packet(2, 0, le(-1, 4)))
    assert [r.kind for r in replies] == ["position", "position"]
    assert replies[0].pan_rad == pytest.approx((166 - 2048) * 2 * math.pi / 4096)
    assert replies[1].tilt_rad == pytest.approx((-1 - 2048) * 2 * math.pi / 4096)


def test_replies_are_matched_to_the_requests_sent(codec) -> None:
    for frame in (
        codec.encode_read(1, "operating_mode"),
        codec.encode_write(2, "torque_enable", 1),
    ):
        codec.sent(frame)
    for frame in codec.encode_query_position():
        codec.sent(frame)
    # a four-byte value read from id 1 is a value, not a position; the ack is an ack
    replies = codec.feed(
        status_packet(1, 0, le(3, 4))
        + status_packet(2, 0)
        + status_packet(1, 0, le(2000, 4))
        + status_packet(2, 0, le(2100, 4))
    )
    assert [r.kind for r in replies] == ["ok", "ack", "position", "position"]
    assert replies[0].value == 3
    assert replies[2].pan_rad == pytest.approx((2000 - 2048) * 2 * math.pi / 4096)


def test_the_mode_follows_the_mode_writes_sent(codec) -> None:
    unsent = codec.encode_set_velocity(0.1, 0.0)  # encoded, never written
    assert codec.stop_needs_position  # still in position mode: a zero velocity would not stop
    for frame in codec.encode_set_velocity(0.1, 0.0):
        codec.sent(frame)
    assert not codec.stop_needs_position
    (stop,) = codec.encode_stop()
    assert decode_packet(stop).params[:2] == H("68 00")  # Goal Velocity 0
    back = codec.encode_set_position(0.0, 0.0)
    assert len(back) == len(unsent) == 4  # torque off, mode, torque on, then the goal
    assert not codec.stop_needs_position  # encoding the way back changes nothing
    for frame in back:
        codec.sent(frame)
    assert codec.stop_needs_position
    assert codec.encode_set_position(0.0, 0.0) == back[3:]
