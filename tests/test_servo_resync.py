"""The one resync loop of every codec and emulated device: frames in any chunking, garbage before
a start dropped and counted, a refused false start skipped one byte so the real frame behind it
is found, a frame still arriving kept, bad frames counted by what names them; and every codec
counts what its pass dropped the same way."""

from __future__ import annotations

import pytest

from gazed.servo import make_codec
from gazed.servo.dynamixel_packets import packet, status_packet
from gazed.servo.pelco_d import EXTENDED, word_frame
from gazed.servo.resync import Cut, Skip, Take, resync

SYNC = 0xAA


def three_byte_frames(front: bytearray) -> Cut[int]:
    """A toy protocol: `AA value checksum`, the checksum the value's complement."""
    if len(front) < 3:
        return None
    if front[2] != front[1] ^ 0xFF:
        return Skip(rejected=front[1])
    return Take(3, front[1])


def find_sync(front: bytearray) -> int:
    return front.find(SYNC)


def toy(value: int) -> bytes:
    return bytes((SYNC, value, value ^ 0xFF))


def test_frames_in_any_chunking_and_an_incomplete_tail_kept() -> None:
    stream = toy(1) + toy(2) + toy(3)
    for cut_at in range(len(stream) + 1):
        buffer = bytearray(stream[:cut_at])
        first = resync(buffer, three_byte_frames, find_sync)
        buffer += stream[cut_at:]
        second = resync(buffer, three_byte_frames, find_sync)
        assert first.frames + second.frames == [1, 2, 3]
        assert first.discarded_bytes == second.discarded_bytes == 0
        assert not buffer


def test_garbage_before_a_start_is_dropped_and_counted() -> None:
    buffer = bytearray(b"\x01\x02\x03" + toy(7) + b"\x04\x05")
    split = resync(buffer, three_byte_frames, find_sync)
    assert split.frames == [7]
    assert split.discarded_bytes == 5  # three before the frame, two after it
    assert not buffer


def test_a_refused_false_start_is_skipped_one_byte_so_the_frame_behind_it_is_found() -> None:
    # `AA AA 55` is no frame (55 is not AA's complement), but its second byte starts one
    buffer = bytearray(bytes((SYNC,)) + toy(SYNC))
    split = resync(buffer, three_byte_frames, find_sync)
    assert split.frames == [SYNC]
    assert split.discarded_bytes == 1
    assert split.rejected == [SYNC]  # the false start failed its check: a bad frame


def test_without_a_start_all_but_the_kept_tail_is_dropped() -> None:
    buffer = bytearray(b"\x01\x02\x03\x04\x05")
    split = resync(buffer, three_byte_frames, find_sync, keep=2)
    assert (split.frames, split.discarded_bytes, bytes(buffer)) == ([], 3, b"\x04\x05")
    buffer = bytearray(b"\x01")
    assert resync(buffer, three_byte_frames, find_sync, keep=2).discarded_bytes == 0
    assert buffer == b"\x01"


def test_a_cut_may_skip_many_bytes_and_take_frames_from_any_byte() -> None:
    def words(front: bytearray) -> Cut[bytes]:
        end = front.find(b";")
        if end < 0:
            return Skip(len(front)) if len(front) > 4 else None
        return Take(end + 1, bytes(front[:end]))

    buffer = bytearray(b"ab;cd;efghij")
    split = resync(buffer, words)
    assert (split.frames, split.discarded_bytes, buffer) == ([b"ab", b"cd"], 6, bytearray())


@pytest.mark.parametrize(
    ("protocol", "good", "bad_frames"),
    [
        # Pelco-D: a bad checksum is garbage, skipped byte by byte from its sync byte
        ("pelco-d", word_frame(1, EXTENDED["pan_response"], 100), 0),
        # Dynamixel: a bad CRC is a bad frame, named by its ID
        ("dynamixel", status_packet(1, 0, bytes(4)), 1),
    ],
)
def test_codecs_count_what_their_pass_dropped(protocol: str, good: bytes, bad_frames: int) -> None:
    codec = make_codec(protocol)
    corrupt = good[:-1] + bytes(((good[-1] + 1) & 0xFF,))
    replies = codec.feed(b"\x00\x01" + corrupt + good)
    assert [reply.raw for reply in replies] == [good]
    assert codec.bad_frames == bad_frames
    # the two garbage bytes, then the corrupt frame: skipped one byte at a time up to the
    # next place a frame may start (Pelco-D's 0xFF sync byte, Dynamixel's header)
    assert codec.discarded_bytes == 2 + len(corrupt)


def test_a_dynamixel_packet_still_arriving_is_dropped_when_a_valid_one_follows() -> None:
    codec = make_codec("dynamixel")
    head_only = packet(1, 0x55, bytes(40))[:9]  # header, ID, LEN and two bytes: no more came
    good = status_packet(2, 0, bytes(4))
    replies = codec.feed(head_only + good)
    assert [reply.raw for reply in replies] == [good]
    assert (codec.discarded_bytes, codec.bad_frames) == (len(head_only), 0)
