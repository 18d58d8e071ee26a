"""When the simulated camera captures, renders and publishes its frames (DESIGN §9).

Frames are captured at their instants on the camera's clock (every `period_s` from the start);
a capture that falls more than a frame behind (an overloaded machine) is skipped and counted,
never queued. Each frame is published `latency_s` after its capture: the hidden camera delay
(exposure to arrival) plus the visual latency (arrival to the bus). Its
pixels are rendered from the snapshot taken at capture, half a frame before the frame is due
on the bus rather than at capture: with a visual latency that is not a whole number of frames,
rendering at capture would put the renderer's work on a core while the loop works on the frame
published just before. For the same reason the renderer's thread runs at a lower priority
(`lower_render_priority`): the simulated world is a test harness, and on a real rig the loop has
the machine to itself.

The schedule holds what it is given (a scene to render, a frame to publish) and hands each back
when it falls due on its clock; it renders and publishes nothing itself.
"""

from __future__ import annotations

import os
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Generic, TypeVar

RENDER_NICENESS = 10  # added to the renderer thread's nice value (lower priority than the loop's)

Scene = TypeVar("Scene")
Frame = TypeVar("Frame")


class CameraSchedule(Generic[Scene, Frame]):
    """Capture instants from `start_s` every `period_s`; scenes due for rendering and frames due
    for publishing on `clock` (monotonic seconds)."""

    def __init__(
        self,
        period_s: float,
        latency_s: float,
        start_s: float,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.period_s = period_s
        self.latency_s = latency_s
        self.clock = clock
        self.next_capture_s = start_s
        self.render_lead_s = min(latency_s, 0.5 * period_s)  # rendered this long before due
        self.skipped = 0
        self._scenes: deque[tuple[float, Scene]] = deque()  # (render at, scene)
        self._frames: deque[tuple[float, Frame]] = deque()  # (publish at, frame)

    def captures_due(self, now_s: float) -> list[float]:
        """The capture instants up to `now_s` not yet taken; those more than a frame behind are
        skipped and counted."""
        if now_s - self.next_capture_s > self.period_s:  # fell behind: skip, never queue
            missed = int((now_s - self.next_capture_s) / self.period_s)
            self.skipped += missed
            self.next_capture_s += missed * self.period_s
        due = []
        while now_s >= self.next_capture_s:
            due.append(self.next_capture_s)
            self.next_capture_s += self.period_s
        return due

    def captured(self, t_s: float, scene: Scene) -> None:
        """The snapshot captured at `t_s`, to render `render_lead_s` before it is due."""
        self._scenes.append((t_s + self.latency_s - self.render_lead_s, scene))

    def next_render(self) -> Scene | None:
        """The oldest scene whose time to render has come, or None."""
        if self._scenes and self._scenes[0][0] <= self.clock():
            return self._scenes.popleft()[1]
        return None

    def rendered(self, t_s: float, frame: Frame) -> None:
        """The frame captured at `t_s`, to publish once the visual latency has passed."""
        self._frames.append((t_s + self.latency_s, frame))

    def next_publish(self) -> Frame | None:
        """The oldest frame whose visual latency has passed, or None."""
        if self._frames and self._frames[0][0] <= self.clock():
            return self._frames.popleft()[1]
        return None

    def wait_s(self) -> float:
        """Seconds until the next capture, render or publication falls due."""
        wake = [self.next_capture_s]
        wake += [self._scenes[0][0]] if self._scenes else []
        wake += [self._frames[0][0]] if self._frames else []
        return max(0.0, min(wake) - self.clock())


def lower_render_priority(niceness: int = RENDER_NICENESS) -> None:
    """Let the calling thread, the renderer's, yield to the loop's processes. Linux sets the nice
    value per thread, so threads started before keep theirs (the emulated head, which answers
    the servo as part of the loop)."""
    me = threading.get_native_id()
    os.setpriority(os.PRIO_PROCESS, me, os.getpriority(os.PRIO_PROCESS, me) + niceness)
