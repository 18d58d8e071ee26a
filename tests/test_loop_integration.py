"""The product, end to end: `gazed run` on the simulated rig acquires the target, holds it in
the fovea, and on SIGTERM parks the head and leaves no process behind; `gazed eval loop`
stopped by SIGTERM stops the rig it started."""

from __future__ import annotations

import contextlib
import math
import signal
import subprocess
import time
from pathlib import Path

import psutil
import pytest
from conftest import PYTHON, REPO, RunningSupervisor, child_env, pid_alive, poll_until

from gazed.eval.loop_metrics import LoopRecord, score
from gazed.eval.private_rig import private_rig
from gazed.geometry.pose import CameraPose
from gazed.topics import ESTIMATOR_STATE, GAZE_STATE, SERVO_COMMAND, SIM_TRUTH

pytestmark = pytest.mark.e2e

RUN_S = 12.0


def test_sim_rig_tracks_and_stops_parked(tmp_path: Path) -> None:
    rig_path = private_rig(REPO / "configs" / "sim.toml", tmp_path, "oval", None, None, 3, None)
    supervisor = RunningSupervisor(rig_path, tmp_path)
    rig = supervisor.rig
    bus = supervisor.bus
    truth = bus.subscribe(SIM_TRUTH, capacity=100000)
    states = bus.subscribe(GAZE_STATE, capacity=1000)
    commands = bus.subscribe(SERVO_COMMAND, capacity=100000)
    estimates = bus.subscribe(ESTIMATOR_STATE, capacity=100000)
    record = LoopRecord([], [], [], [])
    try:
        supervisor.wait_ready(60.0)
        pids = supervisor.pids()
        assert set(pids) == {"sim", "servo", "vision", "estimator", "gaze"}
        started = time.monotonic()
        while time.monotonic() - started < RUN_S:  # record what the loop publishes
            supervisor.wakeup.wait(0.5)
            record.truth.extend(truth.take())
            record.states.extend(states.take())
            record.commands.extend(commands.take())
            record.estimates.extend(estimates.take())
        result = score(record, CameraPose.from_rig(rig), rig.gaze.fovea_half_angle_deg)
        print(result)
        assert result["acquired_after_s"] is not None and result["acquired_after_s"] < 6.0
        assert result["fovea_fraction"] >= 0.8
        assert any(s.state == "pursuit" for s in record.states)
        assert result["ground_rmse_m"] is not None and result["ground_rmse_m"] < 0.5
        parked_from = len(record.truth)
        supervisor.process.send_signal(signal.SIGTERM)
        # the servo parks the head on SIGTERM before the simulator (stopped last) goes away
        poll_until(
            lambda: record.truth.extend(truth.take()) or supervisor.process.poll() is not None, 30.0
        )
        assert supervisor.process.returncode == 0
    finally:
        code = supervisor.stop()
    assert code == 0
    last = record.truth[-1].head
    park_pan, park_tilt = rig.head.park_rad
    assert len(record.truth) > parked_from
    assert (
        math.degrees(abs(last.pan_rad - park_pan)) < 0.5
        and math.degrees(abs(last.tilt_rad - park_tilt)) < 0.5
    )
    assert [name for name, pid in pids.items() if pid_alive(pid)] == []


def test_eval_loop_stopped_by_sigterm_stops_its_rig() -> None:
    evaluation = subprocess.Popen(
        [
            PYTHON,
            "-m",
            "gazed.cli",
            "eval",
            "loop",
            "--rig",
            str(REPO / "configs" / "sim.toml"),
            "--scenario",
            "oval",
            "--seconds",
            "120",
            "--json",
        ],
        cwd=REPO,
        env=child_env(),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    family: list[psutil.Process] = []
    try:
        parent = psutil.Process(evaluation.pid)
        # the supervisor and its five processes
        poll_until(lambda: len(parent.children(recursive=True)) >= 6, 60.0)
        family = parent.children(recursive=True)
        evaluation.send_signal(signal.SIGTERM)
        assert evaluation.wait(timeout=40) == 128 + signal.SIGTERM
        poll_until(lambda: not any(pid_alive(p.pid) for p in family), 10.0)
    finally:
        if evaluation.poll() is None:
            evaluation.kill()
            evaluation.wait()
        for process in family:  # what a failure left behind
            with contextlib.suppress(psutil.NoSuchProcess):
                process.kill()
