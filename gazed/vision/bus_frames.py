"""Frames of the simulated rig, from `sim/frame` on the bus (DESIGN §6).

The subscription keeps only the newest frame (older ones are counted as `replaced` in the bus
statistics); frames whose header lies about their size are dropped and counted as malformed by
the bus layer before they get here. The link is `down` when no frame came for `silence_s`.
Each frame gets a `vision.arrival` stamp, the moment the bus delivered it: vision's processing
latency runs from there, the hop before it is the frame's transport.
"""

from __future__ import annotations

import time

from gazed.bus import Bus, Frame, Subscription
from gazed.messages import ARRIVAL_STAGE
from gazed.topics import SIM_FRAME
from gazed.vision.frames import CapturedFrame
from gazed.vision.source import FrameSource, LinkState, SourceStatus


class BusFrameSource(FrameSource):
    description = "sim frames"

    def __init__(self, bus: Bus, silence_s: float) -> None:
        self._bus = bus
        self.silence_s = silence_s
        self._subscription: Subscription[Frame] | None = None
        self._frames = 0
        self._last_s: float | None = None

    @property
    def is_connected(self) -> bool:
        return self._subscription is not None

    def connect(self) -> None:
        if self._subscription is None:
            self._subscription = self._bus.subscribe(SIM_FRAME, immediate=True)

    def disconnect(self) -> None:
        subscription, self._subscription = self._subscription, None
        if subscription is not None:
            subscription.close()

    def read(self) -> CapturedFrame | None:
        self._require_connected()
        assert self._subscription is not None
        frame: Frame | None = self._subscription.latest()
        if frame is None:
            return None
        self._frames += 1
        self._last_s = time.monotonic()
        header = frame.header
        stamps = (*header.stamps, (ARRIVAL_STAGE, frame.t_received_ns))
        return CapturedFrame(frame.pixels, header.encoding, header.t_capture_ns, header.seq, stamps)

    def status(self) -> SourceStatus:
        link: LinkState
        error = None
        if self._subscription is None:
            link = "down"
        elif self._last_s is None:
            link = "connecting"
        elif time.monotonic() - self._last_s > self.silence_s:
            link, error = "down", f"no frame from the simulator for over {self.silence_s:g} s"
        else:
            link = "connected"
        return SourceStatus(link, self._frames, 0, error)
