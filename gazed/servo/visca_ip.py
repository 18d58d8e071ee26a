"""Sony's VISCA-over-IP framing (SRG-300H technical manual pp.31-32; BRC-X400 command list p.12),
bytes in and out, no I/O: each UDP datagram is an 8-byte big-endian header and one payload.

    payload type (2)  payload length (2, 1..16)  sequence number (4)  payload

Payload types: `01 00` VISCA command, `01 10` inquiry, `01 11` reply (ACK, completion, inquiry
reply, error), `02 00` control command, `02 01` control reply. The control command RESET `01`
sets the camera's sequence number to 0 (the header's value is ignored) and is answered by the
control reply `01`; `0F 01` reports an abnormal sequence number, `0F 02` an abnormal message
type. Sony lists these errors among the control commands and obs-ptz accepts them under either
control type, so both are parsed. Replies echo the sequence number of the message they answer.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

DEFAULT_PORT = 52381
HEADER = struct.Struct(">HHI")
PAYLOAD_TYPE = {
    "command": 0x0100,
    "inquiry": 0x0110,
    "reply": 0x0111,
    "setting": 0x0120,
    "control": 0x0200,
    "control_reply": 0x0201,
}
CONTROL_TYPES = (PAYLOAD_TYPE["control"], PAYLOAD_TYPE["control_reply"])
RESET = b"\x01"
RESET_ACK = b"\x01"
SEQUENCE_ERROR = b"\x0f\x01"
MESSAGE_TYPE_ERROR = b"\x0f\x02"
MAX_PAYLOAD = 16
SEQUENCE_MODULUS = 1 << 32
INQUIRY_CATEGORY = 0x09


@dataclass(frozen=True)
class Message:
    """One datagram, decoded."""

    payload_type: int
    sequence: int
    payload: bytes


def frame(payload_type: int, sequence: int, payload: bytes) -> bytes:
    """The datagram carrying `payload`."""
    if not 1 <= len(payload) <= MAX_PAYLOAD:
        raise ValueError(f"payload of {len(payload)} bytes outside 1..{MAX_PAYLOAD}")
    return HEADER.pack(payload_type, len(payload), sequence % SEQUENCE_MODULUS) + payload


def visca_type(packet: bytes) -> int:
    """The payload type of a VISCA packet from the host: inquiry (`8x 09 ...`) or command."""
    inquiry = len(packet) > 1 and packet[1] == INQUIRY_CATEGORY
    return PAYLOAD_TYPE["inquiry" if inquiry else "command"]


def parse(datagram: bytes) -> Message | None:
    """The datagram's message, or None when it is not one: too short, an unknown payload type,
    or a length field that disagrees with the bytes that came."""
    if len(datagram) <= HEADER.size:
        return None
    payload_type, length, sequence = HEADER.unpack_from(datagram)
    payload = datagram[HEADER.size :]
    if payload_type not in PAYLOAD_TYPE.values() or length != len(payload):
        return None
    if length > MAX_PAYLOAD:
        return None
    return Message(payload_type, sequence, bytes(payload))


def next_sequence(sequence: int) -> int:
    """The sequence number after `sequence` (0xFFFFFFFF wraps to 0)."""
    return (sequence + 1) % SEQUENCE_MODULUS
