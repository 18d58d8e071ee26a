"""The whole simulated loop with a hidden camera delay of 150 ms: the vision process's online
estimate converges on it, and the detections' capture stamps are the frames' exposures to
within a frame period."""

from __future__ import annotations

from pathlib import Path

import pytest
import tomlkit
from conftest import REPO, RunningSupervisor, poll_until

from gazed.eval.private_rig import private_rig
from gazed.messages import Detection, Health
from gazed.topics import SIM_TRUTH, VISION_DETECTION, health

pytestmark = pytest.mark.e2e  # starts the real processes

HIDDEN_MS = 150
FRAME_PERIOD_MS = 40.0
SETTLED_FRAMES = 25  # consecutive detections stamped within a frame period of the exposure
HEALTH_TIMEOUT_S = 10.0  # vision's health comes about once a second


def test_the_online_estimate_converges_on_the_hidden_delay(tmp_path: Path) -> None:
    rig_path = private_rig(REPO / "configs" / "sim.toml", tmp_path, "oval", None, None, 1, None)
    document = tomlkit.parse(rig_path.read_text())
    document["sim"]["camera_delay_ms"] = HIDDEN_MS
    document["camera"]["delay_estimate"] = True
    rig_path.write_text(tomlkit.dumps(document))
    supervisor = RunningSupervisor(rig_path, tmp_path)
    bus, wakeup = supervisor.bus, supervisor.wakeup
    detections = bus.subscribe(VISION_DETECTION, capacity=10_000)
    truths = bus.subscribe(SIM_TRUTH, capacity=10_000)
    healths = bus.subscribe(health("vision"), capacity=100)
    exposure_ns: dict[int, int] = {}
    errors_ms: list[float] = []
    notes: list[Health] = []

    def settled() -> bool:
        wakeup.wait(0.2)
        exposure_ns.update({t.seq: t.t_capture_ns for t in truths.take()})
        notes.extend(healths.take())
        detection: Detection
        for detection in detections.take():
            if detection.seq in exposure_ns:
                errors_ms.append((detection.t_capture_ns - exposure_ns[detection.seq]) / 1e6)
        recent = errors_ms[-SETTLED_FRAMES:]
        return len(recent) == SETTLED_FRAMES and max(map(abs, recent)) < FRAME_PERIOD_MS

    def health_after(seen: int) -> Health | None:
        """A health received after the first `seen`: published once the stamps settled, so
        it tells the estimate that settled them (the last one seen then may be vision's
        first, from before any fit)."""
        wakeup.wait(0.2)
        notes.extend(healths.take())
        return notes[-1] if len(notes) > seen else None

    try:
        supervisor.wait_ready(60.0)
        poll_until(settled, 60.0, interval_s=0.0)
        seen = len(notes)
        latest = poll_until(lambda: health_after(seen), HEALTH_TIMEOUT_S, interval_s=0.0)
    finally:
        supervisor.stop()
    assert max(errors_ms) > HIDDEN_MS - 1.0  # stamped on arrival before the first estimate
    assert notes and "online" in latest.notes["camera_delay"]
