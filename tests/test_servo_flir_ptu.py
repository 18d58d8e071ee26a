"""PTU ASCII codec against PROTOCOLS.md §3 (FLIR PTU-D300 v2.19, PTU-D46 v2.14 manuals)."""

from __future__ import annotations

import math

import pytest

from gazed.servo import CodecError, HandshakeError, Reply, make_codec
from gazed.servo.flir_ptu import parse_line, positions_from_rad, rad_from_positions


@pytest.fixture
def codec():
    return make_codec("flir-ptu", pan_arcsec_per_position=92.5714, tilt_arcsec_per_position=46.2857)


def test_the_manuals_example_21_3_degrees_is_828_positions() -> None:
    assert positions_from_rad(math.radians(21.3), 92.5714) == 828  # flir_ptu's ceil gives 829
    assert math.degrees(rad_from_positions(828, 92.5714)) == pytest.approx(828 * 92.5714 / 3600)


def test_set_position_and_query_frames(codec) -> None:
    assert codec.encode_set_position(math.radians(21.3), math.radians(-10.0)) == [
        b"PP828 ",
        b"TP-778 ",  # tilt divides by the tilt resolution (flirptu divides by pan's)
    ]
    assert codec.encode_query_position() == [b"PP ", b"TP "]
    assert codec.encode_stop() == [b"H "]
    assert all(codec.replies_expected(f) == 1 for f in (b"PP828 ", b"PP ", b"H "))


def sent(codec, frames: list[bytes]) -> list[bytes]:
    """Tell the codec the frames went on the wire, as the driver does."""
    for frame in frames:
        codec.sent(frame)
    return frames


def test_replies_are_matched_to_the_queries_in_order(codec) -> None:
    codec.reset()
    sent(codec, codec.encode_query_position())
    replies = codec.feed(b"* 828\r\n!P\r\n* -778\r\n")
    assert [r.kind for r in replies] == ["position", "limit", "position"]
    assert math.degrees(replies[0].pan_rad) == pytest.approx(828 * 92.5714 / 3600)
    assert replies[0].tilt_rad is None
    assert replies[1].asynchronous and replies[1].reason == "pan limit"
    assert math.degrees(replies[2].tilt_rad) == pytest.approx(-778 * 46.2857 / 3600)


def test_line_forms() -> None:
    assert parse_line("*") == Reply("ok", raw=b"*")
    assert parse_line("* Current Pan position is 1000").value == 1000  # verbose
    assert parse_line("PP * 1000").value == 1000  # echo on
    assert parse_line("* 92.5714 seconds arc per position").value == pytest.approx(92.5714)
    assert parse_line("* Minimum Pan position is -3090").value == -3090
    error = parse_line("PS3300 ! Pan speed cannot exceed 2902 positions/sec")
    assert error.kind == "error" and error.reason == "Pan speed cannot exceed 2902 positions/sec"
    assert parse_line("!T").kind == "limit"
    assert parse_line("garbage") is None


def test_cr_alone_and_crlf_both_end_lines(codec) -> None:
    assert [r.kind for r in codec.feed(b"*\r*\r\n*\n")] == ["ok", "ok", "ok"]


def test_velocity_mode_and_back(codec) -> None:
    rate = math.radians(1000 * 92.5714 / 3600)
    assert sent(codec, codec.encode_set_velocity(rate, 0.0)) == [b"CV ", b"PS1000 ", b"TS0 "]
    assert codec.encode_set_velocity(-rate, 0.0) == [b"PS-1000 ", b"TS0 "]


def scripted(answers: dict[bytes, bytes]):
    """An exchange that answers each frame with the manual's reply line."""
    sent = []

    def exchange(frame: bytes) -> list[Reply]:
        sent.append(frame)
        exchange.codec.sent(frame)
        return exchange.codec.feed(answers[frame])

    exchange.sent = sent
    return exchange


def test_handshake_reads_resolution_limits_and_speeds(codec) -> None:
    exchange = scripted(
        {
            b"ED ": b"ED *\r\n",  # echo is still on when ED arrives
            b"FT ": b"*\r\n",
            b"CI ": b"*\r\n",
            b"PR ": b"* 185.1428 seconds arc per position\r\n",
            b"TR ": b"* 46.2857 seconds arc per position\r\n",
            b"PN ": b"* -3090\r\n",
            b"PX ": b"* 3090\r\n",
            b"TN ": b"* -907\r\n",
            b"TX ": b"* 604\r\n",
            b"PS ": b"* 1000\r\n",
            b"TS ": b"* 500\r\n",
        }
    )
    exchange.codec = codec
    codec.handshake(exchange)
    assert exchange.sent[:3] == [b"ED ", b"FT ", b"CI "]
    assert codec.pan_arcsec_per_position == pytest.approx(185.1428)  # the unit's, not the rig's
    assert codec.limits_positions == {
        "pan_min": -3090,
        "pan_max": 3090,
        "tilt_min": -907,
        "tilt_max": 604,
    }
    rate = math.radians(10 * 185.1428 / 3600)
    sent(codec, codec.encode_set_velocity(rate, 0.0))
    # back to positions: independent mode and the move speeds read at start-up
    assert codec.encode_set_position(0.0, 0.0) == [
        b"CI ",
        b"PS1000 ",
        b"TS500 ",
        b"PP0 ",
        b"TP0 ",
    ]


def test_handshake_fails_on_an_error_line(codec) -> None:
    exchange = scripted({b"ED ": b"! Illegal Command\r\n"})
    exchange.codec = codec
    with pytest.raises(HandshakeError, match="Illegal"):
        codec.handshake(exchange)


def test_frames_encoded_but_not_sent_await_no_answer(codec) -> None:
    """Set-points encoded and never sent: the answers to the query sent next are still read as
    pan and tilt, not as acks of frames that never went out."""
    for _ in range(3):
        codec.encode_set_position(math.radians(1.0), math.radians(2.0))
    sent(codec, codec.encode_query_position())
    pan, tilt = codec.feed(b"* 828\r\n* -778\r\n")
    assert pan.kind == tilt.kind == "position"
    assert math.degrees(pan.pan_rad) == pytest.approx(828 * 92.5714 / 3600)
    assert math.degrees(tilt.tilt_rad) == pytest.approx(-778 * 46.2857 / 3600)


def test_the_control_mode_follows_the_frames_sent(codec) -> None:
    """Velocity frames encoded and never sent leave the unit, and the codec, in independent
    mode: the next set-point needs no `CI`."""
    codec.encode_set_velocity(math.radians(1.0), 0.0)
    assert codec.encode_set_position(0.0, 0.0) == [b"PP0 ", b"TP0 "]
    sent(codec, codec.encode_set_velocity(math.radians(1.0), 0.0))
    with pytest.raises(CodecError, match="leaving velocity mode"):  # CI and the move speeds
        codec.encode_set_position(0.0, 0.0)
