"""The device side of the FLIR / DP PTU ASCII protocol (PROTOCOLS.md §3), for the head emulator.

Commands are tokens ended by a space, CR or LF; op codes are case-insensitive. Every command is
answered by one line ending CR LF: `*` (a query adds its result), or `! <message>` with the
manuals' wording (`! Pan speed cannot exceed 2902 positions/sec`, PTU-D46 §4.4). Echo (`EE`,
the power-up default) repeats the command before its answer; verbose feedback (`FV`, the
default) answers queries in sentences (`* Current Pan position is 1000`), terse (`FT`) with the
number alone. Positions are steps of the rig's `pan_arcsec_per_position`; the position limits
(`PN`/`PX`/`TN`/`TX`) are the rig's joint limits rounded outwards to whole positions, the upper
speed (`PU`/`TU`) the rig's rate limit. In pure velocity mode (`CV`) `PS`/`TS` are signed speeds
(a separate register from the move speeds of `CI`) and an axis that runs into a limit stops
there with the asynchronous notice `!P` / `!T`.
`A` (await) answers once the commanded moves are complete; commands sent meanwhile wait.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from gazed.config import FlirPtuServo
from gazed.servo.axis_motion import AxisMotion
from gazed.servo.flir_ptu import OPS, parse_command, rad_from_positions
from gazed.servo.resync import Cut, Skip, Take, resync
from gazed.sim.head_mechanics import HeadMechanics

TOKEN_ENDS = b" \r\n"
MAX_TOKEN = 64
EOL = "\r\n"
AXIS_NAMES = {"P": "Pan", "T": "Tilt"}


def _token(front: bytearray) -> Cut[str]:
    """A command token ended by a space, CR or LF; a token too long to end is dropped."""
    end = next((i for i, b in enumerate(front) if b in TOKEN_ENDS), -1)
    if end < 0:
        return Skip(len(front)) if len(front) > MAX_TOKEN else None
    return Take(end + 1, bytes(front[:end]).decode("latin-1"))


class FlirPtuDevice:
    """A PTU driving `mechanics`, with the rig's resolutions."""

    def __init__(self, servo: FlirPtuServo, mechanics: HeadMechanics) -> None:
        self.mechanics = mechanics
        self.arcsec = {"P": servo.pan_arcsec_per_position, "T": servo.tilt_arcsec_per_position}
        self.axes: dict[str, AxisMotion] = {"P": mechanics.pan, "T": mechanics.tilt}
        self.min_positions = {
            k: math.floor(self._positions(k, a.lower_rad)) for k, a in self.axes.items()
        }
        self.max_positions = {
            k: math.ceil(self._positions(k, a.upper_rad)) for k, a in self.axes.items()
        }
        self.upper_speed = {
            k: math.floor(self._positions(k, a.rate_max_rad_s)) for k, a in self.axes.items()
        }
        self.lower_speed = {"P": 1, "T": 1}
        self.move_speed = dict(self.upper_speed)  # `PS` in independent mode: speed of moves
        self.velocity = {"P": 0, "T": 0}  # `PS` in velocity mode: signed rate
        self.echo = True
        self.verbose = True
        self.velocity_mode = False
        self._buffer = bytearray()
        self._awaiting: float | None = None
        self._queued: list[tuple[str, float]] = []
        self.ignored = 0

    def _positions(self, axis: str, angle_rad: float) -> float:
        return math.degrees(angle_rad) * 3600.0 / self.arcsec[axis]

    def receive(self, data: bytes, t_s: float) -> bytes:
        self._buffer += data
        split = resync(self._buffer, _token)
        self.ignored += split.discarded_bytes
        out = [self._submit(token, t_s) for token in split.frames if token]
        return "".join(out).encode("latin-1")

    def poll(self, t_s: float) -> bytes:
        """Limit notices, and the `*` of an `A` once the moves are done (then queued commands)."""
        m = self.mechanics
        m.advance(t_s)
        out = []
        for key, axis in self.axes.items():
            if axis.limit_hit:
                axis.limit_hit = False
                out.append(f"!{key}{EOL}")
        if self._awaiting is not None and t_s >= self._awaiting and m.settled:
            self._awaiting = None
            out.append(self._line("A", "*", self.echo))
            queued, self._queued = self._queued, []
            out += [self._submit(token, t) for token, t in queued]
        return "".join(out).encode("latin-1")

    def _submit(self, token: str, t_s: float) -> str:
        if self._awaiting is not None:
            self._queued.append((token, t_s))
            return ""
        echo = self.echo  # characters are echoed as they arrive, before the command acts
        answer = self._execute(token, t_s)
        return self._line(token, answer, echo)

    def _line(self, token: str, answer: str, echo: bool) -> str:
        if not answer:
            return ""
        return f"{token} {answer}{EOL}" if echo else f"{answer}{EOL}"

    def _execute(self, token: str, t_s: float) -> str:
        parsed = parse_command(token)
        if parsed is None:
            return "! Illegal Command"
        op, value = parsed
        simple: dict[str, Callable[[], None]] = {
            OPS["echo_on"]: lambda: setattr(self, "echo", True),
            OPS["echo_off"]: lambda: setattr(self, "echo", False),
            OPS["feedback_terse"]: lambda: setattr(self, "verbose", False),
            OPS["feedback_verbose"]: lambda: setattr(self, "verbose", True),
            OPS["independent_mode"]: lambda: self._set_mode(t_s, velocity=False),
            OPS["velocity_mode"]: lambda: self._set_mode(t_s, velocity=True),
            OPS["halt"]: lambda: self._halt(t_s, "PT"),
            OPS["halt_pan"]: lambda: self._halt(t_s, "P"),
            OPS["halt_tilt"]: lambda: self._halt(t_s, "T"),
        }
        if op in simple and value is None:
            simple[op]()
            return "*"
        if op == OPS["await"] and value is None:
            self._awaiting = t_s + self.mechanics.latency_s
            return ""
        if len(op) == 2 and op[0] in AXIS_NAMES:
            return self._axis_command(op[0], op[1], value, t_s)
        return "! Illegal Command"

    def _axis_command(self, key: str, what: str, value: int | None, t_s: float) -> str:
        name = AXIS_NAMES[key]
        if what == "R" and value is None:
            return self._result(
                f"{self.arcsec[key]:.4f}", f"{self.arcsec[key]:.4f} seconds arc per position"
            )
        if what in "NX" and value is None:
            limit = self.min_positions[key] if what == "N" else self.max_positions[key]
            word = "Minimum" if what == "N" else "Maximum"
            return self._result(str(limit), f"{word} {name} position is {limit}")
        if what in "UL" and value is None:
            speed = self.upper_speed[key] if what == "U" else self.lower_speed[key]
            word = "Maximum" if what == "U" else "Minimum"
            return self._result(str(speed), f"{word} {name} speed is {speed} positions/sec")
        if what == "P":
            return self._position(key, value, t_s, offset=False)
        if what == "O":
            return self._position(key, value, t_s, offset=True)
        if what == "S":
            return self._speed(key, value, t_s)
        return "! Illegal Command"

    def _result(self, terse: str, verbose: str) -> str:
        return f"* {verbose if self.verbose else terse}"

    def _position(self, key: str, value: int | None, t_s: float, offset: bool) -> str:
        name = AXIS_NAMES[key]
        axis = self.axes[key]
        if value is None:
            self.mechanics.advance(t_s)
            if offset:
                target = round(self._positions(key, axis.target_rad))
                return self._result(str(target), f"Target {name} position is {target}")
            encoder = self.mechanics.encoder()[0 if key == "P" else 1]
            now = round(self._positions(key, encoder))
            return self._result(str(now), f"Current {name} position is {now}")
        target = value + (round(self._positions(key, axis.target_rad)) if offset else 0)
        if target > self.max_positions[key]:
            return f"! Maximum allowable {name} position is {self.max_positions[key]}"
        if target < self.min_positions[key]:
            return f"! Minimum allowable {name} position is {self.min_positions[key]}"
        angle = rad_from_positions(target, self.arcsec[key])
        rate = rad_from_positions(self.move_speed[key], self.arcsec[key])
        self.mechanics.schedule(t_s, lambda m: axis.move_to(angle, rate_rad_s=rate))
        return "*"

    def _speed(self, key: str, value: int | None, t_s: float) -> str:
        name = AXIS_NAMES[key]
        speeds = self.velocity if self.velocity_mode else self.move_speed
        if value is None:
            speed = speeds[key]
            return self._result(str(speed), f"Target {name} speed is {speed} positions/sec")
        if abs(value) > self.upper_speed[key]:
            return f"! {name} speed cannot exceed {self.upper_speed[key]} positions/sec"
        if not self.velocity_mode and value < self.lower_speed[key]:
            return f"! {name} speed cannot be less than {self.lower_speed[key]} positions/sec"
        speeds[key] = value
        if self.velocity_mode:
            axis = self.axes[key]
            rate = rad_from_positions(value, self.arcsec[key])
            self.mechanics.schedule(t_s, lambda m: axis.move_at(rate))
        return "*"

    def _set_mode(self, t_s: float, velocity: bool) -> None:
        if velocity == self.velocity_mode:
            return
        self.velocity_mode = velocity
        self._halt(t_s, "PT")

    def _halt(self, t_s: float, keys: str) -> None:
        axes = [self.axes[k] for k in keys]
        self.mechanics.schedule(t_s, lambda m: [axis.hold() for axis in axes])
        for k in keys:
            self.velocity[k] = 0
