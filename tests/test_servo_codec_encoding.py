"""Encoding is pure for every codec: a frame encoded and never written leaves the codec as it
was (DESIGN §8); what is on the wire is learnt only from the frames sent (`Codec.sent`)."""

from __future__ import annotations

import copy

import pytest

from gazed.servo import Codec, make_codec
from gazed.servo.dynamixel_packets import le, status_packet

# a reply each codec takes in before encoding, so there is state to disturb
FED = {
    "pelco-d": bytes.fromhex("FF 01 00 59 10 00 6A"),
    "visca": bytes.fromhex("90 41 FF"),
    "flir-ptu": b"* 100\r\n",
    "dynamixel": status_packet(1, 0, le(2000, 4)) + status_packet(2, 0, le(2100, 4)),
}


def encode_everything(codec: Codec) -> None:
    codec.encode_set_velocity(0.1, -0.1)
    codec.encode_set_position(0.2, -0.1)
    codec.encode_set_velocity(0.0, 0.1)
    codec.encode_stop()
    codec.encode_query_position()
    if codec.zooms:
        codec.encode_set_zoom(0.5)
        codec.encode_query_zoom()
    codec.encode_cancel_acked(codec.last_acked)


@pytest.mark.parametrize("protocol", sorted(FED))
def test_encoding_changes_no_state(protocol: str) -> None:
    codec = make_codec(protocol)
    codec.feed(FED[protocol])
    before = copy.deepcopy(vars(codec))
    encode_everything(codec)
    assert vars(codec) == before
