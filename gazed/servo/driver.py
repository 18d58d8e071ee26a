"""A codec on a transport: the head as a device with one lifecycle (STYLE 1).

    with ServoDriver(codec, SerialTransport(rig.servo.port, rig.servo.baud), 0.1) as head:
        t_ns = head.set_position(pan_rad, tilt_rad)      # device angles
        where = head.query_position()                     # DevicePosition, per-axis times

Request/reply matching: each frame is written, then the driver reads until the codec has decoded
as many synchronous replies as `codec.replies_expected(frame)` says (none for Pelco-D motion
commands and Dynamixel Sync Write, an ACK for VISCA commands, one `*`/`!` line per PTU command,
one status packet per ID of a Dynamixel Sync Read), or the read timeout passes. Only then is the
next frame written, so a half-duplex line never has two talkers and VISCA never has more commands
in flight than its sockets. A frame the device has no room for yet (`codec.has_room`: both
VISCA sockets hold commands) waits for a completion, at most the read timeout; a frame refused
because the device is busy (`codec.refused_as_busy`: VISCA buffer full) is sent once more when
it has room. Nothing is queued: each call carries the newest demand, and a caller that must not
wait asks `has_command_room` first. Asynchronous replies (VISCA completions, PTU `!P`/`!T`) are
kept in `notices`. Bytes waiting before a request are stale answers to a request that timed
out: they are decoded, counted and dropped. The read timeout runs from when the request has left
the line (`SerialTransport.line_busy_s`), not from when it was handed to the port.

A position is as old as the reply that carried it: the device read its axis as it began to
answer, which is before the host has the reply's last byte by the reply's time on the line
(8 ms for a PTU's `* 1234` at 9600 baud). Each axis keeps that instant.
"""

from __future__ import annotations

import time
from collections import Counter, deque
from collections.abc import Callable, Hashable
from dataclasses import dataclass

from gazed.servo.codec import Codec, Reply
from gazed.servo.transport import LinkError, Transport


class ServoTimeout(LinkError):
    """The device did not answer within the read timeout."""


class DeviceError(RuntimeError):
    """The device answered with an error (it refused the command); the link itself is fine."""


@dataclass(frozen=True)
class DevicePosition:
    """Both axes in device angles, each with when the device read it (wall clock, ns): the two
    differ where pan and tilt come in two replies (Pelco-D, PTU)."""

    pan_rad: float
    tilt_rad: float
    t_pan_ns: int
    t_tilt_ns: int


class ServoDriver:
    """The head behind one serial port, speaking one protocol."""

    def __init__(
        self,
        codec: Codec,
        transport: Transport,
        timeout_s: float,
        mono_s: Callable[[], float] = time.monotonic,
    ) -> None:
        self.codec = codec
        self.transport = transport
        self.timeout_s = timeout_s
        self._mono_s = mono_s
        self.counters: Counter[str] = Counter()
        self.notices: deque[Reply] = deque(maxlen=32)
        self.last_error: str | None = None

    def __enter__(self) -> ServoDriver:
        self.connect()
        return self

    def __exit__(self, *_exc: object) -> None:
        self.disconnect()

    @property
    def is_connected(self) -> bool:
        return self.transport.is_connected

    def connect(self) -> None:
        """Open the port and run the protocol's start-up handshake (raises `LinkError`,
        `HandshakeError`; the port is closed again on failure)."""
        self.transport.connect()
        self.codec.reset()
        try:
            self.codec.handshake(self.exchange)
        except BaseException:
            self.disconnect()
            raise

    def disconnect(self) -> None:
        self.transport.disconnect()
        self.codec.reset()

    # --- requests --------------------------------------------------------------------------

    def exchange(self, frame: bytes) -> list[Reply]:
        """Write one frame and return its synchronous replies (raises `ServoTimeout`)."""
        return [reply for reply, _ in self.send([frame])[1]]

    def send(
        self, frames: list[bytes], between: Callable[[], None] | None = None
    ) -> tuple[int, list[tuple[Reply, int]]]:
        """Write frames one after another, each after its replies, calling `between()` after
        every frame but the last (the line is quiet then). Returns the time the first frame was
        written and every synchronous reply with the time the device began to send it."""
        t_written_ns = 0
        replies: list[tuple[Reply, int]] = []
        for i, frame in enumerate(frames):
            if i and between is not None:
                between()
            t_ns, frame_replies = self._send_one(frame)
            t_written_ns = t_written_ns or t_ns
            replies += frame_replies
        return t_written_ns, replies

    def _send_one(self, frame: bytes) -> tuple[int, list[tuple[Reply, int]]]:
        """One frame once the device has room for it, sent again if it was refused as busy."""
        for attempt in range(2):
            self._await_room(frame)
            self._drain()
            t_ns = self.transport.write(frame)
            self.codec.sent(frame)
            self.counters["frames_written"] += 1
            replies = self._collect(self.codec.replies_expected(frame))
            busy = any(self.codec.refused_as_busy(reply) for reply, _ in replies)
            if busy:
                self.counters["refused_as_busy"] += 1
            if not busy or attempt:
                break
        return t_ns, replies

    def command(self, frames: list[bytes]) -> int:
        """Send command frames; returns when the first was written. A device error reply raises
        `DeviceError` (after the remaining frames were sent)."""
        t_written_ns, timed = self.send(frames)
        replies = [reply for reply, _ in timed]
        errors = [r.reason or "error" for r in replies if r.kind == "error"]
        if errors:
            self.counters["device_errors"] += len(errors)
            self.last_error = "; ".join(errors)
            raise DeviceError(self.last_error)
        return t_written_ns

    def set_position(self, pan_rad: float, tilt_rad: float) -> int:
        """Send both axes to device angles; the time the bytes were written (ns)."""
        return self.command(self.codec.encode_set_position(pan_rad, tilt_rad))

    def set_velocity(self, pan_rad_s: float, tilt_rad_s: float) -> int:
        return self.command(self.codec.encode_set_velocity(pan_rad_s, tilt_rad_s))

    def stop(self) -> int:
        """Stop both axes where they are (reads the position first where the protocol needs it)."""
        if self.codec.stop_needs_position:
            self.query_position()
        return self.command(self.codec.encode_stop())

    def set_zoom(self, zoom: float) -> int:
        """Send the zoom to position `zoom` (0 widest, 1 longest); the time it was written."""
        return self.command(self.codec.encode_set_zoom(zoom))

    def query_zoom(self) -> float:
        """The zoom's present position, 0 widest to 1 longest (raises `ServoTimeout`,
        `DeviceError`)."""
        _, replies = self.send(self.codec.encode_query_zoom())
        for reply, _ in replies:
            if reply.kind == "error":
                self.counters["device_errors"] += 1
                self.last_error = reply.reason or "error"
                raise DeviceError(self.last_error)
            if reply.kind == "zoom" and reply.value is not None:
                return reply.value
        raise DeviceError(f"zoom reply missing: {[reply.describe() for reply, _ in replies]}")

    def query_position(self, between: Callable[[], None] | None = None) -> DevicePosition:
        """Both axes' present device angles (raises `ServoTimeout`, `DeviceError`). Where the
        query takes several frames and the protocol's replies say what they answer,
        `between()` may use the line between them (to write a fresh command without waiting
        for the whole query)."""
        frames = self.codec.encode_query_position()
        if not self.codec.replies_identify_themselves:
            between = None
        _, replies = self.send(frames, between)
        pan = tilt = None
        t_pan_ns = t_tilt_ns = 0
        for reply, t_sent_ns in replies:
            if reply.kind == "error":
                self.counters["device_errors"] += 1
                self.last_error = reply.reason or "error"
                raise DeviceError(self.last_error)
            if reply.kind == "position":
                if reply.pan_rad is not None:
                    pan, t_pan_ns = reply.pan_rad, t_sent_ns
                if reply.tilt_rad is not None:
                    tilt, t_tilt_ns = reply.tilt_rad, t_sent_ns
        if pan is None or tilt is None:
            got = [reply.describe() for reply, _ in replies]
            raise DeviceError(f"position reply incomplete: {got}")
        return DevicePosition(pan, tilt, t_pan_ns, t_tilt_ns)

    # --- reading ---------------------------------------------------------------------------

    def _collect(self, expected: int) -> list[tuple[Reply, int]]:
        replies: list[tuple[Reply, int]] = []
        byte_time_ns = self.transport.byte_time_s * 1e9
        deadline = self._mono_s() + self.transport.line_busy_s() + self.timeout_s
        while len(replies) < expected:
            remaining = deadline - self._mono_s()
            if remaining <= 0:
                self.counters["timeouts"] += 1
                self.codec.reset()
                raise ServoTimeout(
                    f"{self.transport.url}: {len(replies)} of {expected} replies within "
                    f"{self.timeout_s * 1000:.0f} ms"
                )
            data, t_ns = self.transport.read(remaining)
            for reply in self.codec.feed(data):
                if reply.asynchronous:
                    self._notice(reply)
                else:
                    replies.append((reply, t_ns - round(len(reply.raw) * byte_time_ns)))
        return replies

    def has_command_room(self) -> bool:
        """True when the device can take a command at once (a VISCA socket is free): the
        replies already in are read first, as a completion frees a socket. Nothing waits, so a
        caller that must not block holds its command until this is true."""
        if not self.codec.has_command_room():
            self._drain()
        return self.codec.has_command_room()

    def _await_room(self, frame: bytes) -> None:
        """Read until the device has room for `frame`. When none comes within the read
        timeout, the completions that would have freed it are lost: the codec forgets what it
        kept, and the device answers for itself."""
        if self.codec.has_room(frame):
            return
        self.counters["waits_for_room"] += 1
        deadline = self._mono_s() + self.timeout_s
        while not self.codec.has_room(frame):
            remaining = deadline - self._mono_s()
            if remaining <= 0:
                self.counters["room_waits_expired"] += 1
                self.codec.reset()
                return
            self._take_unasked(self.transport.read(remaining)[0])

    def _drain(self) -> None:
        self._take_unasked(self.transport.read(0)[0])

    def _take_unasked(self, data: bytes) -> None:
        """Replies that answer no request in flight: notices kept, the rest counted stale."""
        if not data:
            return
        for reply in self.codec.feed(data):
            if reply.asynchronous:
                self._notice(reply)
            else:
                self.counters["stale_replies"] += 1

    def _notice(self, reply: Reply) -> None:
        self.counters[f"notices:{reply.kind}"] += 1
        self.notices.append(reply)


def last_acked(driver: object) -> Hashable | None:
    """The command `driver`'s device acknowledged last (`Codec.last_acked`); None for a head
    without a serial codec."""
    return driver.codec.last_acked if isinstance(driver, ServoDriver) else None


def cancel_acked(driver: object, acked: Hashable) -> bool:
    """End the command `acked` names if it still executes (`Codec.encode_cancel_acked`); True
    when a cancel was sent."""
    frames = driver.codec.encode_cancel_acked(acked) if isinstance(driver, ServoDriver) else []
    if not frames:
        return False
    driver.send(frames)
    return True


def takes_now(driver: object) -> bool:
    """Whether `driver` takes a command without waiting (a head without a serial codec, the
    digital head, ONVIF or speed mode, always does). Nothing is encoded to ask."""
    return not isinstance(driver, ServoDriver) or driver.has_command_room()


class RoomWait:
    """A command held for a socket (`takes_now` is false), since when, for one writer.

    Held for the driver's read timeout, the completion that would have freed a socket is taken
    as lost: the command goes to the driver, which waits for room at most that long and then
    forgets the sockets it kept, letting the head answer for itself. Only a serial driver ever
    makes a command wait, so a hold behind any other head never expires."""

    def __init__(self, driver: object) -> None:
        self.driver = driver
        self.since_s: float | None = None

    @property
    def holding(self) -> bool:
        return self.since_s is not None

    def hold(self, t_s: float) -> bool:
        """The command waits at `t_s`; True when this starts the hold."""
        if self.since_s is not None:
            return False
        self.since_s = t_s
        return True

    def end(self) -> None:
        """Nothing waits (the command went out, or none is due)."""
        self.since_s = None

    def expired(self, t_s: float) -> bool:
        """The hold has lasted the driver's read timeout by `t_s`."""
        if self.since_s is None or not isinstance(self.driver, ServoDriver):
            return False
        return t_s - self.since_s >= self.driver.timeout_s
