"""The whole simulated loop on configs/sim-zoom.toml: the emulated VISCA camera zooms in from its
widest view until the target's true height in the frame holds the setpoint."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import REPO, RunningSupervisor, poll_until

from gazed.config import load_rig
from gazed.eval.private_rig import private_rig
from gazed.eval.zoom_score import TOLERANCE, zoom_scoring
from gazed.messages import SimTruth
from gazed.topics import SIM_TRUTH

pytestmark = pytest.mark.e2e  # starts the real processes

HELD_FRAMES = 25  # a second in a row within the tolerance of the setpoint


def test_the_zoom_holds_the_targets_height_in_the_frame(tmp_path: Path) -> None:
    rig_path = private_rig(
        REPO / "configs" / "sim-zoom.toml", tmp_path, "oval", None, None, 1, None
    )
    scoring = zoom_scoring(load_rig(rig_path))
    assert scoring is not None
    supervisor = RunningSupervisor(rig_path, tmp_path)
    bus, wakeup = supervisor.bus, supervisor.wakeup
    truths = bus.subscribe(SIM_TRUTH, capacity=10_000)
    seen: list[SimTruth] = []

    def held() -> bool:
        wakeup.wait(0.2)
        seen.extend(truths.take())
        recent = seen[-HELD_FRAMES:]
        if len(recent) < HELD_FRAMES:
            return False
        heights = scoring.heights(recent)
        return bool(np.all(np.abs(heights / scoring.setpoint - 1.0) <= TOLERANCE))

    try:
        supervisor.wait_ready(60.0)
        poll_until(held, 60.0, interval_s=0.0)
    finally:
        supervisor.stop()
    zooms = [t.head.zoom for t in seen[-HELD_FRAMES:]]
    assert all(z is not None and z > 0.1 for z in zooms)  # it zoomed in to hold it
    assert seen[0].head.zoom == 0.0  # from the widest
