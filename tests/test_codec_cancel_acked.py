"""`Codec.last_acked` / `encode_cancel_acked`: the command a device acknowledged, cancelled while
it still executes (VISCA Cancel `8x 2y FF`, PROTOCOLS §2); protocols without acknowledgements
name none and cancel nothing."""

from __future__ import annotations

import pytest

from gazed.servo import make_codec


def test_visca_cancels_the_acked_command_while_it_holds_its_socket() -> None:
    codec = make_codec("visca")
    assert codec.last_acked is None
    codec.feed(bytes.fromhex("90 42 FF"))  # ACK: socket 2
    zoom = codec.last_acked
    assert codec.encode_cancel_acked(zoom) == [bytes.fromhex("81 22 FF")]
    codec.feed(bytes.fromhex("90 41 FF"))  # a move in socket 1 does not end it
    assert codec.encode_cancel_acked(zoom) == [bytes.fromhex("81 22 FF")]
    codec.feed(bytes.fromhex("90 52 FF"))  # completion: nothing left to cancel
    assert codec.encode_cancel_acked(zoom) == []
    codec.feed(bytes.fromhex("90 42 FF"))  # socket 2 taken by another command
    assert codec.encode_cancel_acked(zoom) == []
    assert codec.encode_cancel_acked("not an ack") == []


@pytest.mark.parametrize("protocol", ["pelco-d", "flir-ptu", "dynamixel"])
def test_protocols_without_acks_name_none_and_cancel_nothing(protocol: str) -> None:
    codec = make_codec(protocol)
    assert codec.last_acked is None
    assert codec.encode_cancel_acked((1, 1)) == []
