"""Host -> emulator -> host over a real pty, for every protocol: the production driver sends
positions across the full range and the sign boundaries, and reads them back within the
protocol's resolution; velocities arrive as the protocol quantises them; the emulator's true
pose is what the head reports."""

from __future__ import annotations

import math
import subprocess
import time
from pathlib import Path

import pytest
from conftest import PYTHON, REPO, child_env, poll_until

from gazed.config import parse_rig
from gazed.servo import make_codec
from gazed.servo.driver import ServoDriver
from gazed.servo.transport import SerialTransport
from gazed.sim.head_emulator import EmulatorError, HeadEmulator

PROTOCOLS = {
    "pelco-d": "",
    "visca": "pan_deg_per_unit = 0.0694\npan_speed_max_deg_s = 1200\ntilt_speed_max_deg_s = 1200",
    "flir-ptu": "pan_arcsec_per_position = 92.5714\ntilt_arcsec_per_position = 46.2857",
    "dynamixel": "",
}
# pan, tilt in degrees: the ends of the range (the head's limits are a degree beyond, so that no
# rounding to the protocol's unit meets the hard stop), both sides of zero, odd fractions
ANGLES_DEG = [
    (-170.0, -90.0),
    (170.0, 30.0),
    (-0.01, -0.01),
    (0.0, 0.0),
    (0.004, 0.006),
    (0.01, 0.01),
    (-89.99, -45.67),
    (123.45, 29.99),
]


def rig_for(protocol: str, port: Path):
    text = f"""
[rig]
name = "roundtrip"
[servo]
protocol = "{protocol}"
port = "{port}"
baud = 115200
timeout_ms = 500
{PROTOCOLS[protocol]}
[head]
pan_min_deg = -171
pan_max_deg = 171
tilt_min_deg = -91
tilt_max_deg = 31
pan_rate_max_deg_s = 3600
tilt_rate_max_deg_s = 3600
pan_accel_max_deg_s2 = 1000000
tilt_accel_max_deg_s2 = 1000000
[sim]
head_latency_ms = 0
"""
    return parse_rig(text)


@pytest.fixture(params=list(PROTOCOLS))
def head(request, tmp_path: Path):
    rig = rig_for(request.param, tmp_path / "head")
    with HeadEmulator(rig) as emulator:
        codec = make_codec(rig.servo.protocol, **rig.servo_params())
        driver = ServoDriver(codec, SerialTransport(rig.servo.port, rig.servo.baud), 0.5)
        with driver:
            yield rig, emulator, driver


def test_positions_round_trip_across_the_range(head) -> None:
    _rig, emulator, driver = head
    pan_unit, tilt_unit = driver.codec.resolution_rad
    for pan_deg, tilt_deg in ANGLES_DEG:
        pan, tilt = math.radians(pan_deg), math.radians(tilt_deg)
        driver.set_position(pan, tilt)

        def reached(pan=pan, tilt=tilt):
            where = driver.query_position()
            ok = abs(where.pan_rad - pan) <= pan_unit / 2 + 1e-9
            return ok and abs(where.tilt_rad - tilt) <= tilt_unit / 2 + 1e-9

        def still():
            axes = emulator.device_pose_at(time.monotonic())
            return axes.pan_rate_rad_s == axes.tilt_rate_rad_s == 0.0

        poll_until(lambda: reached() and still(), timeout_s=5.0)  # not passing through it
        where = driver.query_position()
        # what the head reports is where its axes truly are, to the protocol's unit
        true = emulator.device_pose_at(time.monotonic())
        assert abs(true.pan_rad - where.pan_rad) <= pan_unit / 2 + 1e-9
        assert abs(true.tilt_rad - where.tilt_rad) <= tilt_unit / 2 + 1e-9
    assert emulator.mechanics.pan.clamps == emulator.mechanics.tilt.clamps == 0
    assert driver.counters["timeouts"] == 0


def quantised_rate_deg_s(protocol: str, rate_deg_s: float) -> float:
    """The rate the protocol can express nearest to `rate_deg_s` (PROTOCOLS.md units)."""
    if protocol == "pelco-d":
        return round(rate_deg_s / 120.0 * 0x3F) / 0x3F * 120.0
    if protocol == "visca":
        return round(rate_deg_s / 1200.0 * 0x18) / 0x18 * 1200.0
    if protocol == "flir-ptu":
        return round(rate_deg_s * 3600 / 92.5714) * 92.5714 / 3600
    return round(rate_deg_s / 6.0 / 0.229) * 0.229 * 6.0  # rev/min units of 0.229


def test_velocity_then_stop(head) -> None:
    rig, emulator, driver = head
    driver.set_velocity(math.radians(-50.0), 0.0)
    expected = -quantised_rate_deg_s(rig.servo.protocol, 50.0)
    poll_until(
        lambda: math.isclose(
            math.degrees(emulator.mechanics.pan.velocity_rad_s), expected, abs_tol=1e-6
        ),
        timeout_s=5.0,
    )
    poll_until(lambda: emulator.mechanics.pan.position_rad < math.radians(-1.0), timeout_s=5.0)
    driver.stop()
    poll_until(lambda: emulator.settled, timeout_s=5.0)
    where = driver.query_position()
    assert where.pan_rad < math.radians(-1.0)  # it moved left, then stopped where it was
    assert where.pan_rad == pytest.approx(emulator.mechanics.pan.position_rad, abs=0.002)
    assert emulator.mechanics.pan.velocity_rad_s == 0.0


def test_the_emulator_refuses_to_replace_a_real_file(tmp_path: Path) -> None:
    port = tmp_path / "ttyUSB0"
    port.write_text("not a symlink")
    with pytest.raises(EmulatorError, match="not a symlink"):
        HeadEmulator(rig_for("pelco-d", port)).open()
    with pytest.raises(EmulatorError, match="URL"):
        HeadEmulator(rig_for("pelco-d", tmp_path), link="socket://localhost:1")


def test_closing_removes_the_link_and_the_host_sees_the_port_vanish(tmp_path: Path) -> None:
    rig = rig_for("visca", tmp_path / "head")
    emulator = HeadEmulator(rig)
    emulator.open()
    emulator.start()
    driver = ServoDriver(make_codec("visca"), SerialTransport(rig.servo.port, 115200), 0.5)
    driver.connect()
    driver.query_position()
    emulator.close()
    assert not (tmp_path / "head").exists()
    with pytest.raises(ConnectionError):
        driver.query_position()
    driver.disconnect()


@pytest.mark.e2e
def test_the_emulator_runs_alone(tmp_path: Path) -> None:
    rig_path = tmp_path / "rig.toml"
    link = tmp_path / "head"
    rig_path.write_text(
        f'[rig]\nname = "alone"\n[servo]\nprotocol = "flir-ptu"\nport = "{link}"\nbaud = 115200\n'
    )
    emulator = subprocess.Popen(
        [PYTHON, "-m", "gazed.sim.head_emulator", "--rig", str(rig_path)],
        cwd=REPO,
        env=child_env(),
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert "flir-ptu head on /dev/pts/" in emulator.stdout.readline()
        with ServoDriver(make_codec("flir-ptu"), SerialTransport(str(link), 115200), 1.0) as driver:
            assert driver.query_position().pan_rad == 0.0
    finally:
        emulator.terminate()
        assert emulator.wait(10) == 0
    assert not link.exists()
