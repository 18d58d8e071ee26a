"""`gazed calibrate zoom` on the simulated PTZ camera (configs/sim-zoom.toml, gaze off): the
table it measures against the lens the simulator renders through, within 2 %, and written into
a copy of the rig."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest
import tomlkit
from conftest import PYTHON, REPO, RunningSupervisor, child_env

from gazed.config import load_rig
from gazed.eval.private_rig import private_rig

pytestmark = pytest.mark.e2e  # starts the real processes

RIG = REPO / "configs" / "sim-zoom.toml"
TOLERANCE = 0.02
# the gravel beside the court, near enough that the widest view shows it unhazed
POSE = ("--pan-deg", "-30", "--tilt-deg", "-20")


def test_the_simulated_lens_s_table_is_measured(tmp_path: Path) -> None:
    rig_path = private_rig(RIG, tmp_path, "oval", None, None, 1, None)
    document = tomlkit.parse(rig_path.read_text())
    document["services"]["gaze"] = {"enabled": False}  # the command drives the head
    rig_path.write_text(tomlkit.dumps(document))
    truth = np.array(load_rig(rig_path).camera.zoom_focal_px)
    written = tmp_path / "written.toml"
    written.write_text(rig_path.read_text())
    supervisor = RunningSupervisor(rig_path, tmp_path)
    try:
        supervisor.wait_ready(60.0)
        command = ["calibrate", "zoom", "--rig", str(rig_path), *POSE, "--positions", "9"]
        result = subprocess.run(
            [PYTHON, "-m", "gazed.cli", *command, "--json", "--write", str(written)],
            capture_output=True,
            text=True,
            env=child_env(),
            timeout=240,
        )
    finally:
        supervisor.stop()
    assert result.returncode == 0, result.stderr
    rows = json.loads(result.stdout)
    print("zoom  fx measured  fx true")
    for row in rows:
        true_fx = float(np.interp(row["zoom"], truth[:, 0], truth[:, 1]))
        print(f"{row['zoom']:.4f} {row['fx_px']:9.1f} {true_fx:9.1f}")
        assert row["fx_px"] == pytest.approx(true_fx, rel=TOLERANCE)
        assert (row["cx_px"], row["cy_px"]) == pytest.approx((319.5, 239.5), abs=3.0)
    assert len(rows) == 9 and rows[-1]["zoom"] == pytest.approx(1.0, abs=0.002)
    table = load_rig(written).camera.zoom_focal_px
    assert [r[0] for r in table] == [row["zoom"] for row in rows]
