"""The newest frame for the page's clients, encoded to JPEG once, only when someone asks.

The bus hands over frames (newest only: the view's subscription keeps one); each client waits
for a frame newer than the one it was last sent (`newer_than`) and gets its JPEG (`jpeg`). A
client that is slow skips frames; nobody waits for it. Frames are counted on arrival, not by
their sequence number, which starts again when the rig restarts.
"""

from __future__ import annotations

import asyncio
from dataclasses import dataclass

from gazed.bus import Frame
from gazed.record.frame_image import jpeg_bytes


@dataclass(frozen=True)
class FeedFrame:
    """A frame as the feed holds it: its arrival number and the frame."""

    number: int
    frame: Frame


class FrameFeed:
    """The newest frame and the clients waiting for one; used from one event loop."""

    def __init__(self, jpeg_quality: int) -> None:
        self.jpeg_quality = jpeg_quality
        self.newest: FeedFrame | None = None
        self.encoded = 0
        self._jpeg: tuple[int, bytes] | None = None
        self._waiters: list[asyncio.Future[None]] = []

    def offer(self, frame: Frame) -> None:
        """A new frame: keep it and wake the clients waiting for one."""
        number = self.newest.number + 1 if self.newest is not None else 1
        self.newest = FeedFrame(number, frame)
        waiters, self._waiters = self._waiters, []
        for waiter in waiters:
            if not waiter.done():
                waiter.set_result(None)

    async def newer_than(self, number: int) -> FeedFrame:
        """The newest frame once its arrival number is above `number`."""
        while self.newest is None or self.newest.number <= number:
            waiter = asyncio.get_running_loop().create_future()
            self._waiters.append(waiter)
            await waiter
        return self.newest

    async def jpeg(self, item: FeedFrame) -> bytes:
        """The frame as JPEG, encoded in a worker thread the first time anyone asks for it."""
        if self._jpeg is None or self._jpeg[0] != item.number:
            header, pixels = item.frame.header, item.frame.pixels
            data = await asyncio.to_thread(jpeg_bytes, header, pixels, self.jpeg_quality)
            self.encoded += 1
            if self._jpeg is None or self._jpeg[0] < item.number:
                self._jpeg = (item.number, data)
            return data
        return self._jpeg[1]
