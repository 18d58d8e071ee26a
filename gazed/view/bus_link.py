"""The view's session on the rig's bus: what it reads into the page's state, and what it publishes
(`gaze/select`, `gaze/command`).

The view is a bus client like `gazed tail` (DESIGN §11): it never sits inside the loop. What a
page shows is subscribed only while a page is open (frames newest-only); every sample is
decoded in zenoh's receive thread and handed to the page's event loop in one coalesced call,
so a busy page never queues samples behind it. Opening
the session is retried until the rig's bus answers (the page is served meanwhile); after that
zenoh reconnects by itself when the rig restarts.
"""

from __future__ import annotations

import asyncio
import logging
from typing import Any

from gazed.backoff import Backoff
from gazed.bus import Bus, BusError, Subscription
from gazed.config import Rig
from gazed.messages import GazeCommand, GazeSelect
from gazed.topics import GAZE_COMMAND, GAZE_SELECT, GAZE_STATE, TOOLS
from gazed.view.frame_feed import FrameFeed
from gazed.view.live_state import LiveState

PROCESS = "view"
# what the view reads and publishes, as `gazed.topics.TOOLS` declares it
CONTRACT = next(tool for tool in TOOLS if tool.name == "gazed view")
KEPT = (GAZE_STATE,)
RETRY_INITIAL_S = 0.5
RETRY_MAX_S = 5.0

log = logging.getLogger("gazed.view")


class ViewLink:
    """The bus session feeding `state` and `feed` in the event loop `loop`."""

    def __init__(
        self, rig: Rig, state: LiveState, feed: FrameFeed, loop: asyncio.AbstractEventLoop
    ) -> None:
        self.bus = Bus(rig, PROCESS)
        self.state = state
        self.feed = feed
        self.loop = loop
        self.connected = False
        self._kept: list[Subscription[Any]] = []
        self._watched: list[Subscription[Any]] = []
        self._select: Any = None
        self._command: Any = None
        self._scheduled = False
        self._watching = False

    async def connect(self) -> None:
        """Open the session, retrying with a backoff until the rig's bus answers."""
        backoff = Backoff(RETRY_INITIAL_S, RETRY_MAX_S)
        failures = 0
        while True:
            try:
                await asyncio.to_thread(self.bus.open)
                break
            except BusError as exc:
                if failures == 0:
                    log.warning("no bus yet, trying until it answers: %s", str(exc)[:200])
                failures += 1
                await asyncio.sleep(backoff.next_delay_s())
        if failures:
            log.info("on the rig's bus")
        self.bus.on_arrival(self._arrived)
        # kept always: the gaze's transitions are rare, and a page that opens shows the last
        self._kept = [self.bus.subscribe(topic) for topic in CONTRACT.reads if topic in KEPT]
        self._select = self.bus.publisher(GAZE_SELECT)
        self._command = self.bus.publisher(GAZE_COMMAND)
        self.bus.declare_alive()
        self.connected = True
        self.watch(self._watching)

    def watch(self, on: bool) -> None:
        """Subscribe the frames and the streams while a page is open, and only then: without
        a page the view takes nothing off the bus but the gaze's transitions."""
        self._watching = on
        if not self.connected:
            return  # `connect` subscribes them if a page is open by then
        if on and not self._watched:
            self._watched = [
                self.bus.subscribe(topic) for topic in CONTRACT.reads if topic not in KEPT
            ]
        elif not on and self._watched:
            for subscription in self._watched:
                subscription.close()
                subscription.take()  # let go of what it held (a frame)
            self._watched = []

    def publish_select(self, selection: GazeSelect) -> None:
        if self._select is None:
            raise BusError("the view is not on the bus yet")
        self._select.put(selection)

    def publish_command(self, command: GazeCommand) -> None:
        if self._command is None:
            raise BusError("the view is not on the bus yet")
        self._command.put(command)

    def close(self) -> None:
        self.bus.close()

    def _arrived(self) -> None:
        """From zenoh's receive thread: drain in the event loop, once per burst of samples."""
        if not self._scheduled:
            self._scheduled = True
            self.loop.call_soon_threadsafe(self.drain)

    def drain(self) -> None:
        """Hand what arrived to the page's state and the frame feed (in the event loop)."""
        self._scheduled = False
        for subscription in (*self._kept, *self._watched):
            if subscription.topic.frames:
                if (frame := subscription.latest()) is not None:
                    self.feed.offer(frame)
            else:
                for message in subscription.take():
                    self.state.take(message)
