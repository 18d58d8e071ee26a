"""`gazed calibrate speeds` against the emulated ONVIF camera on a virtual clock: each step's
rate and the camera's latency from its own readings, inside the joint limits; the command's
refusals."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from onvif_support import PASSWORD, Clock, onvif_rig

from gazed.cli import main
from gazed.servo.onvif_head import OnvifHead
from gazed.servo.speed_calibration import measure_speeds
from gazed.sim.head_onvif import OnvifEmulator


def test_each_steps_rate_is_measured_inside_the_limits(tmp_path: Path) -> None:
    rig, clock = onvif_rig(tmp_path), Clock()
    rig = rig.model_copy(update={"sim": rig.sim.model_copy(update={"head_latency_ms": 45.0})})
    head = rig.head
    poses = []

    def sleep(seconds: float) -> None:
        clock.sleep(seconds)
        pose = camera.pose_at(clock.mono_s)
        poses.append((math.degrees(pose.pan_rad), math.degrees(pose.tilt_rad)))

    with (
        OnvifEmulator(rig, clock=clock.now) as camera,
        OnvifHead(rig.servo, password=PASSWORD, wall_ns=clock.now_ns) as onvif,
    ):
        pan, tilt, latency_ms = measure_speeds(onvif, head, (2, 2), 0.8, 0.04, clock.now, sleep)
    # the emulated camera runs velocity 1 at 120 and 100 deg/s (sim-onvif.toml) and acts on a
    # command [sim] head_latency_ms after it
    assert pan == pytest.approx([60.0, 120.0], rel=0.02)
    assert tilt == pytest.approx([50.0, 100.0], rel=0.02)
    assert latency_ms == pytest.approx(45.0, abs=3.0)
    assert all(head.pan_min_deg <= p <= head.pan_max_deg for p, _ in poses)
    assert all(head.tilt_min_deg <= t <= head.tilt_max_deg for _, t in poses)


def test_the_command_refuses_a_serial_head_and_bad_arguments(capsys) -> None:
    assert main(["calibrate", "speeds", "--rig", "configs/sim.toml"]) == 2
    assert "takes no speed commands" in capsys.readouterr().out
    assert main(["calibrate", "speeds", "--rig", "configs/sim-onvif.toml", "--seconds", "0.1"]) == 2
