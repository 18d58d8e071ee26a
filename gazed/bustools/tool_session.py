"""A tool's session on a running rig (`gazed select`, `operate`, `calibrate trace`, calibrations
that drive the head): the bus, woken by every arrival, or a clear error when no rig runs."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

from gazed.bus import Bus, BusError
from gazed.config import Rig
from gazed.wakeup import Wakeup


class NoRunningRig(BusError):
    """No bus answers for the rig: `gazed run` is not running it, or not where the rig says."""


@contextlib.contextmanager
def tool_session(rig: Rig, name: str) -> Iterator[tuple[Bus, Wakeup]]:
    """The rig's bus as tool `name` for the `with` block, and a wake-up that every sample
    notifies. NoRunningRig when the bus does not answer."""
    bus = Bus(rig, name)
    try:
        bus.open()
    except BusError as exc:
        raise NoRunningRig(
            f"no bus answers for rig '{rig.name}': {exc} (is `gazed run` running?)"
        ) from exc
    try:
        with Wakeup() as wakeup:
            bus.on_arrival(wakeup.notify)
            yield bus, wakeup
    finally:
        bus.close()
