"""`gazed calibrate latency`: the per-step lag fit on synthetic steps (a known delay found in
every step, too few steps refused), and on the simulated rig with a hidden camera delay of 0 and
150 ms, measured within one frame period."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest
import tomlkit
from conftest import PYTHON, REPO, RunningSupervisor, child_env

from gazed.calibrate.camera_latency import (
    LatencyCalibrationError,
    Recording,
    step_delays_s,
    summary,
)
from gazed.cli import main as cli_main
from gazed.eval.private_rig import private_rig

FRAME_PERIOD_S = 0.04
HOLD_S = 1.0
OPTIONS = ("--steps", "4", "--hold-s", "1.0", "--max-delay-ms", "600", "--json")


def pan_steps(t_s: np.ndarray, starts_s: list[float], step_rad: float) -> np.ndarray:
    """A head that moves smoothly (0.25 s) to each step's pan: there, back, there, ..."""
    pan = np.zeros_like(t_s)
    for k, start_s in enumerate(starts_s):
        goal = step_rad if k % 2 == 0 else 0.0
        before = step_rad if k % 2 == 1 else 0.0
        s = np.clip((t_s - start_s) / 0.25, 0.0, 1.0)
        blend = before + (goal - before) * (3 * s**2 - 2 * s**3)
        pan = np.where(t_s >= start_s, blend, pan)
    return pan


def stepped(delay_s: float, steps: int = 4, jitter_s: float = 0.0) -> Recording:
    starts_s = [100.0 + 1.0 + k * HOLD_S for k in range(steps)]
    exposure = np.arange(100.0, 100.0 + 1.0 + steps * HOLD_S, FRAME_PERIOD_S)
    step_rad = np.radians(8.0)
    du = -550.0 * np.diff(pan_steps(exposure, starts_s, step_rad))
    shifts = np.stack(
        [exposure[:-1] + delay_s, exposure[1:] + delay_s, du, np.zeros_like(du)], axis=1
    )
    t = np.arange(99.0, 100.0 + 2.0 + steps * HOLD_S, 0.02)
    read_s = t + np.random.default_rng(5).uniform(0.0, jitter_s, len(t))  # stamped late
    pan = pan_steps(t, starts_s, step_rad)
    odometry = np.stack([read_s, pan, np.zeros_like(t)], axis=1)
    return Recording(shifts, odometry, starts_s, HOLD_S)


@pytest.mark.parametrize("delay_s", [0.0, 0.15, 0.4])
def test_each_step_finds_the_delay(delay_s: float) -> None:
    delays = step_delays_s(stepped(delay_s), max_delay_s=0.9)
    assert all(d is not None and abs(d - delay_s) < 0.005 for d in delays)
    result = summary(delays)
    assert result["delay_ms"] == pytest.approx(delay_s * 1e3, abs=5.0)
    assert result["steps_fitted"] == 4


def test_late_odometry_stamps_do_not_make_the_moving_frames_outliers() -> None:
    delays = step_delays_s(stepped(0.15, jitter_s=0.012), max_delay_s=0.9)
    assert all(d is not None and abs(d - 0.15) < 0.012 for d in delays)


def test_too_few_steps_with_a_fit_are_refused() -> None:
    with pytest.raises(LatencyCalibrationError, match="only 1 of 3 steps"):
        summary([0.1, None, None])


@pytest.mark.parametrize(
    "options", [["--hold-s", "0.5", "--max-delay-ms", "600"], ["--steps", "1"]]
)
def test_bad_options_exit_2_before_the_bus(options: list[str]) -> None:
    rig = str(REPO / "configs" / "sim.toml")
    assert cli_main(["calibrate", "latency", "--rig", rig, *options]) == 2


@pytest.mark.e2e
@pytest.mark.parametrize("hidden_ms", [0, 150])
def test_the_simulated_rig_s_hidden_delay_is_measured(tmp_path: Path, hidden_ms: int) -> None:
    rig_path = private_rig(REPO / "configs" / "sim.toml", tmp_path, "oval", None, None, 1, None)
    document = tomlkit.parse(rig_path.read_text())
    document["sim"]["camera_delay_ms"] = hidden_ms
    document["services"]["gaze"] = {"enabled": False}  # the command drives the head
    rig_path.write_text(tomlkit.dumps(document))
    supervisor = RunningSupervisor(rig_path, tmp_path)
    try:
        supervisor.wait_ready(60.0)
        result = subprocess.run(
            [PYTHON, "-m", "gazed.cli", "calibrate", "latency", "--rig", str(rig_path), *OPTIONS],
            capture_output=True,
            text=True,
            env=child_env(),
            timeout=120,
        )
    finally:
        supervisor.stop()
    assert result.returncode == 0, result.stderr
    measured = json.loads(result.stdout)
    print(f"hidden {hidden_ms} ms: measured {measured}")
    assert abs(measured["delay_ms"] - hidden_ms) < FRAME_PERIOD_S * 1e3
    assert measured["steps_fitted"] >= 3
