"""The device side of Dynamixel Protocol 2.0 (PROTOCOLS.md §4): two X-series servos on one bus,
for the head emulator.

Each servo keeps an X-series control table (e-manual). Ping answers the model number (1060,
XL430-W250) and firmware; Read answers the bytes asked for, the present values (Present
Position 132, Present Velocity 128, Moving 122) read from the mechanism at that instant; Write
stores and acts: Torque Enable 64 (on: hold where it is; off: stop), Operating Mode 11 (EEPROM:
only with torque off, else Access Error), Goal Position 116 (position modes 3 and 4, at the
Profile Velocity 112 when non-zero), Goal Velocity 104 (velocity mode 1). Sync Write acts on each
listed servo and is not answered; Sync Read is answered by one status packet per listed ID, in
order. Status Return Level 68 decides which instructions are answered (0 ping only, 1 ping and
reads, 2 all). A packet with our ID and a bad CRC is answered with the CRC error; an
unknown instruction with the instruction error; a goal outside position mode's 0..4095 with the
data limit error. Broadcast Read and Write are never answered.
"""

from __future__ import annotations

import math

from gazed.config import DynamixelServo
from gazed.servo.axis_motion import AxisMotion
from gazed.servo.codec import nearest
from gazed.servo.dynamixel import (
    CONTROL_TABLE,
    INSTRUCTION,
    OPERATING_MODE,
    POSITION_MODES,
    VELOCITY_UNIT_RAD_S,
)
from gazed.servo.dynamixel_packets import (
    BROADCAST_ID,
    STATUS,
    Packet,
    le,
    split_packets,
    status_packet,
)
from gazed.sim.head_mechanics import HeadMechanics

MODEL_NUMBER = 1060  # XL430-W250
FIRMWARE_VERSION = 46
TABLE_SIZE = 147
ERROR = {"instruction": 2, "crc": 3, "data_length": 5, "data_limit": 6, "access": 7}
READ_ONLY = ("model_number", "firmware_version", "moving", "present_velocity", "present_position")
EEPROM = ("operating_mode", "id")


class _Servo:
    """One servo's control table, bound to one axis of the mechanism."""

    def __init__(self, device_id: int, axis: AxisMotion) -> None:
        self.device_id = device_id
        self.axis = axis
        self.table = bytearray(TABLE_SIZE)
        self.put("model_number", MODEL_NUMBER)
        self.put("firmware_version", FIRMWARE_VERSION)
        self.put("id", device_id)
        self.put("operating_mode", OPERATING_MODE["position"])
        self.put("status_return_level", 2)

    def put(self, item: str, value: int) -> None:
        address, size = CONTROL_TABLE[item]
        self.table[address : address + size] = le(value, size)

    def get(self, item: str, signed: bool = False) -> int:
        address, size = CONTROL_TABLE[item]
        return int.from_bytes(self.table[address : address + size], "little", signed=signed)


class DynamixelDevice:
    """Two servos, `pan_id` on the pan axis and `tilt_id` on the tilt axis."""

    def __init__(self, servo: DynamixelServo, mechanics: HeadMechanics) -> None:
        self.mechanics = mechanics
        self.center = servo.center
        self.units_per_rev = servo.units_per_rev
        self.servos = {
            servo.pan_id: _Servo(servo.pan_id, mechanics.pan),
            servo.tilt_id: _Servo(servo.tilt_id, mechanics.tilt),
        }
        self._buffer = bytearray()
        self.ignored = 0

    def receive(self, data: bytes, t_s: float) -> bytes:
        self._buffer += data
        split = split_packets(self._buffer)
        self.ignored += split.discarded_bytes
        out = bytearray()
        for device_id in split.rejected:
            if device_id in self.servos:
                out += status_packet(device_id, ERROR["crc"])
        for p in split.frames:
            if p.instruction != STATUS:
                out += self._handle(p, t_s)
        return bytes(out)

    def poll(self, t_s: float) -> bytes:
        """Dynamixels speak only when asked."""
        del t_s
        return b""

    def _handle(self, p: Packet, t_s: float) -> bytes:
        if p.instruction == INSTRUCTION["sync_write"]:
            self._sync_write(p.params, t_s)
            return b""
        if p.instruction == INSTRUCTION["sync_read"]:
            return self._sync_read(p.params, t_s)
        targets = (
            list(self.servos.values())
            if p.device_id == BROADCAST_ID
            else ([self.servos[p.device_id]] if p.device_id in self.servos else [])
        )
        out = bytearray()
        for servo in targets:
            error, data = self._instruction(servo, p, t_s)
            level = servo.get("status_return_level")
            answered = p.instruction == INSTRUCTION["ping"] or (
                p.device_id != BROADCAST_ID
                and (level >= 2 or (level == 1 and p.instruction == INSTRUCTION["read"]))
            )
            if answered:
                out += status_packet(servo.device_id, error, data)
        return bytes(out)

    def _instruction(self, servo: _Servo, p: Packet, t_s: float) -> tuple[int, bytes]:
        if p.instruction == INSTRUCTION["ping"]:
            return 0, le(MODEL_NUMBER, 2) + le(FIRMWARE_VERSION, 1)
        if p.instruction == INSTRUCTION["read"]:
            if len(p.params) != 4:
                return ERROR["data_length"], b""
            address = int.from_bytes(p.params[0:2], "little")
            size = int.from_bytes(p.params[2:4], "little")
            if address + size > TABLE_SIZE:
                return ERROR["access"], b""
            self._refresh(servo, t_s)
            return 0, bytes(servo.table[address : address + size])
        if p.instruction == INSTRUCTION["write"]:
            if len(p.params) < 3:
                return ERROR["data_length"], b""
            address = int.from_bytes(p.params[0:2], "little")
            return self._write(servo, address, p.params[2:], t_s), b""
        if p.instruction == INSTRUCTION["reboot"]:
            servo.put("torque_enable", 0)
            self.mechanics.schedule(t_s, lambda m: servo.axis.hold())
            return 0, b""
        return ERROR["instruction"], b""

    def _sync_write(self, params: bytes, t_s: float) -> None:
        if len(params) < 4:
            return
        address = int.from_bytes(params[0:2], "little")
        size = int.from_bytes(params[2:4], "little")
        body = params[4:]
        for i in range(0, len(body) - size, size + 1):
            servo = self.servos.get(body[i])
            if servo is not None and len(body) >= i + 1 + size:
                self._write(servo, address, body[i + 1 : i + 1 + size], t_s)

    def _sync_read(self, params: bytes, t_s: float) -> bytes:
        if len(params) < 5:
            return b""
        address = int.from_bytes(params[0:2], "little")
        size = int.from_bytes(params[2:4], "little")
        out = bytearray()
        for device_id in params[4:]:
            servo = self.servos.get(device_id)
            if servo is None:
                continue
            if address + size > TABLE_SIZE:
                out += status_packet(device_id, ERROR["access"])
                continue
            self._refresh(servo, t_s)
            out += status_packet(device_id, 0, bytes(servo.table[address : address + size]))
        return bytes(out)

    def _refresh(self, servo: _Servo, t_s: float) -> None:
        """Present Position / Velocity and Moving, read from the mechanism now."""
        self.mechanics.advance(t_s)
        pan, tilt = self.mechanics.encoder()
        pan_rate, tilt_rate = self.mechanics.encoder_rates()
        on_pan = servo.axis is self.mechanics.pan
        angle, rate = (pan, pan_rate) if on_pan else (tilt, tilt_rate)
        value = self.center + nearest(angle * self.units_per_rev / (2.0 * math.pi))
        servo.put("present_position", value)
        servo.put("present_velocity", nearest(rate / VELOCITY_UNIT_RAD_S))
        servo.put("moving", 0 if servo.axis.settled else 1)

    def _write(self, servo: _Servo, address: int, data: bytes, t_s: float) -> int:
        """Store `data` at `address` and act on the items it covers; the status error."""
        end = address + len(data)
        if end > TABLE_SIZE:
            return ERROR["access"]
        items = [
            name for name, (a, size) in CONTROL_TABLE.items() if a < end and address < a + size
        ]
        if any(name in READ_ONLY for name in items):
            return ERROR["access"]
        if any(name in EEPROM for name in items) and servo.get("torque_enable"):
            return ERROR["access"]
        if "goal_position" in items and servo.get("operating_mode") == OPERATING_MODE["position"]:
            goal = self._value_after(servo, address, data, "goal_position")
            if not 0 <= goal < self.units_per_rev:
                return ERROR["data_limit"]
        servo.table[address:end] = data
        for name in items:
            self._act(servo, name, t_s)
        return 0

    @staticmethod
    def _value_after(servo: _Servo, address: int, data: bytes, item: str) -> int:
        table = bytearray(servo.table)
        table[address : address + len(data)] = data
        a, size = CONTROL_TABLE[item]
        return int.from_bytes(table[a : a + size], "little", signed=True)

    def _act(self, servo: _Servo, item: str, t_s: float) -> None:
        axis = servo.axis
        mode = servo.get("operating_mode")
        torque = bool(servo.get("torque_enable"))
        if item == "torque_enable":
            # on: hold where it is; off: the motor stops driving (a real tilt axis might sag)
            self.mechanics.schedule(t_s, lambda m: axis.hold())
        elif item == "goal_position" and torque and mode in POSITION_MODES:
            goal = servo.get("goal_position", signed=True)
            angle = (goal - self.center) * 2.0 * math.pi / self.units_per_rev
            profile = servo.get("profile_velocity")
            rate = profile * VELOCITY_UNIT_RAD_S if profile else None
            self.mechanics.schedule(t_s, lambda m: axis.move_to(angle, rate_rad_s=rate))
        elif item == "goal_velocity" and torque and mode == OPERATING_MODE["velocity"]:
            rate = servo.get("goal_velocity", signed=True) * VELOCITY_UNIT_RAD_S
            self.mechanics.schedule(t_s, lambda m: axis.move_at(rate))
