"""The one contract: every process of the running sim rig subscribes and publishes exactly what
`gazed.topics.PROCESSES` declares for it. Each reports the keys its bus session declared in its
health, so a key added to a service but not to topics.py fails here."""

from __future__ import annotations

from pathlib import Path

import pytest
import tomlkit
from conftest import REPO, RunningSupervisor, poll_until

from gazed.eval.private_rig import private_rig
from gazed.messages import Health
from gazed.topics import PROCESSES, health

pytestmark = pytest.mark.e2e


def test_every_process_subscribes_and_publishes_what_topics_declares(tmp_path: Path) -> None:
    rig_path = private_rig(REPO / "configs" / "sim.toml", tmp_path, "oval", None, None, 1, None)
    document = tomlkit.parse(rig_path.read_text())
    # vision declares its candidates' publisher only when candidates are on (the default)
    document.setdefault("vision", tomlkit.table())["candidates"] = True
    rig_path.write_text(tomlkit.dumps(document))
    supervisor = RunningSupervisor(rig_path, tmp_path)
    try:
        subscriptions = {p.name: supervisor.bus.subscribe(health(p.name)) for p in PROCESSES}
        reported: dict[str, Health] = {}

        def all_reported() -> bool:
            for name, subscription in subscriptions.items():
                if (latest := subscription.latest()) is not None:
                    reported[name] = latest
            return len(reported) == len(PROCESSES)

        poll_until(all_reported, 60.0, 0.1)
    finally:
        assert supervisor.stop() == 0
    for process in PROCESSES:
        report = reported[process.name]
        assert sorted(report.subscribes) == sorted(t.suffix for t in process.reads), process.name
        declared = {t.suffix for t in process.publishes} | {f"{process.name}/health"}
        assert sorted(report.publishes) == sorted(declared), process.name
