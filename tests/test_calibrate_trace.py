"""`gazed calibrate trace` on the simulated rig: the gaze process traces the court's sides and the
line calibration's homography agrees with the true one to within 5 cm over the calibrated area."""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path

import pytest
from conftest import PYTHON, REPO, RunningSupervisor, child_env

from gazed.eval.private_rig import private_rig
from gazed.gaze.trace_cli import read_trace_file
from gazed.geometry.calibration_file import CalibrationFileError

TRACE_FILE = REPO / "configs" / "calibration" / "sim_trace.toml"


@pytest.mark.e2e
@pytest.mark.slow
def test_trace_calibrates_the_simulated_rig(tmp_path: Path) -> None:
    rig_path = private_rig(REPO / "configs" / "sim.toml", tmp_path, "oval", None, None, 2, None)
    supervisor = RunningSupervisor(rig_path, tmp_path)
    try:
        supervisor.wait_ready(60.0)
        result = subprocess.run(
            [
                PYTHON,
                "-m",
                "gazed.cli",
                "calibrate",
                "trace",
                "--rig",
                str(rig_path),
                "--lines",
                str(TRACE_FILE),
                "--json",
            ],
            capture_output=True,
            text=True,
            env=child_env(),
            timeout=400,
        )
    finally:
        supervisor.stop()
    assert result.returncode == 0, result.stderr
    fit = json.loads(result.stdout)
    assert fit["n"] == 4
    match = re.search(r"over the calibrated area: max ([0-9.]+) m, rms ([0-9.]+) m", result.stderr)
    assert match, result.stderr
    worst_m, rms_m = float(match[1]), float(match[2])
    print(f"traced homography vs the truth: max {worst_m} m, rms {rms_m} m")
    assert worst_m <= 0.05
    assert all(
        count >= 4 for count in map(int, re.findall(r"  (\d+) samples, ended by", result.stderr))
    )


def test_trace_file_errors_name_the_entry(tmp_path: Path) -> None:
    path = tmp_path / "lines.toml"
    path.write_text("[[line]]\nphi_deg = 0\nd_m = 1\nstart_deg = [1, 2]\n" * 3)
    with pytest.raises(CalibrationFileError, match="at least 4"):
        read_trace_file(path)
    path.write_text(
        "[[line]]\nphi_deg = 0\nd_m = 1\nstart_deg = [1, 2]\n" * 3
        + "[[line]]\nphi_deg = 0\nd_m = 1\n"
    )
    with pytest.raises(CalibrationFileError, match="line 4: 'start_deg'"):
        read_trace_file(path)
    assert len(read_trace_file(TRACE_FILE)) == 4
