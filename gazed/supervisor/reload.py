"""Which processes a reloaded rig restarts: those whose `[services]` entry changed, or one of the
sections `gazed.topics.PROCESSES` declares they read ([rig] and [bus] cannot change on a
reload)."""

from __future__ import annotations

from gazed.config import Rig
from gazed.topics import PROCESSES


def processes_to_restart(old: Rig, new: Rig) -> list[str]:
    """Names of the rig's processes, in start order, that `new` changes."""
    return [
        p.name
        for p in PROCESSES
        if old.services.spec(p.name) != new.services.spec(p.name)
        or any(getattr(old, section) != getattr(new, section) for section in p.sections)
    ]
