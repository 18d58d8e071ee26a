"""A minimal gazed process for the supervisor tests: joins the bus, declares liveliness, counts
steps. Its name comes from the supervisor ($GAZED_PROCESS). Behaviour by environment:
FAKE_CRASH=<name> makes that process exit with code 3 as soon as it is up."""

from __future__ import annotations

import os
import sys

from gazed.bus import Bus
from gazed.config import Rig
from services.runtime import HealthReport, Now, main


class FakeService:
    def __init__(self, name: str) -> None:
        self.name = name
        self.steps = 0

    def step(self, now: Now) -> float:
        self.steps += 1
        if os.environ.get("FAKE_CRASH") == self.name:
            sys.exit(3)
        return 0.5

    def health(self) -> HealthReport:
        return HealthReport(counters={"steps": self.steps})

    def close(self) -> None:
        pass


def build(rig: Rig, bus: Bus) -> FakeService:
    return FakeService(bus.process)


if __name__ == "__main__":
    raise SystemExit(main(os.environ.get("GAZED_PROCESS", "fake"), build))
