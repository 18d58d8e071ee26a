"""Frames off the front of a receive buffer, resynchronising past garbage: the one loop that the
host codecs and the emulated devices of every protocol share.

A protocol says two things: where the next frame may start (`find_start`: its sync byte, its
header) and what lies at the front of the buffer once it starts there (`cut`): a frame still
arriving (`None`), a frame of so many bytes and what it decodes to (`Take`), or bytes that are
no frame (`Skip`). Bytes before a start and skipped bytes are dropped and counted; a skip that
names what it refused (`Skip.rejected`, a frame failing its check) is also counted as a bad
frame. Skipping a refused frame's first byte only, as the binary protocols do, means a false
start never swallows the beginning of a real frame behind it.

    split = resync(buffer, cut, find_start=lambda b: b.find(SYNC))
    split.frames, split.discarded_bytes, split.rejected
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Generic, TypeVar

T = TypeVar("T")


@dataclass(frozen=True)
class Take(Generic[T]):
    """The first `length` bytes are a frame; `frame` is what it decodes to."""

    length: int
    frame: T


@dataclass(frozen=True)
class Skip:
    """The first `length` bytes are no frame: dropped and counted. `rejected` is the number
    naming a frame that failed its check (a bad frame: a Dynamixel packet's ID), None for
    garbage."""

    length: int = 1
    rejected: int | None = None


Cut = Take[T] | Skip | None


@dataclass
class Split(Generic[T]):
    """What one pass over the buffer took: the frames, the bytes dropped, the bad frames."""

    frames: list[T] = field(default_factory=list)
    discarded_bytes: int = 0
    rejected: list[int] = field(default_factory=list)


def from_front(buffer: bytearray | bytes) -> int:
    """A frame may start at any byte (line protocols)."""
    del buffer
    return 0


def resync(
    buffer: bytearray,
    cut: Callable[[bytearray], Cut[T]],
    find_start: Callable[[bytearray], int] = from_front,
    keep: int = 0,
) -> Split[T]:
    """Take every frame `cut` finds off the front of `buffer`, dropping what is not one.
    `find_start` gives the offset of the first byte a frame may start with (-1: none); with
    none, all but the last `keep` bytes (a header's first bytes, still arriving) are dropped.
    A frame still arriving stays in `buffer`."""
    split: Split[T] = Split()
    while buffer:
        start = find_start(buffer)
        if start < 0:
            drop = max(0, len(buffer) - keep)
            split.discarded_bytes += drop
            del buffer[:drop]
            break
        if start:
            split.discarded_bytes += start
            del buffer[:start]
        found = cut(buffer)
        if found is None:
            break
        if isinstance(found, Skip):
            split.discarded_bytes += found.length
            if found.rejected is not None:
                split.rejected.append(found.rejected)
        else:
            split.frames.append(found.frame)
        del buffer[: found.length]
    return split
