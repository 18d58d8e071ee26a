"""VISCA over IP as a transport (`visca-udp://host:52381`): the VISCA codec writes and reads the
same packets as on a serial line, and this wraps each in Sony's header (`visca_ip`).

- `connect()` opens the UDP socket and sends RESET; the link is up once the camera acknowledges
  it, and every message after it takes the next sequence number (0xFFFFFFFF wraps to 0).
- The reply to the message awaiting one must carry its sequence number. A command's later
  completion (`z0 5y FF`) carries the number of the command whose ACK named socket y, and is
  passed on (a completion is never the direct answer: after a RESET, a completion of a command
  from before it may carry the number of the message awaiting its reply); any other reply (a
  late duplicate, a reply to another number) is dropped and counted, and so is a datagram that
  is not a message.
- A message unanswered after `timeout_s / (MAX_RESENDS + 1)` is sent again with the same
  sequence number (Sony p.32), at most `MAX_RESENDS` times; after that, the driver's read
  timeout makes it a link error.
- An abnormal-sequence error `0F 01` (the camera already had that number: an ACK was lost) is
  answered by a RESET, and the message awaiting its reply is sent again under a new number once
  the RESET is acknowledged (Sony: already executed; a new number gets its completion).
- A RESET renumbers the messages to come, not the commands already in the camera's sockets:
  each still completes under the number it was ACKed with, and that completion is passed on
  (the codec frees its socket by it). Only a new link (`connect()`, whose handshake clears the
  sockets) forgets them: a completion dropped after a RESET would leave the codec counting busy
  a socket the camera has freed.

No serial line is behind it: its bytes take no line time.
"""

from __future__ import annotations

import select
import socket
import time
from collections import Counter
from dataclasses import dataclass
from urllib.parse import urlsplit

from gazed.servo import visca_ip
from gazed.servo.transport import READ_SLICE_S, LinkError, NotConnectedError, SerialTransport

SCHEME = "visca-udp"
MAX_RESENDS = 2
DATAGRAM_MAX = 1024


@dataclass
class _Awaiting:
    """A message sent and not yet answered."""

    sequence: int
    datagram: bytes
    sent_s: float
    resends: int = 0


def address_of(url: str) -> tuple[str, int]:
    """`visca-udp://host[:port]` -> (host, port); the port defaults to 52381."""
    parts = urlsplit(url)
    try:
        port = parts.port or visca_ip.DEFAULT_PORT
    except ValueError as exc:
        raise LinkError(f"{url}: {exc}") from exc
    if parts.scheme != SCHEME or not parts.hostname:
        raise LinkError(f"{url}: expected {SCHEME}://host[:port]")
    return parts.hostname, port


def is_completion(payload: bytes) -> bool:
    """`z0 5y FF` with y a command socket: a command's completion, which comes later."""
    return len(payload) == 3 and payload[1] & 0xF0 == 0x50 and payload[1] & 0x0F != 0


def is_ack(payload: bytes) -> bool:
    """`z0 4y FF`: a command accepted into socket y."""
    return len(payload) == 3 and payload[1] & 0xF0 == 0x40


class ViscaIpTransport:
    """A VISCA camera at `url`; `timeout_s` is the driver's read timeout."""

    def __init__(self, url: str, timeout_s: float) -> None:
        self.url = url
        self.address = address_of(url)
        self.resend_s = timeout_s / (MAX_RESENDS + 1)
        self.reset_timeout_s = timeout_s
        self.byte_time_s = 0.0
        self.line_s = 0.0
        self.counters: Counter[str] = Counter()
        self._socket: socket.socket | None = None
        self._sequence = 0
        self._awaiting: _Awaiting | None = None
        self._after_reset: bytes | None = None
        self._executing: dict[int, int] = {}  # socket -> sequence number of its command

    def __enter__(self) -> ViscaIpTransport:
        self.connect()
        return self

    def __exit__(self, *_exc: object) -> None:
        self.disconnect()

    @property
    def is_connected(self) -> bool:
        return self._socket is not None

    def connect(self) -> None:
        """Open the socket and RESET the sequence number (raises `LinkError` when the camera
        does not acknowledge the RESET within the timeout)."""
        if self._socket is not None:
            return
        try:
            sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            sock.connect(self.address)
        except OSError as exc:
            raise LinkError(f"cannot open {self.url}: {exc}") from exc
        sock.setblocking(False)
        self._socket = sock
        self._awaiting = self._after_reset = None
        self._executing.clear()  # a new link: the handshake clears the camera's sockets
        try:
            self._reset()
            deadline = time.monotonic() + self.reset_timeout_s
            while self._awaiting is not None:
                if time.monotonic() >= deadline:
                    raise LinkError(f"{self.url}: no reply to RESET")
                self.read(deadline - time.monotonic())
        except LinkError:
            self.disconnect()
            raise

    def disconnect(self) -> None:
        sock, self._socket = self._socket, None
        if sock is not None:
            sock.close()

    def line_busy_s(self) -> float:
        return 0.0

    def write(self, data: bytes) -> int:
        """Send one VISCA packet under the next sequence number; the wall-clock time (ns)."""
        self._sock()
        self._after_reset = None  # the driver has moved on from the message a RESET held
        self._send_message(data)
        return time.time_ns()

    def read(self, timeout_s: float) -> tuple[bytes, int]:
        """The VISCA bytes of the replies that arrive within `timeout_s` (at most
        `READ_SLICE_S` of waiting), resending an unanswered message when its time comes."""
        sock = self._sock()
        deadline = time.monotonic() + min(max(timeout_s, 0.0), READ_SLICE_S)
        out = bytearray()
        while True:
            self._resend_due()
            wait_s = deadline - time.monotonic()
            if self._awaiting is not None:
                wait_s = min(wait_s, self._awaiting.sent_s + self.resend_s - time.monotonic())
            try:
                readable, _, _ = select.select([sock], [], [], max(0.0, wait_s))
                while readable:
                    out += self._accept(sock.recv(DATAGRAM_MAX))
                    readable, _, _ = select.select([sock], [], [], 0)
            except OSError as exc:
                raise LinkError(f"{self.url}: read failed: {exc}") from exc
            if out or time.monotonic() >= deadline:
                return bytes(out), time.time_ns()

    # --- the protocol ------------------------------------------------------------------------

    def _sock(self) -> socket.socket:
        if self._socket is None:
            raise NotConnectedError(f"{self.url} is not connected (call connect() first)")
        return self._socket

    def _send(self, datagram: bytes) -> None:
        try:
            self._sock().send(datagram)
        except OSError as exc:
            raise LinkError(f"{self.url}: write failed: {exc}") from exc

    def _send_message(self, packet: bytes) -> None:
        self._sequence = visca_ip.next_sequence(self._sequence)
        datagram = visca_ip.frame(visca_ip.visca_type(packet), self._sequence, packet)
        self._send(datagram)
        self._awaiting = _Awaiting(self._sequence, datagram, time.monotonic())

    def _reset(self) -> None:
        datagram = visca_ip.frame(visca_ip.PAYLOAD_TYPE["control"], 0, visca_ip.RESET)
        self._send(datagram)
        self._sequence = 0  # the commands executing keep their numbers (`_executing`)
        self._awaiting = _Awaiting(-1, datagram, time.monotonic())
        self.counters["resets"] += 1

    def _resend_due(self) -> None:
        waiting = self._awaiting
        if waiting is None or time.monotonic() < waiting.sent_s + self.resend_s:
            return
        if waiting.resends >= MAX_RESENDS:
            return
        self._send(waiting.datagram)
        waiting.resends += 1
        waiting.sent_s = time.monotonic()
        self.counters["resends"] += 1

    def _accept(self, datagram: bytes) -> bytes:
        """What of `datagram` goes to the codec."""
        message = visca_ip.parse(datagram)
        if message is None:
            self.counters["garbage_datagrams"] += 1
            return b""
        if message.payload_type in visca_ip.CONTROL_TYPES:
            self._control(message.payload)
            return b""
        if message.payload_type != visca_ip.PAYLOAD_TYPE["reply"]:
            self.counters["garbage_datagrams"] += 1
            return b""
        waiting = self._awaiting
        payload = message.payload
        if is_completion(payload):  # never the direct answer, whatever its number
            if self._executing.get(payload[1] & 0x0F) == message.sequence:
                del self._executing[payload[1] & 0x0F]
                return payload
        elif waiting is not None and message.sequence == waiting.sequence:
            self._awaiting = None
            if is_ack(payload):
                self._executing[payload[1] & 0x0F] = message.sequence
            return payload
        self.counters["foreign_replies"] += 1
        return b""

    def _control(self, payload: bytes) -> None:
        waiting = self._awaiting
        if payload == visca_ip.RESET_ACK and waiting is not None and waiting.sequence < 0:
            self._awaiting = None
            packet, self._after_reset = self._after_reset, None
            if packet is not None:
                self._send_message(packet)
        elif payload == visca_ip.SEQUENCE_ERROR:
            self.counters["sequence_errors"] += 1
            if waiting is not None and waiting.sequence >= 0:
                self._after_reset = waiting.datagram[visca_ip.HEADER.size :]
            self._reset()
        else:
            self.counters["control_errors" if payload[:1] == b"\x0f" else "foreign_replies"] += 1


def open_transport(url: str, baud: int, timeout_s: float) -> ViscaIpTransport | SerialTransport:
    """The transport the port URL names: `visca-udp://` for VISCA over IP, else a pyserial URL."""
    if url.startswith(f"{SCHEME}://"):
        return ViscaIpTransport(url, timeout_s)
    return SerialTransport(url, baud)
