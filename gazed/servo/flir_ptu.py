"""FLIR / Directed Perception PTU ASCII protocol (PROTOCOLS.md §3).

A command is `<OP>[<signed decimal>]<delim>`, the delimiter a space or CR, op codes
case-insensitive; a query is the op code alone: `PP1000 ` sets the pan target, `PP ` asks for
the pan position (FLIR PTU-D300 User's Manual v2.19 §4.2-4.5). Every command is answered by one
line: `*` on success (a query adds ` <result>`), `! <message>` on error; `!P` / `!T` are
asynchronous notices that an axis hit a limit. With echo on (`EE`) the unit echoes the command
before the `*`; with verbose feedback (`FV`) results are sentences (`* Current Pan position is
1000`), with terse (`FT`) just the number. A line is parsed from its first `*` or `!`, taking
the last number on it, so every mode reads the same. Lines end in CR or CR LF.

Positions are motor steps: `degrees = positions × arcsec_per_position / 3600` (21.3° at
92.5714″ -> 828 positions, the D300 manual's example). The resolution depends on model and step
mode, so the handshake asks the unit (`PR`, `TR`) instead of trusting the rig file.

Set position is `PP<n>` then `TP<n>`; query `PP` then `TP`; stop `H`. Velocity uses pure
velocity mode (`CV`, signed `PS`/`TS`); going back to positions restores independent mode
(`CI`) and the position-move speeds read at start-up.

A reply line does not say what it answers: it is matched to the oldest frame written and not
yet answered. So the codec learns what is on the wire only from the frames the driver wrote
(`sent`), never from encoding: a frame encoded and not sent (the rest of a request cut short by a
timeout) would otherwise take the answer of the next one, and a pan
position could be read as tilt. The control mode follows the `CV` / `CI` frames sent.
"""

from __future__ import annotations

import math
import re
from collections import deque
from typing import ClassVar

from gazed.servo.codec import (
    Codec,
    CodecError,
    Exchange,
    HandshakeError,
    Reply,
    handshake_reply,
    nearest,
)
from gazed.servo.resync import Cut, Skip, Split, Take, resync

DELIMITER = " "
LINE_ENDS = b"\r\n"
MAX_LINE = 256
SUCCESS = "*"
FAILURE = "!"
LIMIT_NOTICES = {"!P": "pan limit", "!T": "tilt limit"}
NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?")
COMMAND = re.compile(r"^([A-Za-z]+)([-+]?\d+)?$")

# op codes used by gazed (PTU-D300 §4, E-series command reference)
OPS = {
    "pan_position": "PP",
    "tilt_position": "TP",
    "pan_offset": "PO",
    "tilt_offset": "TO",
    "pan_speed": "PS",
    "tilt_speed": "TS",
    "pan_resolution": "PR",
    "tilt_resolution": "TR",
    "pan_min": "PN",
    "pan_max": "PX",
    "tilt_min": "TN",
    "tilt_max": "TX",
    "pan_upper_speed": "PU",
    "tilt_upper_speed": "TU",
    "pan_lower_speed": "PL",
    "tilt_lower_speed": "TL",
    "echo_on": "EE",
    "echo_off": "ED",
    "feedback_terse": "FT",
    "feedback_verbose": "FV",
    "independent_mode": "CI",
    "velocity_mode": "CV",
    "halt": "H",
    "halt_pan": "HP",
    "halt_tilt": "HT",
    "await": "A",
}
POSITION_QUERIES = (OPS["pan_position"], OPS["tilt_position"])
HANDSHAKE_QUERIES = (
    "pan_resolution",
    "tilt_resolution",
    "pan_min",
    "pan_max",
    "tilt_min",
    "tilt_max",
    "pan_speed",
    "tilt_speed",
)


def command(op: str, value: int | None = None) -> bytes:
    """`PP1000 ` or, for a query, `PP `."""
    return f"{op}{'' if value is None else value}{DELIMITER}".encode("ascii")


def parse_command(text: str) -> tuple[str, int | None] | None:
    """(`PP`, 1000) for `PP1000`, (`PP`, None) for the query `PP` (op codes upper-cased,
    delimiters stripped); None for no command."""
    match = COMMAND.match(text.strip())
    if match is None:
        return None
    op, value = match.group(1).upper(), match.group(2)
    return op, None if value is None else int(value)


def positions_from_rad(angle_rad: float, arcsec_per_position: float) -> int:
    """`round(deg × 3600 / arcsec)` (flir_ptu uses ceil; this rounds to nearest)."""
    if not math.isfinite(angle_rad):
        raise CodecError(f"angle {angle_rad} is not finite")
    return nearest(math.degrees(angle_rad) * 3600.0 / arcsec_per_position)


def rad_from_positions(positions: float, arcsec_per_position: float) -> float:
    return math.radians(positions * arcsec_per_position / 3600.0)


def split_lines(buffer: bytearray) -> Split[str]:
    """Take every complete line (ended by CR or LF) off `buffer`, blank ones skipped; a line
    longer than 256 bytes is dropped."""

    def cut(front: bytearray) -> Cut[str]:
        end = next((i for i, b in enumerate(front) if b in LINE_ENDS), -1)
        if end < 0:
            return Skip(len(front)) if len(front) > MAX_LINE else None
        line = bytes(front[:end]).decode("latin-1").strip()
        return Skip(end + 1) if len(line) > MAX_LINE else Take(end + 1, line)

    split = resync(buffer, cut)
    split.frames = [line for line in split.frames if line]
    return split


def parse_line(line: str) -> Reply | None:
    """`*`, `* 1000`, `! message`, `!P`, `!T` (echo and verbose text tolerated); None if the line
    has neither `*` nor `!`."""
    if line in LIMIT_NOTICES:
        return Reply("limit", reason=LIMIT_NOTICES[line], asynchronous=True, raw=line.encode())
    marks = [i for i in (line.find(SUCCESS), line.find(FAILURE)) if i >= 0]
    if not marks:
        return None
    start = min(marks)
    text = line[start + 1 :].strip()
    if line[start] == FAILURE:
        return Reply("error", reason=text or "error", raw=line.encode())
    numbers = NUMBER.findall(text)
    value = float(numbers[-1]) if numbers else None
    return Reply("ok", value=value, reason=text or None, raw=line.encode())


class FlirPtuCodec(Codec):
    """Host side of the PTU protocol. The resolutions given are used until the handshake reads
    the unit's own."""

    protocol: ClassVar[str] = "flir-ptu"
    replies_identify_themselves: ClassVar[bool] = False

    def __init__(
        self, pan_arcsec_per_position: float = 46.2857, tilt_arcsec_per_position: float = 46.2857
    ) -> None:
        super().__init__()
        self.pan_arcsec_per_position = pan_arcsec_per_position
        self.tilt_arcsec_per_position = tilt_arcsec_per_position
        self.limits_positions: dict[str, int] = {}
        self._move_speeds: tuple[int, int] | None = None
        self._velocity_mode = False
        self._pending: deque[str] = deque()  # per frame sent: the position query it is, or ""

    @property
    def resolution_rad(self) -> tuple[float, float]:
        return (
            rad_from_positions(1, self.pan_arcsec_per_position),
            rad_from_positions(1, self.tilt_arcsec_per_position),
        )

    def encode_set_position(self, pan_rad: float, tilt_rad: float) -> list[bytes]:
        pan = positions_from_rad(pan_rad, self.pan_arcsec_per_position)
        tilt = positions_from_rad(tilt_rad, self.tilt_arcsec_per_position)
        frames = []
        if self._velocity_mode:
            if self._move_speeds is None:
                raise CodecError("leaving velocity mode needs the move speeds (run the handshake)")
            frames += [
                command(OPS["independent_mode"]),
                command(OPS["pan_speed"], self._move_speeds[0]),
                command(OPS["tilt_speed"], self._move_speeds[1]),
            ]
        return [*frames, command(OPS["pan_position"], pan), command(OPS["tilt_position"], tilt)]

    def encode_set_velocity(self, pan_rad_s: float, tilt_rad_s: float) -> list[bytes]:
        pan = positions_from_rad(pan_rad_s, self.pan_arcsec_per_position)
        tilt = positions_from_rad(tilt_rad_s, self.tilt_arcsec_per_position)
        frames = [] if self._velocity_mode else [command(OPS["velocity_mode"])]
        return [*frames, command(OPS["pan_speed"], pan), command(OPS["tilt_speed"], tilt)]

    def encode_stop(self) -> list[bytes]:
        return [command(OPS["halt"])]

    def encode_query_position(self) -> list[bytes]:
        return [command(OPS["pan_position"]), command(OPS["tilt_position"])]

    def encode_query(self, op: str) -> list[bytes]:
        """Any query by op code (`PR`, `PN`, …); answered `ok` with the value."""
        return [command(op)]

    def replies_expected(self, frame_bytes: bytes) -> int:
        return 1 if frame_bytes.endswith(DELIMITER.encode()) else 0

    def sent(self, frame_bytes: bytes) -> None:
        """The frame's answer is the next line awaited; `CV` / `CI` switch the control mode."""
        if not self.replies_expected(frame_bytes):
            return
        op, value = parse_command(frame_bytes.decode("latin-1")) or ("", None)
        self._pending.append(op if value is None and op in POSITION_QUERIES else "")
        if op == OPS["velocity_mode"]:
            self._velocity_mode = True
        elif op == OPS["independent_mode"]:
            self._velocity_mode = False

    def handshake(self, exchange: Exchange) -> None:
        """Echo off, terse feedback, independent mode; read resolutions, limits and move speeds
        (PROTOCOLS §3: query the resolution at start-up instead of hard-coding it)."""
        for op in (OPS["echo_off"], OPS["feedback_terse"], OPS["independent_mode"]):
            handshake_reply(exchange(command(op)), "PTU", op)
        values = {name: self._value(exchange, OPS[name]) for name in HANDSHAKE_QUERIES}
        if values["pan_resolution"] <= 0 or values["tilt_resolution"] <= 0:
            raise HandshakeError(
                f"PTU reported resolutions {values['pan_resolution']}, "
                f"{values['tilt_resolution']} arcsec/position"
            )
        self.pan_arcsec_per_position = values["pan_resolution"]
        self.tilt_arcsec_per_position = values["tilt_resolution"]
        self.limits_positions = {
            k: int(values[k]) for k in ("pan_min", "pan_max", "tilt_min", "tilt_max")
        }
        self._move_speeds = (int(values["pan_speed"]), int(values["tilt_speed"]))
        self._velocity_mode = False

    def _value(self, exchange: Exchange, op: str) -> float:
        reply = handshake_reply(exchange(self.encode_query(op)[0]), "PTU", op)
        if reply.value is None:
            raise HandshakeError(f"PTU answered {op} without a number: {reply.describe()}")
        return reply.value

    def reset(self) -> None:
        super().reset()
        self._pending.clear()

    def _parse(self) -> list[Reply]:
        replies = []
        for line in self._counted(split_lines(self._buffer)):
            reply = parse_line(line)
            if reply is None:
                self.bad_frames += 1
                continue
            if not reply.asynchronous:
                reply = self._answer(reply)
            replies.append(reply)
        return replies

    def _answer(self, reply: Reply) -> Reply:
        """Match a `*`/`!` line to the oldest frame sent still waiting for one: the answer to
        a position query is a position."""
        asked = self._pending.popleft() if self._pending else ""
        if reply.kind != "ok" or reply.value is None:
            return reply
        if asked == OPS["pan_position"]:
            pan = rad_from_positions(reply.value, self.pan_arcsec_per_position)
            return Reply("position", pan_rad=pan, raw=reply.raw)
        if asked == OPS["tilt_position"]:
            tilt = rad_from_positions(reply.value, self.tilt_arcsec_per_position)
            return Reply("position", tilt_rad=tilt, raw=reply.raw)
        return reply
