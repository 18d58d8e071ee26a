"""`gazed operate` on the running sim rig: hold keeps the head still, park sends it to the park
pose, resume follows again; each answered by the gaze on gaze/state with the operator as the
reason, and carried out in the demands written to the head."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest
from conftest import PYTHON, REPO, RunningSupervisor, child_env, poll_until

from gazed.bus import Subscription
from gazed.eval.private_rig import private_rig
from gazed.messages import GazeDemand, GazeState
from gazed.topics import GAZE_DEMAND, GAZE_STATE, SERVO_COMMAND

pytestmark = pytest.mark.e2e


def operate(rig_path: Path, command: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [PYTHON, "-m", "gazed.cli", "operate", "--rig", str(rig_path), command],
        env=child_env(),
        capture_output=True,
        text=True,
        timeout=60,
    )


def collect(subscription: Subscription[GazeDemand], count: int) -> list[GazeDemand]:
    """The next `count` demands on `subscription`."""
    got: list[GazeDemand] = []
    poll_until(lambda: got.extend(subscription.take()) or len(got) >= count, 10.0, 0.05)
    return got


def test_hold_park_and_resume_reach_the_gaze_and_the_head(tmp_path: Path) -> None:
    rig_path = private_rig(REPO / "configs" / "sim.toml", tmp_path, "oval", None, None, 2, None)
    supervisor = RunningSupervisor(rig_path, tmp_path)
    try:
        states = supervisor.bus.subscribe(GAZE_STATE, capacity=1000)
        demands = supervisor.bus.subscribe(GAZE_DEMAND, capacity=1000)
        written = supervisor.bus.subscribe(SERVO_COMMAND, capacity=1000)
        seen: list[GazeState] = []

        def reached(state: str) -> bool:
            seen.extend(states.take())
            return any(s.state == state for s in seen)

        poll_until(lambda: reached("pursuit"), 60.0, 0.05)

        held = operate(rig_path, "hold")
        assert held.returncode == 0, held.stderr
        assert held.stdout.strip().endswith("-> hold: operator: hold")
        demands.take()
        written.take()
        held_demands = collect(demands, 10)
        assert {d.kind for d in held_demands} == {"hold"}
        assert len({(d.pan_rad, d.tilt_rad) for d in held_demands}) == 1  # still, where it was
        assert {d.kind for d in collect(written, 10)} == {"hold"}  # as written to the head

        parked = operate(rig_path, "park")
        assert parked.returncode == 0, parked.stderr
        assert parked.stdout.strip() == "hold -> park: operator: park"
        demands.take()
        written.take()
        park = supervisor.rig.head.park_rad
        for demand in collect(demands, 10):
            assert demand.kind == "park"
            assert (demand.pan_rad, demand.tilt_rad) == pytest.approx(park)
        assert {d.kind for d in collect(written, 10)} == {"park"}

        resumed = operate(rig_path, "resume")
        assert resumed.returncode == 0, resumed.stderr
        assert resumed.stdout.strip() == "park -> search: operator: resume"
        seen.clear()
        poll_until(lambda: reached("pursuit"), 60.0, 0.05)  # following again
    finally:
        assert supervisor.stop() == 0


def test_without_a_running_rig_it_says_so(tmp_path: Path) -> None:
    rig_path = private_rig(REPO / "configs" / "sim.toml", tmp_path, "oval", None, None, 2, None)
    result = subprocess.run(
        [PYTHON, "-m", "gazed.cli", "operate", "--rig", str(rig_path), "--timeout-s", "1", "park"],
        env=child_env(),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 1
    assert "gazed operate:" in result.stderr
