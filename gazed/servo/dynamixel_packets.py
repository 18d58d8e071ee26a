"""Dynamixel Protocol 2.0 packets: framing, CRC and byte stuffing, shared by the host codec
(`gazed.servo.dynamixel`) and the emulated servos (`gazed.sim.head_dynamixel`).

Instruction packet (ROBOTIS e-manual, Protocol 2.0)::

    FF FF FD 00 | ID | LEN_L LEN_H | INST | PARAM... | CRC_L CRC_H

LEN = len(INST..PARAM after stuffing) + 2, little-endian, as are all multi-byte fields. The CRC
is CRC-16/BUYPASS (polynomial 0x8005, initial 0, no reflection, no final XOR) over everything
from the first FF to the last parameter, sent low byte first. Byte stuffing: wherever FF FF FD
occurs in INST..PARAM the sender inserts an extra FD (counted in LEN, covered by the CRC); the
receiver drops one FD from each FF FF FD FD. (dynamixel-sdk 4.1.0 does not stuff; this does.)
A status packet is `FF FF FD 00 ID LEN 55 ERR PARAM... CRC`.
"""

from __future__ import annotations

from dataclasses import dataclass

from gazed.servo.resync import Cut, Skip, Split, Take, resync

HEADER = b"\xff\xff\xfd\x00"
STUFF_PATTERN = b"\xff\xff\xfd"
STUFFING = 0xFD
BROADCAST_ID = 0xFE
MAX_LENGTH = 512  # longest LEN accepted; anything claiming more is garbage
HEAD_LENGTH = 7  # header, ID, LEN
STATUS = 0x55  # the instruction byte of a status packet


def _crc_table() -> tuple[int, ...]:
    table = []
    for i in range(256):
        crc = i << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x8005) if crc & 0x8000 else (crc << 1)
        table.append(crc & 0xFFFF)
    return tuple(table)


CRC_TABLE = _crc_table()


def crc16(data: bytes | bytearray) -> int:
    """CRC-16/BUYPASS; crc16(b"123456789") == 0xFEE8."""
    crc = 0
    for b in data:
        crc = ((crc << 8) ^ CRC_TABLE[((crc >> 8) ^ b) & 0xFF]) & 0xFFFF
    return crc


def stuff(region: bytes) -> bytes:
    """Insert FD after every FF FF FD in INST..PARAM."""
    out = bytearray()
    for b in region:
        out.append(b)
        if out[-3:] == STUFF_PATTERN:
            out.append(STUFFING)
    return bytes(out)


def unstuff(region: bytes | bytearray) -> bytes:
    """Drop the FD that follows each FF FF FD."""
    out = bytearray()
    i = 0
    while i < len(region):
        out.append(region[i])
        if out[-3:] == STUFF_PATTERN and i + 1 < len(region) and region[i + 1] == STUFFING:
            i += 1
        i += 1
    return bytes(out)


def packet(device_id: int, instruction: int, params: bytes = b"") -> bytes:
    """A complete, stuffed packet with its CRC."""
    region = stuff(bytes((instruction,)) + params)
    body = HEADER + bytes((device_id,)) + (len(region) + 2).to_bytes(2, "little") + region
    return body + crc16(body).to_bytes(2, "little")


def status_packet(device_id: int, error: int, params: bytes = b"") -> bytes:
    return packet(device_id, STATUS, bytes((error,)) + params)


def le(value: int, size: int) -> bytes:
    """A register value as `size` little-endian bytes (negative values two's complement)."""
    return (value & ((1 << (8 * size)) - 1)).to_bytes(size, "little")


def int32(data: bytes) -> int:
    """Little-endian signed int32 (the SDK returns it unsigned: -1 as 4294967295)."""
    return int.from_bytes(data[:4], "little", signed=True)


@dataclass(frozen=True)
class Packet:
    """A decoded packet: `params` unstuffed and without the instruction byte (for a status
    packet `params[0]` is the error byte)."""

    device_id: int
    instruction: int
    params: bytes
    raw: bytes


def _packet_at(buffer: bytearray, start: int) -> tuple[int, bool] | None:
    """(total length, CRC good) of the packet whose header is at `start`, None if incomplete;
    (0, False) if its LEN is impossible."""
    if len(buffer) < start + HEAD_LENGTH:
        return None
    length = int.from_bytes(buffer[start + 5 : start + 7], "little")
    if not 3 <= length <= MAX_LENGTH:
        return 0, False
    total = HEAD_LENGTH + length
    if len(buffer) < start + total:
        return None
    crc = int.from_bytes(buffer[start + total - 2 : start + total], "little")
    return total, crc16(buffer[start : start + total - 2]) == crc


def split_packets(buffer: bytearray) -> Split[Packet]:
    """Take every CRC-valid packet off the front of `buffer`; `rejected` holds the IDs of
    packets whose CRC failed. A packet still arriving stays in `buffer` unless a complete valid
    packet follows it (then its header was garbage)."""

    def cut(front: bytearray) -> Cut[Packet]:
        found = _packet_at(front, 0)
        if found is None:
            later = _next_valid(front)
            return None if later < 0 else Skip(later)
        total, good = found
        if not good:
            return Skip(1, rejected=front[4] if total else None)
        raw = bytes(front[:total])
        region = unstuff(raw[HEAD_LENGTH:-2])
        return Take(total, Packet(raw[4], region[0], region[1:], raw))

    return resync(buffer, cut, find_start=lambda front: front.find(HEADER), keep=len(HEADER) - 1)


def _next_valid(buffer: bytearray) -> int:
    """Offset of the first complete CRC-valid packet after offset 0, or -1."""
    start = buffer.find(HEADER, 1)
    while start >= 0:
        found = _packet_at(buffer, start)
        if found is not None and found[1]:
            return start
        start = buffer.find(HEADER, start + 1)
    return -1


def decode_packet(frame_bytes: bytes) -> Packet | None:
    packets = split_packets(bytearray(frame_bytes)).frames
    return packets[0] if packets else None
