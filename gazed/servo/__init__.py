"""Servo IO (DESIGN §8): one codec module per protocol (bytes in, bytes out, no I/O) over one
resync loop (`resync`), the transports (a pyserial URL, or `visca-udp://` for Sony's VISCA
over IP: `visca_ip_transport`), the driver that pairs them, and what the `servo`
process runs on them: the head link (`head_link`) with its set-point writer and safety layer
(`setpoint_writer`, `limits`, `setpoints`), odometry dating (`odometry`), the line-load meter
(`line_load`), the response lag (`response_lag`) and the park (`park`).

    codec = make_codec(rig.servo.protocol, **rig.servo_params())
    codec.encode_set_position(pan_rad, tilt_rad) -> list[bytes]
    codec.feed(data) -> list[Reply]
"""

from __future__ import annotations

from gazed.servo.codec import Codec, CodecError, HandshakeError, Reply
from gazed.servo.dynamixel import DynamixelCodec
from gazed.servo.flir_ptu import FlirPtuCodec
from gazed.servo.pelco_d import PelcoDCodec
from gazed.servo.visca import ViscaCodec

__all__ = [
    "CODECS",
    "Codec",
    "CodecError",
    "DynamixelCodec",
    "FlirPtuCodec",
    "HandshakeError",
    "PelcoDCodec",
    "Reply",
    "ViscaCodec",
    "make_codec",
]

CODECS: dict[str, type[Codec]] = {
    c.protocol: c for c in (PelcoDCodec, ViscaCodec, FlirPtuCodec, DynamixelCodec)
}


def make_codec(protocol: str, **params: object) -> Codec:
    """The codec of `protocol`; `params` are that protocol's `[servo]` keys
    (`rig.servo_params()`): `make_codec("pelco-d", address=1)`."""
    if protocol not in CODECS:
        raise CodecError(f"unknown protocol {protocol!r} (expected one of {', '.join(CODECS)})")
    try:
        return CODECS[protocol](**params)  # type: ignore[arg-type]
    except TypeError as exc:
        raise CodecError(f"{protocol}: {exc}") from exc
