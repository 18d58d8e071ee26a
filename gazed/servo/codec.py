"""The interface every protocol codec implements: pure bytes in and out, no I/O.

A codec turns head commands into the frames the device understands (`encode_*`, angles in
device radians, see `gazed.geometry.kinematics.device_from_joint`) and turns whatever bytes come
back, in any chunking, into typed `Reply`s (`feed`). It keeps only what the protocol makes it
keep: a receive buffer, and for protocols whose replies do not say what they answer (PTU lines,
Dynamixel status packets) the queue of requests sent and not yet answered. Those codecs
follow the wire from the frames the driver says it wrote (`sent`): encoding changes nothing.

Request/reply matching (DESIGN §8): `replies_expected(frame)` says how many synchronous replies
a frame sent elicits; replies marked `asynchronous` (VISCA completions, PTU limit notices) are
not counted. The driver sends a frame, waits for that many replies, then sends the next one, so
a half-duplex bus (RS-485, Dynamixel TTL) never has two talkers.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Hashable
from dataclasses import dataclass
from typing import ClassVar, Literal, TypeVar

from gazed.servo.resync import Split

T = TypeVar("T")

ReplyKind = Literal["position", "zoom", "ack", "completion", "error", "limit", "ok"]

# A receive buffer that grows past this without yielding a frame is garbage: it is dropped.
MAX_BUFFER_BYTES = 4096


class CodecError(ValueError):
    """A command the protocol cannot express (a value out of its range, a missing handshake)."""


class HandshakeError(ConnectionError):
    """The device did not answer the start-up handshake as the protocol says it must."""


@dataclass(frozen=True)
class Reply:
    """One decoded reply from the device.

    `pan_rad` / `tilt_rad` are device angles, None where the reply carries only one axis (or
    none). A `zoom` reply's `value` is the zoom position, 0 widest to 1 longest. `reason` is the
    device's own words for errors and notices; `value` a number the reply carries that is not an
    angle (a PTU resolution, a Dynamixel register); `socket` the VISCA command socket; `device_id`
    the Dynamixel ID. `asynchronous` replies (completions, limit notices) do not answer the request
    in flight.
    """

    kind: ReplyKind
    pan_rad: float | None = None
    tilt_rad: float | None = None
    reason: str | None = None
    value: float | None = None
    socket: int | None = None
    device_id: int | None = None
    asynchronous: bool = False
    raw: bytes = b""

    def describe(self) -> str:
        """One line for people (`gazed servo jog`): kind, angles in degrees, the device's words."""
        parts = [self.kind]
        if self.pan_rad is not None:
            parts.append(f"pan {math.degrees(self.pan_rad):.3f} deg")
        if self.tilt_rad is not None:
            parts.append(f"tilt {math.degrees(self.tilt_rad):.3f} deg")
        if self.value is not None:
            parts.append(f"value {self.value:g}")
        if self.socket is not None:
            parts.append(f"socket {self.socket}")
        if self.device_id is not None:
            parts.append(f"id {self.device_id}")
        if self.reason:
            parts.append(f"({self.reason})")
        if self.asynchronous:
            parts.append("[async]")
        return " ".join(parts)


def handshake_reply(replies: list[Reply], device: str, what: str) -> Reply:
    """The first reply to a start-up request; HandshakeError when none came or it is an error."""
    if not replies or replies[0].kind == "error":
        got = replies[0].describe() if replies else "nothing"
        raise HandshakeError(f"{device} answered {what} with {got}")
    return replies[0]


Exchange = Callable[[bytes], list[Reply]]
"""Send one frame and return its synchronous replies (raises on timeout): the driver's half of a
handshake."""


def nearest(x: float) -> int:
    """Round half away from zero: device units are rounded, never truncated (PROTOCOLS §1)."""
    return int(math.copysign(math.floor(abs(x) + 0.5), x))


class Codec(ABC):
    """One protocol. Subclasses define the frame layout and the tables; see each module."""

    protocol: ClassVar[str]
    pan_wraps: ClassVar[bool] = False
    """True when the protocol's pan is a circle (Pelco-D 0..35999): readings are taken modulo 2π."""
    replies_identify_themselves: ClassVar[bool] = True
    """False when replies are matched to requests by order alone (PTU lines): then no other
    request may be slipped between the frames of one."""

    def __init__(self) -> None:
        self._buffer = bytearray()
        self.discarded_bytes = 0
        self.bad_frames = 0

    # --- commands -------------------------------------------------------------------------

    @abstractmethod
    def encode_set_position(self, pan_rad: float, tilt_rad: float) -> list[bytes]:
        """Frames that send both axes to absolute device angles."""

    @abstractmethod
    def encode_set_velocity(self, pan_rad_s: float, tilt_rad_s: float) -> list[bytes]:
        """Frames that drive both axes continuously at signed device rates."""

    @abstractmethod
    def encode_stop(self) -> list[bytes]:
        """Frames that stop both axes where they are."""

    @abstractmethod
    def encode_query_position(self) -> list[bytes]:
        """Frames that ask for both axes' present positions."""

    def replies_expected(self, frame_bytes: bytes) -> int:
        """Synchronous replies the device sends to one of this codec's frames."""
        del frame_bytes
        return 0

    def sent(self, frame_bytes: bytes) -> None:
        """The driver wrote `frame_bytes` to the device. A codec that follows what is on the
        wire (the requests awaiting an answer, the device's mode) takes it in here, never when
        encoding: a frame encoded and left unsent after a timeout then leaves no trace."""
        del frame_bytes

    def has_room(self, frame_bytes: bytes) -> bool:
        """True when the device can take `frame_bytes` now (VISCA: a command socket is free)."""
        del frame_bytes
        return self.has_command_room()

    def has_command_room(self) -> bool:
        """True when the device can take a command now, asked without encoding one (VISCA: a
        command socket is free)."""
        return True

    def refused_as_busy(self, reply: Reply) -> bool:
        """True when `reply` refuses a frame only because the device is busy (VISCA: command
        buffer full): the frame is sent again once the device has room."""
        del reply
        return False

    @property
    def last_acked(self) -> Hashable | None:
        """The command the device acknowledged last, named so that `encode_cancel_acked` can
        end it later (VISCA: its socket and the ACK's number); None where commands are not
        acknowledged, or none was since the link opened."""
        return None

    def holds(self, acked: Hashable) -> bool:
        """Whether the command acknowledged as `acked` (a `last_acked`) still executes: False
        once its end was heard, and where commands are not acknowledged."""
        del acked
        return False

    def encode_cancel_acked(self, acked: Hashable) -> list[bytes]:
        """Frames that end the command `acked` (a `last_acked`) while it still executes: none
        once it has ended (completed, cancelled, refused, its socket taken by another), nor
        where the protocol cannot cancel a command."""
        del acked
        return []

    def handshake(self, exchange: Exchange) -> None:
        """Bring the device into the state the codec assumes; `exchange` does the I/O. Raises
        `HandshakeError`. Protocols without a handshake do nothing."""
        del exchange

    @property
    def can_report_position(self) -> bool:
        return True

    @property
    def zooms(self) -> bool:
        """True when the protocol drives and reads a zoom lens (`encode_set_zoom`)."""
        return False

    def encode_set_zoom(self, zoom: float) -> list[bytes]:
        """Frames that send the zoom to position `zoom` (0 widest, 1 longest)."""
        raise CodecError(f"{self.protocol} has no zoom command")

    def encode_query_zoom(self) -> list[bytes]:
        """Frames that ask for the zoom's present position."""
        raise CodecError(f"{self.protocol} has no zoom inquiry")

    @property
    def stop_needs_position(self) -> bool:
        """True when `encode_stop` needs a present position decoded first (Dynamixel)."""
        return False

    @property
    @abstractmethod
    def resolution_rad(self) -> tuple[float, float]:
        """One device unit of pan and tilt position, radians."""

    # --- replies --------------------------------------------------------------------------

    def feed(self, data: bytes) -> list[Reply]:
        """Decode replies from bytes in any chunking. Garbage is skipped and counted
        (`discarded_bytes`), frames failing their checksum or layout counted (`bad_frames`);
        this never raises."""
        self._buffer += data
        replies = self._parse()
        if len(self._buffer) > MAX_BUFFER_BYTES:
            self.discarded_bytes += len(self._buffer)
            self._buffer.clear()
        return replies

    @abstractmethod
    def _parse(self) -> list[Reply]:
        """Consume complete frames from `self._buffer`, leaving an incomplete tail."""

    def _counted(self, split: Split[T]) -> list[T]:
        """The frames of one pass over the buffer (`gazed.servo.resync`), its dropped bytes and
        bad frames counted."""
        self.discarded_bytes += split.discarded_bytes
        self.bad_frames += len(split.rejected)
        return split.frames

    def reset(self) -> None:
        """Forget buffered bytes and outstanding requests (after a timeout or a reconnect)."""
        self._buffer.clear()
