"""Frame sources: one lifecycle for a camera, a stream, a file or the simulator's frames.

    with source:                      # connect() ... disconnect()
        frame = source.read()         # the newest frame not yet returned, or None

`read()` never blocks and never queues: a source keeps only its newest frame, so a slow
consumer skips frames instead of falling behind (DESIGN §3). A source that fails (device
unplugged, stream dropped, file ended) says so in `status()` and reopens itself with
exponential backoff; reading from it meanwhile returns None. `read()` before `connect()`
raises `SourceNotConnectedError`.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass
from typing import Literal

from gazed.vision.frames import CapturedFrame

LinkState = Literal["connected", "connecting", "down"]


class SourceError(ConnectionError):
    """A frame source cannot be used."""


class SourceNotConnectedError(SourceError):
    """The source was used before `connect()` or after `disconnect()`."""


@dataclass(frozen=True)
class SourceStatus:
    link: LinkState
    frames: int = 0
    reopens: int = 0
    last_error: str | None = None


class FrameSource(abc.ABC):
    """Base of every frame source; see the module docstring for the lifecycle."""

    description: str = "frame source"

    def __enter__(self) -> FrameSource:
        self.connect()
        return self

    def __exit__(self, *_exc: object) -> None:
        self.disconnect()

    @property
    @abc.abstractmethod
    def is_connected(self) -> bool: ...

    @abc.abstractmethod
    def connect(self) -> None:
        """Start delivering frames (returns at once; opening happens in the background)."""

    @abc.abstractmethod
    def disconnect(self) -> None:
        """Stop and release the device; safe to call twice."""

    @abc.abstractmethod
    def read(self) -> CapturedFrame | None:
        """The newest frame not returned before, or None."""

    @abc.abstractmethod
    def status(self) -> SourceStatus: ...

    def due_in_s(self) -> float | None:
        """A source that holds frames back (a frame delay): how long until the next is due, as
        nothing wakes the loop then. None: frames wake the loop as they arrive."""
        return None

    def _require_connected(self) -> None:
        if not self.is_connected:
            raise SourceNotConnectedError(f"{self.description}: read before connect()")
