"""The emulated head's end of the serial line, without the pty: the protocol's device model, the
mechanism, and the line's timing at the rig's baud rate. Driven by explicit times, so tests and
benchmarks can run it on a clock of their own; `HeadEmulator` puts it on a real pty.

The line is 8N1, ten bit times a byte. A request counts as received when its last byte would
have arrived; the device answers `head_reply_delay_ms` later; the answer reaches the host when
its last byte would have, answers queuing behind each other on the line. So poll rates and
latencies measured against the emulator are those of the real line at that baud rate.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from typing import Protocol

from gazed.config import Rig
from gazed.servo.transport import BITS_PER_BYTE
from gazed.sim.head_dynamixel import DynamixelDevice
from gazed.sim.head_flir_ptu import FlirPtuDevice
from gazed.sim.head_mechanics import HeadMechanics
from gazed.sim.head_pelco_d import PelcoDDevice
from gazed.sim.head_visca import ViscaDevice


class DeviceModel(Protocol):
    """The device side of one protocol."""

    def receive(self, data: bytes, t_s: float) -> bytes:
        """Bytes from the host, fully received at `t_s`; returns the reply bytes."""
        ...

    def poll(self, t_s: float) -> bytes:
        """Bytes the device sends unasked by `t_s` (completions, limit notices)."""
        ...


DEVICES: dict[str, Callable[..., DeviceModel]] = {
    "pelco-d": PelcoDDevice,
    "visca": ViscaDevice,
    "flir-ptu": FlirPtuDevice,
    "dynamixel": DynamixelDevice,
}


class HeadLine:
    """The rig's head at the far end of its serial line, on the caller's clock (seconds).
    `serial=False` is a network link: its bytes take no line time."""

    def __init__(self, rig: Rig, t0_s: float, *, serial: bool = True) -> None:
        self.mechanics = HeadMechanics(rig.head, rig.sim, t0_s)
        self.device: DeviceModel = DEVICES[rig.servo.protocol](rig.servo, self.mechanics)
        self.byte_time_s = BITS_PER_BYTE / rig.servo.baud if serial else 0.0
        self.reply_delay_s = rig.sim.head_reply_delay_ms / 1000.0
        self._arrivals: deque[tuple[float, bytes]] = deque()
        self._outgoing: deque[tuple[float, bytes]] = deque()
        self._in_free_s = t0_s
        self._out_free_s = t0_s

    def receive(self, data: bytes, t_s: float) -> None:
        """The host started writing `data` at `t_s`."""
        if data:
            done = max(t_s, self._in_free_s) + len(data) * self.byte_time_s
            self._in_free_s = done
            self._arrivals.append((done, data))

    def next_due_s(self) -> float | None:
        """When the next request completes or the next reply reaches the host."""
        due = [queue[0][0] for queue in (self._arrivals, self._outgoing) if queue]
        return min(due) if due else None

    def service(self, t_s: float) -> bytes:
        """Act on the requests received by `t_s`, move the axes to `t_s`, and return the bytes
        that have reached the host by then."""
        while self._arrivals and self._arrivals[0][0] <= t_s:
            t_received, data = self._arrivals.popleft()
            self._send(self.device.receive(data, t_received), t_received + self.reply_delay_s)
        self.mechanics.advance(t_s)
        self._send(self.device.poll(t_s), t_s)
        out = bytearray()
        while self._outgoing and self._outgoing[0][0] <= t_s:
            out += self._outgoing.popleft()[1]
        return bytes(out)

    def _send(self, data: bytes, t_s: float) -> None:
        if data:
            done = max(t_s, self._out_free_s) + len(data) * self.byte_time_s
            self._out_free_s = done
            self._outgoing.append((done, data))
