"""Dynamixel Protocol 2.0, two X-series servos as a pan/tilt head (PROTOCOLS.md §4): the
instruction and control tables and the host codec; packets, CRC and stuffing are
`gazed.servo.dynamixel_packets`.

Set position is one Sync Write of Goal Position (116, 4 bytes) for both IDs, which gets no
status; query is one Sync Read of Present Position (132, 4 bytes, signed int32), answered by one
status packet per ID in order. Positions are `units_per_rev` per turn about `center`.

A status packet names its ID but not the instruction it answers, so the codec keeps, per ID, what
each instruction written awaits (a position, a value, an ack). It learns what is on the wire
only from the frames the driver wrote (`sent`), never from encoding: a frame encoded and not
sent would otherwise leave an expectation that takes the answer of the next one. The operating
mode follows the Operating Mode writes sent.
"""

from __future__ import annotations

import math
from collections import deque
from typing import ClassVar

from gazed.servo.codec import (
    Codec,
    CodecError,
    Exchange,
    Reply,
    handshake_reply,
    nearest,
)
from gazed.servo.dynamixel_packets import (
    BROADCAST_ID,
    STATUS,
    Packet,
    decode_packet,
    int32,
    le,
    packet,
    split_packets,
)

INSTRUCTION = {
    "ping": 0x01,
    "read": 0x02,
    "write": 0x03,
    "reg_write": 0x04,
    "action": 0x05,
    "reboot": 0x08,
    "sync_read": 0x82,
    "sync_write": 0x83,
    "bulk_read": 0x92,
    "bulk_write": 0x93,
}

# X-series control table: name -> (address, size) (e-manual X-series control-table includes)
CONTROL_TABLE = {
    "model_number": (0, 2),
    "firmware_version": (6, 1),
    "id": (7, 1),
    "operating_mode": (11, 1),
    "torque_enable": (64, 1),
    "status_return_level": (68, 1),
    "hardware_error_status": (70, 1),
    "goal_velocity": (104, 4),
    "profile_acceleration": (108, 4),
    "profile_velocity": (112, 4),
    "goal_position": (116, 4),
    "moving": (122, 1),
    "present_velocity": (128, 4),
    "present_position": (132, 4),
}
OPERATING_MODE = {"velocity": 1, "position": 3, "extended_position": 4, "pwm": 16}
POSITION_MODES = (OPERATING_MODE["position"], OPERATING_MODE["extended_position"])
ERRORS = {
    1: "result fail",
    2: "instruction error",
    3: "CRC error",
    4: "data range error",
    5: "data length error",
    6: "data limit error",
    7: "access error",
}
ALERT = 0x80
VELOCITY_UNIT_RPM = 0.229
VELOCITY_UNIT_RAD_S = VELOCITY_UNIT_RPM * 2.0 * math.pi / 60.0


def error_reason(error: int) -> str:
    """The status ERR byte in words: bit 7 hardware alert, bits 0-6 the error number."""
    parts = []
    if error & 0x7F:
        parts.append(ERRORS.get(error & 0x7F, f"error {error & 0x7F}"))
    if error & ALERT:
        parts.append("hardware alert (read Hardware Error Status, address 70)")
    return "; ".join(parts)


class DynamixelCodec(Codec):
    """Host side of a Dynamixel pan/tilt pair; IDs, the joint's zero (`center`) and
    `units_per_rev` from the rig."""

    protocol: ClassVar[str] = "dynamixel"

    def __init__(
        self, pan_id: int = 1, tilt_id: int = 2, center: int = 2048, units_per_rev: int = 4096
    ) -> None:
        super().__init__()
        if pan_id == tilt_id or not (0 <= pan_id <= 252 and 0 <= tilt_id <= 252):
            raise CodecError(f"ids {pan_id}, {tilt_id}: expected two distinct ids 0..252")
        self.pan_id = pan_id
        self.tilt_id = tilt_id
        self.center = center
        self.units_per_rev = units_per_rev
        self.position_mode = OPERATING_MODE["position"]
        self.model_numbers: dict[int, int] = {}
        self._velocity_mode = False
        self._present: dict[int, int] = {}
        self._pending: dict[int, deque[str]] = {}

    @property
    def ids(self) -> tuple[int, int]:
        return self.pan_id, self.tilt_id

    @property
    def resolution_rad(self) -> tuple[float, float]:
        unit = 2.0 * math.pi / self.units_per_rev
        return unit, unit

    @property
    def stop_needs_position(self) -> bool:
        return not self._velocity_mode

    def units(self, angle_rad: float) -> int:
        if not math.isfinite(angle_rad):
            raise CodecError(f"angle {angle_rad} is not finite")
        value = self.center + nearest(angle_rad * self.units_per_rev / (2.0 * math.pi))
        if self.position_mode == OPERATING_MODE["position"] and not (
            0 <= value < self.units_per_rev
        ):
            raise CodecError(
                f"goal {value} outside 0..{self.units_per_rev - 1} of position mode "
                "(use extended position mode, 4, for more than one turn)"
            )
        return value

    def angle_rad(self, value: int) -> float:
        return (value - self.center) * 2.0 * math.pi / self.units_per_rev

    # --- instruction builders ------------------------------------------------------------

    def encode_ping(self, device_id: int) -> bytes:
        return packet(device_id, INSTRUCTION["ping"])

    def encode_read(self, device_id: int, item: str) -> bytes:
        address, size = CONTROL_TABLE[item]
        return packet(device_id, INSTRUCTION["read"], le(address, 2) + le(size, 2))

    def encode_write(self, device_id: int, item: str, value: int) -> bytes:
        address, size = CONTROL_TABLE[item]
        return packet(device_id, INSTRUCTION["write"], le(address, 2) + le(value, size))

    def encode_sync_write(self, item: str, values: dict[int, int]) -> bytes:
        address, size = CONTROL_TABLE[item]
        params = le(address, 2) + le(size, 2)
        for device_id, value in values.items():
            params += bytes((device_id,)) + le(value, size)
        return packet(BROADCAST_ID, INSTRUCTION["sync_write"], params)

    def _both(self, item: str, value: int) -> bytes:
        return self.encode_sync_write(item, {self.pan_id: value, self.tilt_id: value})

    def _switch_mode(self, mode: int) -> list[bytes]:
        """Operating Mode is EEPROM: write it with torque off, then torque on again."""
        return [
            self._both("torque_enable", 0),
            self._both("operating_mode", mode),
            self._both("torque_enable", 1),
        ]

    # --- the codec interface -------------------------------------------------------------

    def encode_set_position(self, pan_rad: float, tilt_rad: float) -> list[bytes]:
        goals = {self.pan_id: self.units(pan_rad), self.tilt_id: self.units(tilt_rad)}
        frames = self._switch_mode(self.position_mode) if self._velocity_mode else []
        return [*frames, self.encode_sync_write("goal_position", goals)]

    def encode_set_velocity(self, pan_rad_s: float, tilt_rad_s: float) -> list[bytes]:
        if not (math.isfinite(pan_rad_s) and math.isfinite(tilt_rad_s)):
            raise CodecError(f"rates {pan_rad_s}, {tilt_rad_s} are not finite")
        goals = {
            self.pan_id: nearest(pan_rad_s / VELOCITY_UNIT_RAD_S),
            self.tilt_id: nearest(tilt_rad_s / VELOCITY_UNIT_RAD_S),
        }
        frames = [] if self._velocity_mode else self._switch_mode(OPERATING_MODE["velocity"])
        return [*frames, self.encode_sync_write("goal_velocity", goals)]

    def encode_stop(self) -> list[bytes]:
        """Velocity mode: Goal Velocity 0. Position mode: the last Present Position decoded
        becomes the Goal Position (torque off would drop a loaded tilt axis)."""
        if self._velocity_mode:
            return [self._both("goal_velocity", 0)]
        if not all(i in self._present for i in self.ids):
            raise CodecError("stop in position mode needs a position reply first")
        return [self.encode_sync_write("goal_position", {i: self._present[i] for i in self.ids})]

    def encode_query_position(self) -> list[bytes]:
        address, size = CONTROL_TABLE["present_position"]
        params = le(address, 2) + le(size, 2) + bytes(self.ids)
        return [packet(BROADCAST_ID, INSTRUCTION["sync_read"], params)]

    def replies_expected(self, frame_bytes: bytes) -> int:
        p = decode_packet(frame_bytes)
        if p is None:
            return 0
        if p.instruction in (INSTRUCTION["sync_read"], INSTRUCTION["bulk_read"]):
            return len(p.params) - 4
        if p.device_id == BROADCAST_ID:
            return len(self.ids) if p.instruction == INSTRUCTION["ping"] else 0
        return 1  # status return level 2 (the default): every instruction is answered

    def sent(self, frame_bytes: bytes) -> None:
        """Each ID a frame asks awaits its status: a Sync Read of Present Position a position,
        another read or a ping a value, any other instruction to one ID an ack. An Operating
        Mode write to both IDs switches the mode the codec encodes for."""
        p = decode_packet(frame_bytes)
        if p is None:
            return
        address = int.from_bytes(p.params[:2], "little")
        if p.instruction == INSTRUCTION["sync_read"]:
            position = (address, int.from_bytes(p.params[2:4], "little")) == CONTROL_TABLE[
                "present_position"
            ]
            for device_id in p.params[4:]:
                self._expect(device_id, "position" if position else "value")
        elif p.device_id != BROADCAST_ID:
            reads = (INSTRUCTION["ping"], INSTRUCTION["read"])
            self._expect(p.device_id, "value" if p.instruction in reads else "ack")
        elif (p.instruction, address) == (
            INSTRUCTION["sync_write"],
            CONTROL_TABLE["operating_mode"][0],
        ):
            modes = set(p.params[5::2])  # ID, mode: one byte each
            self._velocity_mode = modes == {OPERATING_MODE["velocity"]}

    def _expect(self, device_id: int, what: str) -> None:
        self._pending.setdefault(device_id, deque()).append(what)

    def handshake(self, exchange: Exchange) -> None:
        """Ping both servos; put each in a position mode (3, or 4 if already extended) with
        torque off to change it; torque on."""
        modes = []
        for device_id in self.ids:
            self.model_numbers[device_id] = (
                int(_answer(exchange(self.encode_ping(device_id)), "ping", device_id).value or 0)
                & 0xFFFF
            )
            mode_reply = _answer(
                exchange(self.encode_read(device_id, "operating_mode")), "read mode", device_id
            )
            mode = int(mode_reply.value or 0)
            if mode not in POSITION_MODES:
                for item, value in (("torque_enable", 0), ("operating_mode", POSITION_MODES[0])):
                    _answer(exchange(self.encode_write(device_id, item, value)), item, device_id)
                mode = POSITION_MODES[0]
            modes.append(mode)
            _answer(
                exchange(self.encode_write(device_id, "torque_enable", 1)), "torque on", device_id
            )
        self.position_mode = (
            OPERATING_MODE["extended_position"]
            if all(m == OPERATING_MODE["extended_position"] for m in modes)
            else OPERATING_MODE["position"]
        )
        self._velocity_mode = False

    def reset(self) -> None:
        super().reset()
        self._pending.clear()

    def _parse(self) -> list[Reply]:
        replies = []
        for p in self._counted(split_packets(self._buffer)):
            if p.instruction != STATUS or not p.params:
                self.bad_frames += 1  # our own instruction echoed by a half-duplex adapter
                continue
            replies.append(self._status(p))
        return replies

    def _status(self, p: Packet) -> Reply:
        pending = self._pending.get(p.device_id)
        error, data = p.params[0], p.params[1:]
        if error:
            if pending:
                pending.popleft()
            return Reply("error", reason=error_reason(error), device_id=p.device_id, raw=p.raw)
        if pending:
            expect = pending.popleft()
        elif p.device_id in self.ids and len(data) == 4:
            expect = "position"
        else:
            expect = "ack" if not data else "value"
        if expect == "position" and p.device_id in self.ids and len(data) == 4:
            value = int32(data)
            self._present[p.device_id] = value
            angle = self.angle_rad(value)
            if p.device_id == self.pan_id:
                return Reply("position", pan_rad=angle, device_id=p.device_id, raw=p.raw)
            return Reply("position", tilt_rad=angle, device_id=p.device_id, raw=p.raw)
        if expect == "ack" and not data:
            return Reply("ack", device_id=p.device_id, raw=p.raw)
        value = int.from_bytes(data, "little") if data else None
        return Reply("ok", value=value, device_id=p.device_id, raw=p.raw)


def _answer(replies: list[Reply], what: str, device_id: int) -> Reply:
    return handshake_reply(replies, f"Dynamixel id {device_id}", what)
