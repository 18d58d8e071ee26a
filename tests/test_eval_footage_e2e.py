"""`gazed eval loop --truth` end to end: the PETS rig runs over its footage, the operator's
choice of a person goes out at their first frame, and the person is scored and acquired."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import REPO, SHARED_DATA, child_env

from gazed.config import load_rig

pytestmark = pytest.mark.e2e

PETS = REPO / "configs" / "pets.toml"
TRUTH = SHARED_DATA / "footage" / "pets09-s2l1" / "truth_frames_0000-0399.csv"
PERSON = 15  # in view from the footage's first frame, near the wide camera's axis
KEYS = {
    "id",
    "visible_frames",
    "acquired_after_s",
    "fovea_fraction",
    "switches",
    "gaze_error_deg",
    "ground_rmse_m",
}


def test_a_selected_person_is_scored_and_acquired() -> None:
    source = load_rig(PETS).wide_source
    if source is None or not Path(source).is_file() or not TRUTH.is_file():
        pytest.skip(f"the PETS footage ({source}) or its truth ({TRUTH}) is absent")
    command = ["eval", "loop", "--rig", str(PETS), "--truth", str(TRUTH), "--json"]
    run = subprocess.run(
        [
            sys.executable,
            "-m",
            "gazed.cli",
            *command,
            "--select-id",
            str(PERSON),
            "--seconds",
            "10",
        ],
        capture_output=True,
        text=True,
        timeout=180,
        env=child_env(),
        cwd=REPO,
    )
    assert run.returncode == 0, run.stderr
    result = json.loads(run.stdout)
    person = result["person"]
    assert set(person) == KEYS and person["id"] == PERSON
    assert person["visible_frames"] > 30 and person["acquired_after_s"] is not None
    assert set(person["gaze_error_deg"]) == {"rms", "p95"}
    assert result["selected_frame"] is not None and result["frames"] > 30
    assert set(result["person_reach"]) == {"out_of_reach_fraction", "fovea_fraction_reachable"}
