"""The serial link: a pyserial URL, so a rig can name `/dev/ttyUSB0`, a pty path,
`socket://host:port`, `spy:///dev/ttyUSB0` (hex dump for debugging) or `loop://` and the driver
never knows which (STYLE 2; pyserial `serial/urlhandler/`).

One lifecycle (STYLE 1): `connect()`, `disconnect()`, `is_connected`, `write()` / `read()`,
usable as a context manager; I/O before `connect()` raises `NotConnectedError`. Every failure of
the port (unplugged adapter, closed pty) comes out as `LinkError`.

A write returns as soon as the port has the bytes; the line then takes ten bit times a byte
(8N1) to send them: 15 ms for two 7-byte Pelco-D frames at 9600 baud. The transport keeps the
time its line will be free (`line_busy_s()`), so the driver waits for a reply only from when
its request has left, and the servo never queues a set-point behind more than the one on the
line; it also adds up the line's time of every byte written and read (`line_s`), from which the
servo tells how full the line is. `socket://` and `loop://` have no serial line behind them:
their bytes take no time.
"""

from __future__ import annotations

import contextlib
import time
from collections import Counter
from typing import Protocol

import serial

# Longest single blocking read; callers loop until their own deadline.
READ_SLICE_S = 0.01
WRITE_TIMEOUT_S = 1.0
BITS_PER_BYTE = 10  # 8N1: start bit, eight data bits, stop bit
UNPACED_SCHEMES = ("socket://", "loop://")


class LinkError(ConnectionError):
    """The serial port cannot be opened, or failed while in use."""


class NotConnectedError(LinkError):
    """I/O was attempted before `connect()`."""


class Transport(Protocol):
    """What the driver needs of a link: `SerialTransport` here, `ViscaIpTransport` for VISCA
    over IP. `counters` holds the link's own counts (none for a serial line)."""

    url: str
    byte_time_s: float
    line_s: float
    counters: Counter[str]

    @property
    def is_connected(self) -> bool: ...

    def connect(self) -> None: ...

    def disconnect(self) -> None: ...

    def write(self, data: bytes) -> int: ...

    def read(self, timeout_s: float) -> tuple[bytes, int]: ...

    def line_busy_s(self) -> float: ...


class SerialTransport:
    """A serial port opened from a pyserial URL at `baud`, 8N1."""

    def __init__(self, url: str, baud: int) -> None:
        self.url = url
        self.baud = baud
        self.byte_time_s = 0.0 if url.startswith(UNPACED_SCHEMES) else BITS_PER_BYTE / baud
        self._serial: serial.SerialBase | None = None
        self._line_free_s = 0.0
        self.line_s = 0.0  # the line's time of every byte written and read so far
        self.counters: Counter[str] = Counter()

    def __enter__(self) -> SerialTransport:
        self.connect()
        return self

    def __exit__(self, *_exc: object) -> None:
        self.disconnect()

    @property
    def is_connected(self) -> bool:
        return self._serial is not None

    def connect(self) -> None:
        if self._serial is not None:
            return
        try:
            self._serial = serial.serial_for_url(
                self.url,
                baudrate=self.baud,
                timeout=READ_SLICE_S,
                write_timeout=WRITE_TIMEOUT_S,
                exclusive=True,
            )
        except (serial.SerialException, OSError, ValueError) as exc:
            raise LinkError(f"cannot open {self.url}: {exc}") from exc

    def disconnect(self) -> None:
        port, self._serial = self._serial, None
        if port is not None:
            # a port already gone (pulled adapter, closed pty) needs no more than this
            with contextlib.suppress(serial.SerialException, OSError):
                port.close()

    def _port(self) -> serial.SerialBase:
        if self._serial is None:
            raise NotConnectedError(f"{self.url} is not connected (call connect() first)")
        return self._serial

    def write(self, data: bytes) -> int:
        """Write all of `data`; returns the wall-clock time (ns) just after the bytes were handed
        to the port (DESIGN §3: the servo stamps the moment command bytes are written)."""
        port = self._port()
        try:
            port.write(data)
        except (serial.SerialException, OSError) as exc:
            raise LinkError(f"{self.url}: write failed: {exc}") from exc
        self._line_free_s = max(self._line_free_s, time.monotonic()) + len(data) * self.byte_time_s
        self.line_s += len(data) * self.byte_time_s
        return time.time_ns()

    def line_busy_s(self) -> float:
        """How long the bytes written so far still take to leave at the baud rate (0: idle)."""
        return max(0.0, self._line_free_s - time.monotonic())

    def read(self, timeout_s: float) -> tuple[bytes, int]:
        """Whatever arrives within `timeout_s` (at most `READ_SLICE_S` of blocking), and the
        wall-clock time (ns) it was read. Returns b"" when nothing came."""
        port = self._port()
        try:
            if timeout_s <= 0:
                waiting = port.in_waiting
                data = port.read(waiting) if waiting else b""
            else:
                data = port.read(max(1, port.in_waiting))
                if data and port.in_waiting:
                    data += port.read(port.in_waiting)
        except (serial.SerialException, OSError) as exc:
            raise LinkError(f"{self.url}: read failed: {exc}") from exc
        self.line_s += len(data) * self.byte_time_s
        return data, time.time_ns()
