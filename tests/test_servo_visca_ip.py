"""VISCA over IP, sans I/O: Sony's header against golden bytes from independent libraries
(visca-over-ip 0.5.2 sending to a fake camera, obs-ptz's RESET, pyvisca and visca-over-ip for
tilt speeds above 0x14; /work/notes/ip-cameras.md §4), the VISCA codec's packets inside it, and
the parsers fed garbage (hypothesis)."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from servo_link_support import link_rig

from gazed.config import RigError
from gazed.servo import visca_ip
from gazed.servo.codec import CodecError
from gazed.servo.transport import SerialTransport
from gazed.servo.visca import ViscaCodec
from gazed.servo.visca_ip_transport import LinkError, address_of, open_transport
from gazed.sim.head_visca_ip import ViscaIpSession

COMMAND, INQUIRY, REPLY = (visca_ip.PAYLOAD_TYPE[k] for k in ("command", "inquiry", "reply"))
CONTROL, CONTROL_REPLY = visca_ip.PAYLOAD_TYPE["control"], visca_ip.PAYLOAD_TYPE["control_reply"]


def h(text: str) -> bytes:
    return bytes.fromhex(text)


def test_reset_is_the_bytes_visca_over_ip_and_obs_ptz_send() -> None:
    assert visca_ip.frame(CONTROL, 1, visca_ip.RESET) == h("02 00 00 01 00 00 00 01 01")
    assert visca_ip.frame(CONTROL, 0, visca_ip.RESET) == h("02 00 00 01 00 00 00 00 01")


def test_codec_packets_in_the_header_are_visca_over_ips_bytes() -> None:
    codec = ViscaCodec(pan_speed_max_deg_s=24.0, tilt_speed_max_deg_s=20.0)
    (if_clear,) = codec.encode_if_clear()
    assert visca_ip.frame(visca_ip.visca_type(if_clear), 2, if_clear) == h(
        "01 00 00 05 00 00 00 02 81 01 00 01 FF"
    )
    (right_down,) = codec.encode_set_velocity(math.radians(3.0), math.radians(-4.0))
    assert visca_ip.frame(visca_ip.visca_type(right_down), 3, right_down) == h(
        "01 00 00 09 00 00 00 03 81 01 06 01 03 04 02 02 FF"
    )
    (left_up,) = codec.encode_set_velocity(math.radians(-24.0), math.radians(20.0))
    assert left_up == h("81 01 06 01 18 14 01 01 FF")
    (absolute,) = ViscaCodec(pan_deg_per_unit=1.0, tilt_deg_per_unit=1.0).encode_set_position(
        math.radians(-2267), math.radians(1200)
    )
    assert visca_ip.frame(visca_ip.visca_type(absolute), 6, absolute) == h(
        "01 00 00 0F 00 00 00 06 81 01 06 02 18 14 0F 07 02 05 00 04 0B 00 FF"
    )


def test_an_inquiry_travels_as_sony_types_it_and_its_reply_decodes() -> None:
    codec = ViscaCodec(pan_deg_per_unit=1.0, tilt_deg_per_unit=1.0)
    (inquiry,) = codec.encode_query_position()
    # visca-over-ip sends it as a command (01 00); Sony and obs-ptz type it 01 10
    assert visca_ip.frame(visca_ip.visca_type(inquiry), 8, inquiry) == h(
        "01 10 00 05 00 00 00 08 81 09 06 12 FF"
    )
    message = visca_ip.parse(h("01 11 00 0B 00 00 00 08 90 50 0F 07 02 05 00 04 0B 00 FF"))
    assert message is not None and (message.payload_type, message.sequence) == (REPLY, 8)
    (reply,) = codec.feed(message.payload)
    assert round(math.degrees(reply.pan_rad)) == -2267
    assert round(math.degrees(reply.tilt_rad)) == 1200


def test_sequence_numbers_wrap_and_the_header_is_big_endian() -> None:
    assert visca_ip.next_sequence(0xFFFFFFFF) == 0
    assert visca_ip.frame(COMMAND, 0x01020304, b"\x81\xff")[4:8] == h("01 02 03 04")


def test_tilt_speeds_above_0x14_go_out_when_the_rig_says_the_camera_takes_them() -> None:
    wide = ViscaCodec(tilt_speed_max_code=0x18, pan_speed_max_deg_s=24.0, tilt_speed_max_deg_s=24.0)
    # visca-over-ip pantilt(5, 24) -> 05 18 02 02; pyvisca left_up(24, 24) -> 18 18 01 01
    assert wide.encode_set_velocity(math.radians(5), math.radians(-24))[0] == h(
        "81 01 06 01 05 18 02 02 FF"
    )
    assert wide.encode_set_velocity(math.radians(-24), math.radians(24))[0] == h(
        "81 01 06 01 18 18 01 01 FF"
    )
    assert ViscaCodec(tilt_speed=0x18, tilt_speed_max_code=0x18).tilt_speed == 0x18
    # a camera that takes 0x14 at most never gets more: the rate saturates
    usual = ViscaCodec(tilt_speed_max_deg_s=20.0)
    assert usual.encode_set_velocity(0.0, math.radians(90))[0][5] == 0x14
    with pytest.raises(CodecError, match="outside"):
        ViscaCodec(tilt_speed=0x15)


def test_the_rig_keys_bound_the_speed_bytes() -> None:
    rig = link_rig(protocol="visca", tilt_speed_max_code=23, tilt_speed=23)
    assert rig.servo_params()["tilt_speed_max_code"] == 23
    with pytest.raises(RigError, match="tilt_speed"):
        link_rig(protocol="visca", tilt_speed=21)
    with pytest.raises(RigError, match="visca-udp"):
        link_rig("visca-udp://127.0.0.1:52381", protocol="pelco-d")


def test_the_port_url_chooses_the_transport() -> None:
    assert address_of("visca-udp://10.0.0.9") == ("10.0.0.9", visca_ip.DEFAULT_PORT)
    assert open_transport("visca-udp://127.0.0.1:6000", 9600, 0.1).address == ("127.0.0.1", 6000)
    assert isinstance(open_transport("socket://127.0.0.1:5678", 9600, 0.1), SerialTransport)
    with pytest.raises(LinkError, match="host"):
        address_of("visca-udp://:52381")


@given(st.binary(max_size=40))
def test_a_datagram_is_a_message_exactly_when_its_header_says_so(data: bytes) -> None:
    message = visca_ip.parse(data)
    if message is not None:
        assert visca_ip.frame(message.payload_type, message.sequence, message.payload) == data


@settings(max_examples=200)
@given(st.lists(st.binary(max_size=30), max_size=8))
def test_the_camera_side_drops_garbage_and_still_answers(garbage: list[bytes]) -> None:
    session = ViscaIpSession()
    for datagram in garbage:
        data, replies = session.receive(datagram)
        assert all(visca_ip.parse(reply) is not None for reply in replies)
    session.receive(visca_ip.frame(CONTROL, 0, visca_ip.RESET))
    data, _ = session.receive(visca_ip.frame(INQUIRY, 1, h("81 09 06 12 FF")))
    assert data == h("81 09 06 12 FF")
    (reply,) = session.send(h("90 50 00 00 00 00 00 00 00 00 FF"))
    assert visca_ip.parse(reply) == visca_ip.Message(
        REPLY, 1, h("90 50 00 00 00 00 00 00 00 00 FF")
    )


def test_the_camera_side_refuses_a_repeated_sequence_number_and_numbers_completions() -> None:
    session = ViscaIpSession()
    command = visca_ip.frame(COMMAND, 5, h("81 01 06 02 18 14 00 00 00 00 00 00 00 00 FF"))
    assert session.receive(command)[0]
    assert session.receive(command) == (
        b"",
        [visca_ip.frame(CONTROL_REPLY, 5, visca_ip.SEQUENCE_ERROR)],
    )
    ack, completion = session.send(h("90 41 FF 90 51 FF"))
    assert visca_ip.parse(ack) == visca_ip.Message(REPLY, 5, h("90 41 FF"))
    assert visca_ip.parse(completion) == visca_ip.Message(REPLY, 5, h("90 51 FF"))
    assert session.receive(visca_ip.frame(0x0120, 6, b"\x01"))[1] == [
        visca_ip.frame(CONTROL_REPLY, 6, visca_ip.MESSAGE_TYPE_ERROR)
    ]
