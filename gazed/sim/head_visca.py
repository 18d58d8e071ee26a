"""The device side of Sony VISCA pan-tilt (PROTOCOLS.md §2), for the head emulator.

Two command sockets, as on Sony cameras (SRG-300H technical manual p.28): a command is accepted
into a socket and answered `z0 4y FF` at once; its completion `z0 5y FF` follows when it has
been executed — for Pan-tiltDrive, stop and CAM_Zoom Direct once they take effect (the zoom
then runs to its position, as a drive runs at its speed), for absolute/relative moves, Home and
Reset when pan and tilt have settled on the target.
Each command drives one mechanism, pan-tilt or the zoom, and a new command for a mechanism takes
it over from the one executing there, without a Cancel first: Sony's SRG cameras take a new
target for a move under way (Opencast's VISCA steering notes, LS-102, which also say that other
makes refuse it and need the move cancelled), and Fawkes' EVI-D100 driver sends each new
absolute move while the last still runs. The superseded command is reported complete right
after the new one's ACK (its motion has ended), and its socket is free again. A command needs a
free socket (Sony SRG-HD1 and BRC-X400 technical manuals: two sockets, "command buffer full"
while both execute): one that finds both holding commands (a pan-tilt move and a zoom) is
refused with buffer full (`z0 60 03 FF`) and changes nothing. Cancel
`8x 2y FF` answers `z0 6y 04 FF` (no completion follows) or `z0 6y 05 FF`. Inquiries are
answered directly and use no socket; IF_Clear empties the sockets and answers `z0 50 FF`.
CAM_Zoom Direct moves the mechanism's zoom axis (position 0 .. the rig's `zoom_max_units`, the
lens's zoom 0 .. 1); the zoom position inquiry reads it. Anything else, or a parameter out of
range, is a syntax error `z0 60 02 FF`. Packets for another address are not for this camera
and get nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from gazed.config import ViscaServo
from gazed.servo.codec import nearest
from gazed.servo.visca import (
    BROADCAST,
    CANCEL,
    CATEGORY,
    IF_CLEAR,
    PAN_DIRECTION,
    PAN_TILT,
    PAN_TILT_POSITION_INQUIRY,
    REPLY,
    TERMINATOR,
    TILT_DIRECTION,
    ZOOM_DIRECT,
    from_nibbles,
    reply_header,
    split_packets,
    to_nibbles,
)
from gazed.sim.head_mechanics import Action, HeadMechanics

HOST_HEADERS = bytes(range(0x81, 0x89))
SOCKETS = (1, 2)
ERROR_CODE = {"syntax": 0x02, "buffer_full": 0x03, "cancelled": 0x04, "no_socket": 0x05}


@dataclass
class _Job:
    """A command in a socket for `mechanism` ("pan_tilt" or "zoom"): complete at `t_effect_s`,
    or once that mechanism has settled after it when the command `moves` to a target."""

    t_effect_s: float
    moves: bool
    mechanism: str


def _command(packet: bytes) -> bytes | None:
    """A host packet: header, at least one payload byte, terminator."""
    return packet if len(packet) >= 3 else None


class ViscaDevice:
    """A VISCA camera at `servo.address` driving `mechanics`."""

    def __init__(self, servo: ViscaServo, mechanics: HeadMechanics) -> None:
        self.address = servo.address
        self.pan_deg_per_unit = servo.pan_deg_per_unit
        self.tilt_deg_per_unit = servo.tilt_deg_per_unit
        self.pan_speed_max_code = servo.pan_speed_max_code
        self.tilt_speed_max_code = servo.tilt_speed_max_code
        self.pan_speed_max_rad_s = math.radians(servo.pan_speed_max_deg_s)
        self.tilt_speed_max_rad_s = math.radians(servo.tilt_speed_max_deg_s)
        self.zoom_max_units = servo.zoom_max_units
        self.mechanics = mechanics
        self._z = reply_header(self.address)
        self._buffer = bytearray()
        self._sockets: dict[int, _Job] = {}
        self.ignored = 0

    def _reply(self, *payload: int) -> bytes:
        return bytes((self._z, *payload, TERMINATOR))

    def _error(self, socket: int, code: str) -> bytes:
        return self._reply(REPLY["error"] | socket, ERROR_CODE[code])

    def receive(self, data: bytes, t_s: float) -> bytes:
        self._buffer += data
        split = split_packets(self._buffer, HOST_HEADERS, _command)
        self.ignored += split.discarded_bytes
        out = bytearray()
        for p in split.frames:
            if p[0] != BROADCAST and p[0] & 0x0F != self.address:
                continue
            out += self._handle(p[1:-1], t_s)
        return bytes(out)

    def poll(self, t_s: float) -> bytes:
        """Completions of the moves that have ended by `t_s`."""
        out = bytearray()
        self.mechanics.advance(t_s)
        for socket, job in sorted(self._sockets.items()):
            if t_s >= job.t_effect_s and (not job.moves or self._settled(job.mechanism)):
                del self._sockets[socket]
                out += self._reply(REPLY["completion"] | socket)
        return bytes(out)

    def _settled(self, mechanism: str) -> bool:
        m = self.mechanics
        return m.zoom.settled if mechanism == "zoom" else m.pan.settled and m.tilt.settled

    def _handle(self, payload: bytes, t_s: float) -> bytes:
        if tuple(payload) == IF_CLEAR:
            self._sockets.clear()
            return self._reply(REPLY["completion"])
        if len(payload) == 1 and payload[0] & 0xF0 == CANCEL:
            socket = payload[0] & 0x0F
            job = self._sockets.pop(socket, None)
            if job is None:
                return self._error(socket, "no_socket")
            if job.mechanism == "zoom":
                self.mechanics.schedule(t_s, lambda m: m.zoom.hold())
            else:
                self.mechanics.schedule(t_s, lambda m: (m.pan.hold(), m.tilt.hold()))
            return self._error(socket, "cancelled")
        if tuple(payload) == (CATEGORY["inquiry"], CATEGORY["pan_tilt"], PAN_TILT_POSITION_INQUIRY):
            self.mechanics.advance(t_s)
            pan, tilt = self.mechanics.encoder()
            pan_units = nearest(math.degrees(pan) / self.pan_deg_per_unit)
            tilt_units = nearest(math.degrees(tilt) / self.tilt_deg_per_unit)
            return self._reply(REPLY["completion"], *to_nibbles(pan_units), *to_nibbles(tilt_units))
        if tuple(payload) == (CATEGORY["inquiry"], CATEGORY["camera"], ZOOM_DIRECT):
            self.mechanics.advance(t_s)
            zoom_units = nearest(self.mechanics.zoom.position_rad * self.zoom_max_units)
            return self._reply(REPLY["completion"], *to_nibbles(zoom_units))
        if tuple(payload[:3]) == (CATEGORY["command"], CATEGORY["camera"], ZOOM_DIRECT):
            return self._zoom(payload[3:], t_s)
        if (
            len(payload) >= 3
            and payload[0] == CATEGORY["command"]
            and payload[1] == CATEGORY["pan_tilt"]
        ):
            return self._pan_tilt(payload[2], payload[3:], t_s)
        return self._error(0, "syntax")

    def _zoom(self, args: bytes, t_s: float) -> bytes:
        """CAM_Zoom Direct: four nibbles, at most the telephoto end."""
        if len(args) != 4 or any(b > 0x0F for b in args):
            return self._error(0, "syntax")
        units = from_nibbles(args) & 0xFFFF
        if units > self.zoom_max_units:
            return self._error(0, "syntax")
        zoom = units / self.zoom_max_units
        return self._accept((lambda m: m.zoom.move_to(zoom)), False, t_s, mechanism="zoom")

    def _pan_tilt(self, kind: int, args: bytes, t_s: float) -> bytes:
        action = self._decode(kind, args)
        if action is None:
            return self._error(0, "syntax")
        return self._accept(*action, t_s)

    def _accept(self, run: Action, moves: bool, t_s: float, mechanism: str = "pan_tilt") -> bytes:
        """Into a free socket, taking `mechanism` over from the command executing there (whose
        completion follows the ACK). `moves`: it completes when the mechanism settles, not on
        arrival."""
        free = [s for s in SOCKETS if s not in self._sockets]
        if not free:
            return self._error(0, "buffer_full")
        superseded = sorted(s for s, job in self._sockets.items() if job.mechanism == mechanism)
        for old in superseded:
            del self._sockets[old]
        self.mechanics.schedule(t_s, run)
        self._sockets[free[0]] = _Job(t_s + self.mechanics.latency_s, moves, mechanism)
        ack = self._reply(REPLY["ack"] | free[0])
        return ack + b"".join(self._reply(REPLY["completion"] | s) for s in superseded)

    def _decode(self, kind: int, args: bytes) -> tuple[Action, bool] | None:
        """The action of a pan-tilt command and whether it is a move that completes on arrival."""
        if kind == PAN_TILT["drive"] and len(args) == 4:
            vv, ww, pp, tt = args
            if not (1 <= vv <= self.pan_speed_max_code and 1 <= ww <= self.tilt_speed_max_code):
                return None
            pan_sign = {
                PAN_DIRECTION["right"]: 1,
                PAN_DIRECTION["left"]: -1,
                PAN_DIRECTION["stop"]: 0,
            }
            tilt_sign = {
                TILT_DIRECTION["up"]: 1,
                TILT_DIRECTION["down"]: -1,
                TILT_DIRECTION["stop"]: 0,
            }
            if pp not in pan_sign or tt not in tilt_sign:
                return None
            pan_rate = pan_sign[pp] * vv / self.pan_speed_max_code * self.pan_speed_max_rad_s
            tilt_rate = tilt_sign[tt] * ww / self.tilt_speed_max_code * self.tilt_speed_max_rad_s
            if pan_rate == 0 and tilt_rate == 0:
                return (lambda m: (m.pan.hold(), m.tilt.hold())), False
            return (lambda m: (m.pan.move_at(pan_rate), m.tilt.move_at(tilt_rate))), False
        if kind in (PAN_TILT["absolute"], PAN_TILT["relative"]) and len(args) == 10:
            vv, ww = args[0], args[1]
            if not (
                1 <= vv <= self.pan_speed_max_code and 1 <= ww <= self.tilt_speed_max_code
            ) or any(b > 0x0F for b in args[2:]):
                return None
            pan = math.radians(from_nibbles(args[2:6]) * self.pan_deg_per_unit)
            tilt = math.radians(from_nibbles(args[6:10]) * self.tilt_deg_per_unit)
            pan_rate = vv / self.pan_speed_max_code * self.pan_speed_max_rad_s
            tilt_rate = ww / self.tilt_speed_max_code * self.tilt_speed_max_rad_s
            relative = kind == PAN_TILT["relative"]

            def move(m: HeadMechanics) -> None:
                pan_target = pan + (m.pan.target_rad if relative else 0.0)
                tilt_target = tilt + (m.tilt.target_rad if relative else 0.0)
                m.pan.move_to(pan_target, rate_rad_s=pan_rate)
                m.tilt.move_to(tilt_target, rate_rad_s=tilt_rate)

            return move, True
        if kind in (PAN_TILT["home"], PAN_TILT["reset"]) and not args:
            return (lambda m: (m.pan.move_to(0.0), m.tilt.move_to(0.0))), True
        return None
