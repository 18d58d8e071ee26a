"""The device side of Pelco-D (PROTOCOLS.md §1), for the head emulator.

Answers as a PTZ unit with the extended commands does: set pan (0x4B) / set tilt (0x4D) start an
absolute move and are not answered; the standard drive command (cmd2 direction bits, data1/data2
speeds 0..0x3F, 0x40 turbo) drives continuously until the stop command (all bits clear); queries
0x51 / 0x53 are answered with 0x59 / 0x5B extended responses carrying the encoder reading in
hundredths of a degree (tilt in Pelco's downward-positive convention); set zoom (0x4F) moves
the lens and the zoom query (0x55) is answered with 0x5D, in `zoom_max_units` of the rig. Frames
with a bad checksum, another address or an unsupported command are ignored in silence, as the
protocol says. With `position_feedback = false` the unit does not answer queries either.
"""

from __future__ import annotations

import math

from gazed.config import PelcoDServo
from gazed.servo.pelco_d import (
    DRIVE,
    EXTENDED,
    SPEED_MAX,
    SPEED_TURBO,
    Frame,
    pan_deg_from_raw,
    pan_raw_from_deg,
    split_frames,
    tilt_deg_from_raw,
    tilt_raw_from_deg,
    word_frame,
)
from gazed.sim.head_mechanics import HeadMechanics


class PelcoDDevice:
    """A Pelco-D receiver at `servo.address` driving `mechanics`."""

    def __init__(self, servo: PelcoDServo, mechanics: HeadMechanics) -> None:
        self.address = servo.address
        self.position_feedback = servo.position_feedback
        self.pan_speed_max_rad_s = math.radians(servo.pan_speed_max_deg_s)
        self.tilt_speed_max_rad_s = math.radians(servo.tilt_speed_max_deg_s)
        self.zoom_max_units = servo.zoom_max_units
        self.mechanics = mechanics
        # pan is a circle: decode set-points to the turn that holds the middle of the pan range
        self._pan_center_deg = math.degrees((mechanics.pan.lower_rad + mechanics.pan.upper_rad) / 2)
        self._buffer = bytearray()
        self.ignored = 0

    def receive(self, data: bytes, t_s: float) -> bytes:
        """Bytes from the host, received by `t_s`; returns the reply bytes."""
        self._buffer += data
        split = split_frames(self._buffer, lambda f: f.address == self.address)
        self.ignored += split.discarded_bytes
        out = bytearray()
        for frame, _ in split.frames:
            out += self._handle(frame, t_s)
        return bytes(out)

    def poll(self, t_s: float) -> bytes:
        """Pelco-D units never speak unasked."""
        del t_s
        return b""

    def _handle(self, f: Frame, t_s: float) -> bytes:
        m = self.mechanics
        if f.cmd2 == EXTENDED["set_pan"]:
            pan = math.radians(pan_deg_from_raw(f.word, self._pan_center_deg))
            m.schedule(t_s, lambda m: m.pan.move_to(pan))
        elif f.cmd2 == EXTENDED["set_tilt"]:
            tilt = math.radians(tilt_deg_from_raw(f.word))
            m.schedule(t_s, lambda m: m.tilt.move_to(tilt))
        elif f.cmd2 == EXTENDED["set_zoom"] and self.position_feedback:
            zoom = min(f.word / self.zoom_max_units, 1.0)
            m.schedule(t_s, lambda m: m.zoom.move_to(zoom))
        elif f.cmd2 == EXTENDED["query_zoom"] and self.position_feedback:
            m.advance(t_s)
            units = round(m.zoom.position_rad * self.zoom_max_units)
            return word_frame(self.address, EXTENDED["zoom_response"], units)
        elif f.cmd2 in (EXTENDED["query_pan"], EXTENDED["query_tilt"]):
            if not self.position_feedback:
                return b""
            m.advance(t_s)
            pan, tilt = m.encoder()
            if f.cmd2 == EXTENDED["query_pan"]:
                return word_frame(
                    self.address, EXTENDED["pan_response"], pan_raw_from_deg(math.degrees(pan))
                )
            return word_frame(
                self.address, EXTENDED["tilt_response"], tilt_raw_from_deg(math.degrees(tilt))
            )
        elif not f.cmd2 & 0x01:
            self._drive(f, t_s)
        else:
            self.ignored += 1
        return b""

    def _drive(self, f: Frame, t_s: float) -> None:
        """cmd2 bits: right 0x02, left 0x04, up 0x08, down 0x10; all clear (and no speeds) stops."""
        bits = f.cmd2
        if bits & ~(DRIVE["right"] | DRIVE["left"] | DRIVE["up"] | DRIVE["down"]) or f.cmd1 & 0x0F:
            self.ignored += 1  # lens, iris or camera commands: nothing for the axes to do
            return
        if (bits & DRIVE["right"] and bits & DRIVE["left"]) or (
            bits & DRIVE["up"] and bits & DRIVE["down"]
        ):
            self.ignored += 1
            return
        pan_rate = self._rate(f.data1, self.pan_speed_max_rad_s, self.mechanics.pan.rate_max_rad_s)
        tilt_rate = self._rate(
            f.data2, self.tilt_speed_max_rad_s, self.mechanics.tilt.rate_max_rad_s
        )
        pan_rate *= 1 if bits & DRIVE["right"] else -1 if bits & DRIVE["left"] else 0
        tilt_rate *= 1 if bits & DRIVE["up"] else -1 if bits & DRIVE["down"] else 0
        if not bits:
            self.mechanics.schedule(t_s, lambda m: (m.pan.hold(), m.tilt.hold()))
            return
        self.mechanics.schedule(t_s, lambda m: (m.pan.move_at(pan_rate), m.tilt.move_at(tilt_rate)))

    @staticmethod
    def _rate(speed: int, speed_max_rad_s: float, rate_max_rad_s: float) -> float:
        if speed >= SPEED_TURBO:
            return rate_max_rad_s
        return min(speed, SPEED_MAX) / SPEED_MAX * speed_max_rad_s
