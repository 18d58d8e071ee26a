"""Sony VISCA pan-tilt over RS-232/422 (PROTOCOLS.md §2).

Packets are `8x <payload> FF` from the host (x = camera address 1..7, 88 broadcast) and
`z0 <payload> FF` from the camera (z = address + 8). No byte but the terminator may be FF, so
16-bit values travel as four nibbles, most significant first, each in the low half of its own
byte: -1 -> 0F 0F 0F 0F, +2267 -> 00 08 0D 0B (Sony EVI-D70 technical manual p.42, 51).

    Pan-tiltDrive     8x 01 06 01 VV WW PP TT FF           PP 01 left 02 right 03 stop,
                                                           TT 01 up 02 down 03 stop
    AbsolutePosition  8x 01 06 02 VV WW 0Y 0Y 0Y 0Y 0Z 0Z 0Z 0Z FF
    Pan-tiltPosInq    8x 09 06 12 FF  ->  y0 50 0w 0w 0w 0w 0z 0z 0z 0z FF
    CAM_Zoom Direct   8x 01 04 47 0p 0q 0r 0s FF           pqrs: zoom position, 0 widest
    CAM_ZoomPosInq    8x 09 04 47 FF  ->  y0 50 0p 0q 0r 0s FF
    IF_Clear          8x 01 00 01 FF  ->  y0 50 FF (no ACK)

Every command is answered by an ACK `z0 4y FF` (accepted into socket y) or an error
`z0 6y ee FF`, and later by a completion `z0 5y FF` when it has been executed, or by
`z0 6y 41 FF` when it could not be; inquiries get their answer directly (Sony SRG-300H
technical manual p.28). The camera has two command sockets: the codec keeps which of them hold
a command (from the ACKs, completions and errors it decodes), so the driver sends a command only
when one is free (`has_room`), and one refused with `z0 60 03 FF` (buffer full: both busy, as
when the codec lost track after a timeout) is sent again once a socket frees. Pan is positive to the
right and tilt positive up; units per degree depend on the model (the rig's `pan_deg_per_unit`). The
zoom's position runs from 0 (widest) to the model's telephoto end (0x4000 on most Sony models'
optical zoom; the rig's `zoom_max_units`), which gazed calls zoom 1.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Hashable
from dataclasses import replace
from typing import ClassVar, TypeVar

from gazed.servo.codec import Codec, CodecError, Exchange, HandshakeError, Reply, nearest
from gazed.servo.resync import Cut, Skip, Split, Take, resync

T = TypeVar("T")

TERMINATOR = 0xFF
MAX_PACKET = 16
BROADCAST = 0x88

CATEGORY = {"command": 0x01, "inquiry": 0x09, "interface": 0x00, "camera": 0x04, "pan_tilt": 0x06}
PAN_TILT = {"drive": 0x01, "absolute": 0x02, "relative": 0x03, "home": 0x04, "reset": 0x05}
PAN_TILT_POSITION_INQUIRY = 0x12
ZOOM_DIRECT = 0x47  # CAM_Zoom Direct, and with the inquiry category CAM_ZoomPosInq
ZOOM_UNITS_MAX = 0x7FFF  # the nibbles carry a signed 16-bit word here; zoom is never negative
IF_CLEAR = (0x01, 0x00, 0x01)
CANCEL = 0x20  # 8x 2y FF cancels the command in socket y
PAN_DIRECTION = {"left": 0x01, "right": 0x02, "stop": 0x03}
TILT_DIRECTION = {"up": 0x01, "down": 0x02, "stop": 0x03}
PAN_SPEED_MAX = 0x18  # the usual highest speed bytes (EVI-D70, PTZOptics)
TILT_SPEED_MAX = 0x14
SPEED_CODE_LIMIT = 0x7F  # no payload byte may reach the terminator's high bit

# reply message types (high nibble of the second byte) and error codes (SRG-300H p.28)
REPLY = {"ack": 0x40, "completion": 0x50, "error": 0x60}
NETWORK_CHANGE = 0x38
ERRORS = {
    0x01: "message length error",
    0x02: "syntax error",
    0x03: "command buffer full",
    0x04: "command cancelled",
    0x05: "no socket",
    0x41: "command not executable",
}
BUFFER_FULL = ERRORS[0x03]
NOT_EXECUTABLE = ERRORS[0x41]
SOCKETS = (1, 2)


def to_nibbles(value: int) -> bytes:
    """Signed 16-bit two's complement -> four bytes, one nibble each, most significant first."""
    if not -0x8000 <= value <= 0x7FFF:
        raise CodecError(f"{value} does not fit a signed 16-bit VISCA position")
    word = value & 0xFFFF
    return bytes((word >> shift) & 0x0F for shift in (12, 8, 4, 0))


def from_nibbles(data: bytes | bytearray) -> int:
    """Four nibble bytes -> signed 16-bit (pyvisca returns them unsigned; this sign-extends)."""
    word = 0
    for b in data:
        word = (word << 4) | (b & 0x0F)
    return word - 0x10000 if word & 0x8000 else word


def units_from_rad(angle_rad: float, deg_per_unit: float) -> int:
    """An angle in position units, rounded to nearest."""
    if not math.isfinite(angle_rad):
        raise CodecError(f"angle {angle_rad} is not finite")
    return nearest(math.degrees(angle_rad) / deg_per_unit)


def reply_header(address: int) -> int:
    """The first byte of the replies of camera `address`: (address + 8) << 4."""
    return (address + 8) << 4


def split_packets(
    buffer: bytearray, is_header: bytes, decode: Callable[[bytes], T | None]
) -> Split[T]:
    """Take every `header ... FF` packet (at most 16 bytes) off the front of `buffer` that
    `decode` accepts, and return what it made of them. `is_header` lists the bytes a packet may
    start with. A packet `decode` refuses is skipped one byte at a time, like garbage, so a
    false start never swallows a real packet."""

    def find_start(front: bytearray) -> int:
        return next((i for i, b in enumerate(front) if b in is_header), -1)

    def cut(front: bytearray) -> Cut[T]:
        end = front.find(TERMINATOR, 1)
        if end < 0 and len(front) < MAX_PACKET:
            return None
        decoded = decode(bytes(front[: end + 1])) if 0 < end < MAX_PACKET else None
        return Skip() if decoded is None else Take(end + 1, decoded)

    return resync(buffer, cut, find_start)


class ViscaCodec(Codec):
    """Host side of VISCA. `pan_speed_max_code`/`tilt_speed_max_code` are the highest speed
    bytes the camera takes (0x18/0x14 on most models; Sony SRG-X400 tilt 0x17, pyvisca sends
    up to 0x18); `pan_speed`/`tilt_speed` the speed bytes of absolute moves;
    `pan_speed_max_deg_s`/`tilt_speed_max_deg_s` the rates of the highest speed bytes (drive
    speeds are mapped linearly; the model's own table is not linear)."""

    protocol: ClassVar[str] = "visca"

    def __init__(
        self,
        address: int = 1,
        pan_deg_per_unit: float = 0.075,
        tilt_deg_per_unit: float = 0.075,
        pan_speed: int = PAN_SPEED_MAX,
        tilt_speed: int = TILT_SPEED_MAX,
        pan_speed_max_deg_s: float = 120.0,
        tilt_speed_max_deg_s: float = 90.0,
        pan_speed_max_code: int = PAN_SPEED_MAX,
        tilt_speed_max_code: int = TILT_SPEED_MAX,
        zoom_max_units: int = 0x4000,
    ) -> None:
        super().__init__()
        if not 1 <= address <= 7:
            raise CodecError(f"address {address} outside 1..7")
        for name, code in (("pan", pan_speed_max_code), ("tilt", tilt_speed_max_code)):
            if not 1 <= code <= SPEED_CODE_LIMIT:
                raise CodecError(f"{name} speed max {code:#x} outside 0x01..{SPEED_CODE_LIMIT:#x}")
        if not (1 <= pan_speed <= pan_speed_max_code and 1 <= tilt_speed <= tilt_speed_max_code):
            raise CodecError(
                f"speeds {pan_speed}, {tilt_speed} outside 1..{pan_speed_max_code}, "
                f"1..{tilt_speed_max_code}"
            )
        if not 1 <= zoom_max_units <= ZOOM_UNITS_MAX:
            raise CodecError(f"zoom max {zoom_max_units:#x} outside 0x0001..{ZOOM_UNITS_MAX:#x}")
        self.zoom_max_units = zoom_max_units
        self.pan_speed_max_code = pan_speed_max_code
        self.tilt_speed_max_code = tilt_speed_max_code
        self.address = address
        self.pan_deg_per_unit = pan_deg_per_unit
        self.tilt_deg_per_unit = tilt_deg_per_unit
        self.pan_speed = pan_speed
        self.tilt_speed = tilt_speed
        self.pan_speed_max_deg_s = pan_speed_max_deg_s
        self.tilt_speed_max_deg_s = tilt_speed_max_deg_s
        self._header = 0x80 | address
        self._reply_headers = bytes((reply_header(address),))
        self.sockets_busy: set[int] = set()
        self._buffer_full = False  # the camera said both sockets are busy; none freed since
        self.last_ack: tuple[int, int] | None = None  # the newest ACK: its socket and number
        self._acks = 0
        self._filled_by: dict[int, int] = {}  # the number of the ACK that filled each socket

    @property
    def resolution_rad(self) -> tuple[float, float]:
        return math.radians(self.pan_deg_per_unit), math.radians(self.tilt_deg_per_unit)

    def _packet(self, *payload: int) -> bytes:
        return bytes((self._header, *payload, TERMINATOR))

    def encode_set_position(self, pan_rad: float, tilt_rad: float) -> list[bytes]:
        pan = to_nibbles(units_from_rad(pan_rad, self.pan_deg_per_unit))
        tilt = to_nibbles(units_from_rad(tilt_rad, self.tilt_deg_per_unit))
        head = (CATEGORY["command"], CATEGORY["pan_tilt"], PAN_TILT["absolute"])
        return [self._packet(*head, self.pan_speed, self.tilt_speed, *pan, *tilt)]

    def encode_set_velocity(self, pan_rad_s: float, tilt_rad_s: float) -> list[bytes]:
        pan_speed, pan_dir = self._drive(
            pan_rad_s,
            self.pan_speed_max_deg_s,
            self.pan_speed_max_code,
            PAN_DIRECTION,
            "right",
            "left",
        )
        tilt_speed, tilt_dir = self._drive(
            tilt_rad_s,
            self.tilt_speed_max_deg_s,
            self.tilt_speed_max_code,
            TILT_DIRECTION,
            "up",
            "down",
        )
        head = (CATEGORY["command"], CATEGORY["pan_tilt"], PAN_TILT["drive"])
        return [self._packet(*head, pan_speed, tilt_speed, pan_dir, tilt_dir)]

    @staticmethod
    def _drive(
        rate_rad_s: float,
        speed_max_deg_s: float,
        code_max: int,
        directions: dict[str, int],
        positive: str,
        negative: str,
    ) -> tuple[int, int]:
        if not math.isfinite(rate_rad_s):
            raise CodecError(f"rate {rate_rad_s} is not finite")
        code = min(code_max, nearest(abs(math.degrees(rate_rad_s)) / speed_max_deg_s * code_max))
        if code == 0:
            return 1, directions["stop"]
        return code, directions[positive if rate_rad_s > 0 else negative]

    def encode_stop(self) -> list[bytes]:
        head = (CATEGORY["command"], CATEGORY["pan_tilt"], PAN_TILT["drive"])
        stop = (PAN_DIRECTION["stop"], TILT_DIRECTION["stop"])
        return [self._packet(*head, self.pan_speed, self.tilt_speed, *stop)]

    def encode_query_position(self) -> list[bytes]:
        return [self._packet(CATEGORY["inquiry"], CATEGORY["pan_tilt"], PAN_TILT_POSITION_INQUIRY)]

    @property
    def zooms(self) -> bool:
        return True

    def encode_set_zoom(self, zoom: float) -> list[bytes]:
        if not math.isfinite(zoom):
            raise CodecError(f"zoom {zoom} is not finite")
        units = nearest(min(max(zoom, 0.0), 1.0) * self.zoom_max_units)
        return [
            self._packet(CATEGORY["command"], CATEGORY["camera"], ZOOM_DIRECT, *to_nibbles(units))
        ]

    def encode_query_zoom(self) -> list[bytes]:
        return [self._packet(CATEGORY["inquiry"], CATEGORY["camera"], ZOOM_DIRECT)]

    def encode_if_clear(self) -> list[bytes]:
        """IF_Clear: empties the camera's command buffers; answered `z0 50 FF`."""
        return [self._packet(*IF_CLEAR)]

    def encode_cancel(self, socket: int) -> list[bytes]:
        """Cancel `8x 2y FF`: ends the command in socket y, answered `z0 6y 04 FF` (or
        `z0 6y 05 FF` when it had ended); it needs no socket of its own."""
        if socket not in SOCKETS:
            raise CodecError(f"socket {socket} outside {SOCKETS}")
        return [self._packet(CANCEL | socket)]

    @property
    def last_acked(self) -> tuple[int, int] | None:
        return self.last_ack

    def encode_cancel_acked(self, acked: Hashable) -> list[bytes]:
        """Cancel for the socket of the command ACKed as `acked`, if it still holds it."""
        if not isinstance(acked, tuple) or not self.holds(acked):
            return []
        return self.encode_cancel(acked[0])

    def holds(self, acked: Hashable) -> bool:
        """Whether the command whose ACK was `acked` (`last_ack` then) still holds its socket:
        not completed, cancelled or refused since, nor its socket taken by another."""
        if not isinstance(acked, tuple):
            return False
        socket, number = acked
        return socket in self.sockets_busy and self._filled_by.get(socket) == number

    def replies_expected(self, frame_bytes: bytes) -> int:
        # every command, inquiry, IF_Clear and cancel gets exactly one direct answer
        return 1 if len(frame_bytes) >= 3 and frame_bytes[0] == self._header else 0

    def handshake(self, exchange: Exchange) -> None:
        """IF_Clear, so no stale command holds a socket (Tamron MP3010M-EV manual §4.4)."""
        replies = exchange(self.encode_if_clear()[0])
        if not replies or replies[0].kind != "completion":
            got = replies[0].describe() if replies else "nothing"
            raise HandshakeError(f"VISCA IF_Clear answered {got}, expected completion")

    def has_room(self, frame_bytes: bytes) -> bool:
        is_command = len(frame_bytes) >= 3 and frame_bytes[1] == CATEGORY["command"]
        if not is_command or tuple(frame_bytes[1:-1]) == IF_CLEAR:
            return True  # inquiries and IF_Clear use no socket
        return self.has_command_room()

    def has_command_room(self) -> bool:
        return not self._buffer_full and len(self.sockets_busy) < len(SOCKETS)

    def refused_as_busy(self, reply: Reply) -> bool:
        return reply.kind == "error" and reply.reason == BUFFER_FULL

    def reset(self) -> None:
        super().reset()
        self.sockets_busy.clear()
        self._buffer_full = False
        self._filled_by.clear()
        self.last_ack = None

    def _parse(self) -> list[Reply]:
        split = split_packets(self._buffer, self._reply_headers, self._decode)
        return [self._track(reply) for reply in self._counted(split)]

    def _track(self, reply: Reply) -> Reply:
        """Keep the sockets the reply names. An ACK fills its socket; a completion, or an error
        naming a socket, frees it (`z0 50 FF`, IF_Clear's answer, frees both). `z0 6y 41 FF` on
        a socket holding a command ends that command: it answers no request in flight."""
        socket = reply.socket
        if reply.kind == "ack" and socket is not None:
            self.sockets_busy.add(socket)
            self._acks += 1
            self._filled_by[socket] = self._acks
            self.last_ack = (socket, self._acks)
            return reply
        if reply.kind == "error" and reply.reason == BUFFER_FULL:
            self._buffer_full = True
            return reply
        if reply.kind not in ("completion", "error"):
            return reply
        ends_command = reply.kind == "error" and reply.reason == NOT_EXECUTABLE
        if ends_command and socket in self.sockets_busy:
            reply = replace(reply, asynchronous=True)
        if socket:
            self.sockets_busy.discard(socket)
            self._buffer_full = False
        elif reply.kind == "completion" and len(reply.raw) == 3:
            self.sockets_busy.clear()
            self._buffer_full = False
        return reply

    def _decode(self, p: bytes) -> Reply | None:
        kind, socket = p[1] & 0xF0, p[1] & 0x0F
        if len(p) == 3 and kind == REPLY["ack"] and socket in (1, 2):
            return Reply("ack", socket=socket, raw=p)
        if len(p) == 3 and kind == REPLY["completion"]:
            return Reply("completion", socket=socket, asynchronous=socket != 0, raw=p)
        if len(p) == 3 and p[1] == NETWORK_CHANGE:
            return Reply("ok", reason="network change", asynchronous=True, raw=p)
        if len(p) == 4 and kind == REPLY["error"] and p[2] in ERRORS:
            return Reply("error", socket=socket, reason=ERRORS[p[2]], raw=p)
        if len(p) == 7 and p[1] == REPLY["completion"] and all(b <= 0x0F for b in p[2:6]):
            units = from_nibbles(p[2:6]) & 0xFFFF  # a zoom position is unsigned
            return Reply("zoom", value=min(units / self.zoom_max_units, 1.0), raw=p)
        if len(p) == 11 and p[1] == REPLY["completion"] and all(b <= 0x0F for b in p[2:10]):
            pan = math.radians(from_nibbles(p[2:6]) * self.pan_deg_per_unit)
            tilt = math.radians(from_nibbles(p[6:10]) * self.tilt_deg_per_unit)
            return Reply("position", pan_rad=pan, tilt_rad=tilt, raw=p)
        return None
