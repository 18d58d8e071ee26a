"""`gazed calibrate tsai`: the PETS calibration as a rig's wide camera and ground homography,
checked against the footage's truth through gazed's own geometry."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gazed import cli
from gazed.config import load_rig
from gazed.eval.truth import read_truth
from gazed.geometry.ground import GroundGeometry
from gazed.geometry.homography import GroundHomography
from gazed.geometry.kinematics import HeadKinematics
from gazed.vision.digital_camera import wide_camera

RIG = """# a rig's own comment, kept
[rig]
name = "tsai"
[calibration]
target_height_m = 0.0
"""


def test_tsai_output_puts_the_truths_feet_on_their_ground_positions(
    shared_data: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    footage = shared_data / "footage" / "pets09-s2l1"
    rig_path = tmp_path / "rig.toml"
    rig_path.write_text(RIG)
    args = ["calibrate", "tsai", str(footage / "View_001.xml"), "--size", "480x360"]
    assert cli.main([*args, "--write", str(rig_path)]) == 0
    printed = capsys.readouterr().out
    assert "distortion fit max" in printed and "[wide]" in printed
    assert "# a rig's own comment, kept" in rig_path.read_text()
    rig = load_rig(rig_path)
    geometry = GroundGeometry(
        wide_camera(rig.wide),
        HeadKinematics.from_section(rig.head),
        GroundHomography.from_section(rig.calibration),
    )
    errors_m = [
        np.hypot(*(geometry.ground_from_gaze(0.0, 0.0, u, v) - ground))
        for person in read_truth(footage / "truth_frames_0000-0399.csv").values()
        for (u, v), ground in zip(person.foot_px, person.ground_m, strict=True)
    ]
    assert len(errors_m) > 1000
    assert np.max(errors_m) < 0.05
    assert rig.calibration.camera_xyz_m is not None and 5.0 < rig.calibration.camera_xyz_m[2] < 10


def test_tsai_refuses_a_bad_size_and_a_missing_file(tmp_path: Path) -> None:
    absent = str(tmp_path / "absent.xml")
    assert cli.main(["calibrate", "tsai", absent, "--size", "480x360"]) == 2
    assert cli.main(["calibrate", "tsai", absent, "--size", "480"]) == 2
