"""Waking a loop that sleeps until there is news: a sample on the bus, a signal, a deadline that
moved earlier.

A loop (a process's `ServiceLoop`, the supervisor, a tool waiting for replies) blocks in
`wait(timeout_s)`; `bus.on_arrival(wakeup.notify)` has every sample wake it. The wake-ups go
through a pipe, not a `threading.Event`: `notify()` is then safe from zenoh's threads and from
signal handlers alike (an Event's lock taken in a handler can deadlock the very thread that
waits on it).
"""

from __future__ import annotations

import contextlib
import os
import select


class Wakeup:
    """A self-pipe: `notify()` and `reschedule()` from anywhere, `wait()` in the loop; use as a
    context manager (or `close()`)."""

    def __init__(self) -> None:
        self._read, self._write = os.pipe()
        os.set_blocking(self._read, False)
        os.set_blocking(self._write, False)
        self.wakeups = 0  # `notify()` calls: news for the loop (`reschedule()` is not)

    def __enter__(self) -> Wakeup:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    def notify(self) -> None:
        """Wake `wait()` with news (counted in `wakeups`); safe from any thread and from a
        signal handler."""
        self.wakeups += 1
        self.reschedule()

    def reschedule(self) -> None:
        """Wake `wait()` without news: its caller's deadline moved earlier."""
        # full: a wake-up is pending anyway; closed: no one waits
        with contextlib.suppress(OSError):
            os.write(self._write, b"\0")

    def wait(self, timeout_s: float) -> bool:
        """Block until `notify()` or `reschedule()` (True), at most `timeout_s` (False)."""
        if self._read < 0:
            raise ValueError("wait() on a closed Wakeup")
        ready, _, _ = select.select([self._read], [], [], max(0.0, timeout_s))
        if not ready:
            return False
        with contextlib.suppress(BlockingIOError):
            while os.read(self._read, 4096):
                pass
        return True

    def close(self) -> None:
        for fd in (self._read, self._write):
            if fd >= 0:
                os.close(fd)
        self._read, self._write = -1, -1
