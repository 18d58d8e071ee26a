"""Properties every codec's `feed` must have (hypothesis): any bytes in any chunking never raise;
chunking never changes what is decoded; corrupted frames never raise; a valid frame inside
garbage is still found."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gazed.servo import Codec, Reply, make_codec
from gazed.servo.dynamixel_packets import le, status_packet
from gazed.servo.pelco_d import EXTENDED, word_frame
from gazed.servo.visca import to_nibbles

SETTINGS = settings(
    max_examples=100, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)


@dataclass(frozen=True)
class Case:
    """How to make a codec ready for replies, and a strategy of (reply bytes, check)."""

    protocol: str
    params: dict
    prepare: Callable[[Codec], None]
    replies: st.SearchStrategy
    line_oriented: bool = False


def pelco_replies():
    def build(pan: bool, raw: int):
        cmd2 = EXTENDED["pan_response"] if pan else EXTENDED["tilt_response"]

        def check(r: Reply) -> bool:
            got = r.pan_rad if pan else r.tilt_rad
            if pan:
                want = math.radians(((raw / 100.0) + 180.0) % 360.0 - 180.0)
            else:
                want = math.radians((36000 - raw) / 100.0 if raw > 18000 else -raw / 100.0)
            return (
                r.kind == "position" and got is not None and math.isclose(got, want, abs_tol=1e-9)
            )

        return word_frame(1, cmd2, raw), check

    return st.builds(build, st.booleans(), st.integers(0, 35999))


def visca_replies():
    def position(pan: int, tilt: int):
        frame = bytes((0x90, 0x50, *to_nibbles(pan), *to_nibbles(tilt), 0xFF))

        def check(r: Reply) -> bool:
            return (
                r.kind == "position"
                and math.isclose(r.pan_rad, math.radians(pan * 0.075))
                and math.isclose(r.tilt_rad, math.radians(tilt * 0.075))
            )

        return frame, check

    def short(kind: int, socket: int):
        names = {0x40: "ack", 0x50: "completion"}
        frame = bytes((0x90, kind | socket, 0xFF))
        return frame, lambda r: r.kind == names[kind] and r.socket == socket

    int16 = st.integers(-0x8000, 0x7FFF)
    return st.one_of(
        st.builds(position, int16, int16),
        st.builds(short, st.sampled_from([0x40, 0x50]), st.sampled_from([1, 2])),
    )


def ptu_replies():
    def build(value: int):
        def check(r: Reply) -> bool:
            # a query asks pan then tilt: the reply is whichever was asked next
            angle = r.pan_rad if r.pan_rad is not None else r.tilt_rad
            return r.kind == "position" and math.isclose(
                angle, math.radians(value * 46.2857 / 3600)
            )

        return f"* {value}\r\n".encode(), check

    return st.builds(build, st.integers(-100000, 100000))


def dynamixel_replies():
    def build(value: int):
        def check(r: Reply) -> bool:
            return r.kind == "position" and math.isclose(
                r.pan_rad, (value - 2048) * 2 * math.pi / 4096
            )

        return status_packet(1, 0, le(value, 4)), check

    # includes values whose bytes hold FF FF FD, so the status packet is stuffed
    stuffed = st.sampled_from([-33554688, 0x00FDFFFF, -0x020000FF])
    return st.builds(build, st.one_of(st.integers(-(2**31), 2**31 - 1), stuffed))


def query_first(codec: Codec) -> None:
    for frame in codec.encode_query_position():
        codec.sent(frame)


CASES = [
    Case("pelco-d", {"address": 1}, lambda c: None, pelco_replies()),
    Case("visca", {"address": 1}, lambda c: None, visca_replies()),
    Case("flir-ptu", {"pan_arcsec_per_position": 46.2857}, query_first, ptu_replies(), True),
    Case("dynamixel", {}, query_first, dynamixel_replies()),
]
IDS = [c.protocol for c in CASES]


def fresh(case: Case) -> Codec:
    codec = make_codec(case.protocol, **case.params)
    case.prepare(codec)
    return codec


def chunked(data: bytes, cuts: list[int]) -> list[bytes]:
    points = sorted({min(c, len(data)) for c in cuts})
    edges = [0, *points, len(data)]
    return [data[a:b] for a, b in itertools.pairwise(edges)]


@pytest.mark.parametrize("case", CASES, ids=IDS)
@SETTINGS
@given(data=st.binary(max_size=600), cuts=st.lists(st.integers(0, 600), max_size=20))
def test_random_bytes_in_any_chunking_never_raise(case: Case, data: bytes, cuts: list[int]) -> None:
    codec = fresh(case)
    for chunk in chunked(data, cuts):
        replies = codec.feed(chunk)
        assert all(isinstance(r, Reply) for r in replies)
    assert len(codec._buffer) <= 4096


@pytest.mark.parametrize("case", CASES, ids=IDS)
@SETTINGS
@given(st.data())
def test_chunking_does_not_change_what_is_decoded(case: Case, data: st.DataObject) -> None:
    frames = data.draw(st.lists(case.replies, min_size=1, max_size=8))
    stream = b"".join(f for f, _ in frames)
    cuts = data.draw(st.lists(st.integers(0, len(stream)), max_size=30))
    whole, pieces = fresh(case), fresh(case)
    if case.prepare is query_first:
        for _ in range(len(frames)):  # one pending query per reply
            query_first(whole)
            query_first(pieces)
    expected = whole.feed(stream)
    got = [r for chunk in chunked(stream, cuts) for r in pieces.feed(chunk)]
    assert got == expected
    assert len(got) == len(frames)
    for reply, (_, check) in zip(got, frames, strict=True):
        assert check(reply)


@pytest.mark.parametrize("case", CASES, ids=IDS)
@SETTINGS
@given(st.data())
def test_corrupted_frames_never_raise(case: Case, data: st.DataObject) -> None:
    frames = data.draw(st.lists(case.replies, min_size=1, max_size=6))
    stream = bytearray(b"".join(f for f, _ in frames))
    for _ in range(data.draw(st.integers(1, 4))):
        i = data.draw(st.integers(0, len(stream) - 1))
        stream[i] = data.draw(st.integers(0, 255))
    if data.draw(st.booleans()):
        del stream[data.draw(st.integers(0, len(stream) - 1))]
    codec = fresh(case)
    replies = codec.feed(bytes(stream))
    assert len(replies) <= len(frames) + 2


def garbage_for(case: Case):
    if case.line_oriented:
        # a line protocol resyncs at the line end: garbage is anything but the reply markers
        text = st.binary(max_size=80).map(lambda b: b.replace(b"*", b"").replace(b"!", b""))
        return text.map(lambda b: b + b"\r\n")
    return st.binary(max_size=80)


@pytest.mark.parametrize("case", CASES, ids=IDS)
@SETTINGS
@given(st.data())
def test_a_valid_frame_inside_garbage_is_found(case: Case, data: st.DataObject) -> None:
    frame, check = data.draw(case.replies)
    before = data.draw(garbage_for(case))
    after = data.draw(garbage_for(case))
    codec = fresh(case)
    replies = codec.feed(before + frame + after)
    assert any(check(r) for r in replies), replies
