"""Pelco-D over RS-485 with the extended absolute-position commands (PROTOCOLS.md §1).

Frame, always 7 bytes (Pelco D Protocol Manual v2.1, TF-0002)::

    FF  addr  cmd1  cmd2  data1  data2  cksum      cksum = (addr+cmd1+cmd2+data1+data2) mod 256

Extended commands have bit 0 of cmd2 set and carry a 16-bit argument MSB/LSB in data1/data2
(Pelco C466M-E §5.2.4). Positions are hundredths of a degree, 0..35999. Pan grows to the right.
Tilt raw 0 is the horizon and grows downwards: `raw = round(-tilt_up_deg*100) mod 36000`, so
10° up is 35000 and 30° down is 3000.

Set position is the pan frame (0x4B) then the tilt frame (0x4D); query is 0x51 then 0x53,
answered by 0x59 (pan) and 0x5B (tilt) extended responses. The zoom goes to a position with
0x4F and is read with 0x55, answered by 0x5D; its units are the device's, 0 the widest (the
rig's `zoom_max_units` is the longest zoom, 65535 on units that scale it to their zoom limit).
Motion commands get no reply; a bad checksum or an unsupported command is silently ignored by the
device. The 4-byte general response `FF addr alarm cksum` of C466M-E is not produced by the units
this targets; its bytes are skipped as garbage.

The frame helpers below are shared by the host codec and the emulated device (gazed.sim).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar

from gazed.servo.codec import Codec, CodecError, Reply, nearest
from gazed.servo.resync import Cut, Skip, Split, Take, resync

SYNC = 0xFF
FRAME_LENGTH = 7
HUNDREDTHS_PER_TURN = 36000

# cmd2 of the extended commands (C466M-E §5.2.4; Telycam/AViPAS/Minrray tables for the queries)
EXTENDED = {
    "preset_call": 0x07,
    "set_pan": 0x4B,
    "set_tilt": 0x4D,
    "set_zoom": 0x4F,
    "query_pan": 0x51,
    "query_tilt": 0x53,
    "query_zoom": 0x55,
    "pan_response": 0x59,
    "tilt_response": 0x5B,
    "zoom_response": 0x5D,
}
RESPONSES = (EXTENDED["pan_response"], EXTENDED["tilt_response"], EXTENDED["zoom_response"])
# cmd2 direction bits of the standard drive command (TF-0002); data1 pan speed, data2 tilt speed
DRIVE = {"right": 0x02, "left": 0x04, "up": 0x08, "down": 0x10}
SPEED_MAX = 0x3F
SPEED_TURBO = 0x40


def checksum(body: bytes | bytearray) -> int:
    """Sum of addr, cmd1, cmd2, data1, data2 modulo 256 (the sync byte is not included)."""
    return sum(body) & 0xFF


def frame(address: int, cmd1: int, cmd2: int, data1: int = 0, data2: int = 0) -> bytes:
    """`FF addr cmd1 cmd2 data1 data2 cksum`."""
    body = bytes((address, cmd1, cmd2, data1, data2))
    return bytes((SYNC, *body, checksum(body)))


def word_frame(address: int, cmd2: int, value: int) -> bytes:
    """An extended command or response carrying `value` MSB/LSB in data1/data2."""
    return frame(address, 0, cmd2, (value >> 8) & 0xFF, value & 0xFF)


@dataclass(frozen=True)
class Frame:
    address: int
    cmd1: int
    cmd2: int
    data1: int
    data2: int

    @property
    def word(self) -> int:
        return (self.data1 << 8) | self.data2


def split_frames(
    buffer: bytearray, accept: Callable[[Frame], bool] = lambda frame: True
) -> Split[tuple[Frame, bytes]]:
    """Take every checksum-valid frame that `accept`s off the front of `buffer`, decoded and
    raw. A frame that is not accepted is skipped one byte at a time, like garbage, so a false
    start can never swallow the beginning of a real frame. An incomplete tail stays in
    `buffer`."""

    def cut(front: bytearray) -> Cut[tuple[Frame, bytes]]:
        if len(front) < FRAME_LENGTH:
            return None
        frame = Frame(*front[1:6])
        if checksum(front[1:6]) != front[6] or not accept(frame):
            return Skip()
        return Take(FRAME_LENGTH, (frame, bytes(front[:FRAME_LENGTH])))

    return resync(buffer, cut, find_start=lambda front: front.find(SYNC))


def pan_raw_from_deg(pan_deg: float) -> int:
    """Pan angle -> hundredths 0..35999, rounded (pyptzcontroller truncates: 0.29° must be 29)."""
    return nearest(pan_deg * 100) % HUNDREDTHS_PER_TURN


def tilt_raw_from_deg(tilt_up_deg: float) -> int:
    """Tilt (positive up) -> raw, `round(-tilt_up_deg*100) mod 36000`: 0 is level, not 36000."""
    return nearest(-tilt_up_deg * 100) % HUNDREDTHS_PER_TURN


def pan_deg_from_raw(raw: int, center_deg: float = 0.0) -> float:
    """Hundredths -> the pan angle within ±180° of `center_deg` (pan is a circle)."""
    deg = (raw % HUNDREDTHS_PER_TURN) / 100.0
    return center_deg + (deg - center_deg + 180.0) % 360.0 - 180.0


def tilt_deg_from_raw(raw: int) -> float:
    """Raw -> tilt positive up: above 18000 is above the horizon, `(36000-raw)/100`."""
    raw %= HUNDREDTHS_PER_TURN
    return (HUNDREDTHS_PER_TURN - raw) / 100.0 if raw > HUNDREDTHS_PER_TURN // 2 else -raw / 100.0


class PelcoDCodec(Codec):
    """Host side of Pelco-D. `position_feedback=False` for units without the 0x51/0x53 queries;
    `pan_speed_max_deg_s` / `tilt_speed_max_deg_s` are the rates of drive speed 0x3F (drive
    speeds are device steps, mapped linearly)."""

    protocol: ClassVar[str] = "pelco-d"
    pan_wraps: ClassVar[bool] = True

    def __init__(
        self,
        address: int = 1,
        position_feedback: bool = True,
        pan_speed_max_deg_s: float = 120.0,
        tilt_speed_max_deg_s: float = 90.0,
        zoom_max_units: int = 0xFFFF,
    ) -> None:
        super().__init__()
        if not 1 <= address <= 255:
            raise CodecError(f"address {address} outside 1..255")
        if not 1 <= zoom_max_units <= 0xFFFF:
            raise CodecError(f"zoom max {zoom_max_units} outside 1..65535")
        self.zoom_max_units = zoom_max_units
        self.address = address
        self.position_feedback = position_feedback
        self.pan_speed_max_deg_s = pan_speed_max_deg_s
        self.tilt_speed_max_deg_s = tilt_speed_max_deg_s

    @property
    def resolution_rad(self) -> tuple[float, float]:
        unit = math.radians(0.01)
        return unit, unit

    @property
    def can_report_position(self) -> bool:
        return self.position_feedback

    def encode_set_position(self, pan_rad: float, tilt_rad: float) -> list[bytes]:
        return [
            word_frame(self.address, EXTENDED["set_pan"], pan_raw_from_deg(math.degrees(pan_rad))),
            word_frame(
                self.address, EXTENDED["set_tilt"], tilt_raw_from_deg(math.degrees(tilt_rad))
            ),
        ]

    @property
    def zooms(self) -> bool:
        """Units with the extended commands (the position queries) take and report a zoom."""
        return self.position_feedback

    def encode_set_zoom(self, zoom: float) -> list[bytes]:
        if not math.isfinite(zoom):
            raise CodecError(f"zoom {zoom} is not finite")
        units = nearest(min(max(zoom, 0.0), 1.0) * self.zoom_max_units)
        return [word_frame(self.address, EXTENDED["set_zoom"], units)]

    def encode_query_zoom(self) -> list[bytes]:
        return [frame(self.address, 0, EXTENDED["query_zoom"])]

    def encode_set_velocity(self, pan_rad_s: float, tilt_rad_s: float) -> list[bytes]:
        pan_speed = self._speed(pan_rad_s, self.pan_speed_max_deg_s)
        tilt_speed = self._speed(tilt_rad_s, self.tilt_speed_max_deg_s)
        cmd2 = 0
        if pan_speed:
            cmd2 |= DRIVE["right"] if pan_rad_s > 0 else DRIVE["left"]
        if tilt_speed:
            cmd2 |= DRIVE["up"] if tilt_rad_s > 0 else DRIVE["down"]
        return [frame(self.address, 0, cmd2, pan_speed, tilt_speed)]

    @staticmethod
    def _speed(rate_rad_s: float, speed_max_deg_s: float) -> int:
        if not math.isfinite(rate_rad_s):
            raise CodecError(f"rate {rate_rad_s} is not finite")
        return min(SPEED_MAX, nearest(abs(math.degrees(rate_rad_s)) / speed_max_deg_s * SPEED_MAX))

    def encode_stop(self) -> list[bytes]:
        return [frame(self.address, 0, 0, 0, 0)]

    def encode_query_position(self) -> list[bytes]:
        return [
            frame(self.address, 0, EXTENDED["query_pan"]),
            frame(self.address, 0, EXTENDED["query_tilt"]),
        ]

    def replies_expected(self, frame_bytes: bytes) -> int:
        queries = (EXTENDED["query_pan"], EXTENDED["query_tilt"], EXTENDED["query_zoom"])
        is_query = len(frame_bytes) == FRAME_LENGTH and frame_bytes[3] in queries
        return 1 if is_query and self.position_feedback else 0

    def _is_reply(self, frame: Frame) -> bool:
        """Our camera's extended response (not another camera's, nor our own command echoed
        by the RS-485 adapter)."""
        return frame.address == self.address and frame.cmd1 == 0 and frame.cmd2 in RESPONSES

    def _parse(self) -> list[Reply]:
        replies = []
        for f, raw in self._counted(split_frames(self._buffer, self._is_reply)):
            if f.cmd2 == EXTENDED["pan_response"]:
                pan = math.radians(pan_deg_from_raw(f.word))
                replies.append(Reply("position", pan_rad=pan, raw=raw))
            elif f.cmd2 == EXTENDED["tilt_response"]:
                tilt = math.radians(tilt_deg_from_raw(f.word))
                replies.append(Reply("position", tilt_rad=tilt, raw=raw))
            else:
                zoom = min(f.word / self.zoom_max_units, 1.0)
                replies.append(Reply("zoom", value=zoom, raw=raw))
        return replies
