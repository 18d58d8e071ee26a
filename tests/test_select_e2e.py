"""`gazed select` on the running sim rig: the operator's choice of track reaches the gaze, whose
gaze/state names it; an unknown id is refused; `--rule` hands the choice back to the rule.

The rig's rule zone lies far from the simulated walker, so the rule picks nothing and only the
operator's choice sets the target."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest
import tomlkit
from conftest import PYTHON, REPO, RunningSupervisor, child_env, poll_until

from gazed.eval.private_rig import private_rig
from gazed.messages import EstimatorState, GazeState, Track
from gazed.topics import ESTIMATOR_STATE, GAZE_STATE

pytestmark = pytest.mark.e2e


def select(rig_path: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [PYTHON, "-m", "gazed.cli", "select", "--rig", str(rig_path), *args],
        env=child_env(),
        capture_output=True,
        text=True,
        timeout=60,
    )


def test_gazed_select_sets_the_target_of_gaze_state(tmp_path: Path) -> None:
    rig_path = private_rig(REPO / "configs" / "sim.toml", tmp_path, "oval", None, None, 3, None)
    document = tomlkit.parse(rig_path.read_text())
    document.setdefault("gaze", tomlkit.table())["select_zone_xy_m"] = [
        [100.0, 100.0],
        [101.0, 100.0],
        [101.0, 101.0],
    ]
    rig_path.write_text(tomlkit.dumps(document))
    supervisor = RunningSupervisor(rig_path, tmp_path)
    try:
        estimates = supervisor.bus.subscribe(ESTIMATOR_STATE, capacity=1000)
        states = supervisor.bus.subscribe(GAZE_STATE, capacity=1000)
        seen: list[GazeState] = []

        def confirmed_track() -> Track | None:
            latest: EstimatorState | None = estimates.latest()
            tracks = [t for t in latest.tracks if t.confirmed] if latest is not None else []
            return tracks[0] if tracks else None

        track_id = poll_until(confirmed_track, 60.0, 0.05).id
        seen += states.take()
        assert all(s.target_id is None for s in seen)  # outside the zone: the rule picks none

        chosen = select(rig_path, "--track", str(track_id))
        assert chosen.returncode == 0, chosen.stderr
        assert f"target {track_id}: operator chose track {track_id} by id" in chosen.stdout

        def answered() -> GazeState | None:
            seen.extend(states.take())
            return next((s for s in seen if s.target_id == track_id), None)

        answer = poll_until(answered, 10.0, 0.05)
        assert answer.reason.startswith("operator") and answer.state == answer.previous

        refused = select(rig_path, "--track", "99999")
        assert refused.returncode == 1
        assert "no track 99999; target unchanged" in refused.stdout

        back = select(rig_path, "--rule")
        assert back.returncode == 0, back.stderr
        assert back.stdout.startswith("target None: operator: back to rule first")
    finally:
        assert supervisor.stop() == 0
