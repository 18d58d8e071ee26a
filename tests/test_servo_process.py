"""The real `servo` process (`python -m services.servo --rig RIG`) against the head emulator on a
real pty: commanded angles reached within the protocol's resolution; out-of-limit and NaN
demands clamped or refused, counted, never sent; hold on timeout; link loss reported and
recovered when the pty returns; park on SIGTERM; dead-reckoned odometry where the head cannot
report its position; the head's response lag measured while it pursues; a slow line kept
from being overrun."""

from __future__ import annotations

import json
import math
import subprocess
import time
from pathlib import Path

import pytest
import zenoh
from conftest import poll_until, start_service, unique_rig_name
from servo_link_support import HEAD_SECTION, demand

from gazed.bus import Bus
from gazed.config import load_rig
from gazed.messages import GazeDemand
from gazed.servo import make_codec
from gazed.servo.transport import BITS_PER_BYTE
from gazed.sim.head_emulator import HeadEmulator
from gazed.topics import GAZE_DEMAND, SERVO_COMMAND, SERVO_ODOMETRY, SERVO_STATUS, health
from gazed.wakeup import Wakeup

pytestmark = pytest.mark.e2e  # every test here starts the real processes

PORTS = {"pelco-d": 17511, "visca": 17512, "flir-ptu": 17513, "dynamixel": 17514}
SERVO_KEYS = {
    "pelco-d": "",
    "visca": "pan_speed_max_deg_s = 300\ntilt_speed_max_deg_s = 300",
    "flir-ptu": "pan_arcsec_per_position = 92.5714\ntilt_arcsec_per_position = 46.2857",
    "dynamixel": "",
}


def write_servo_rig(
    tmp_path: Path,
    protocol: str,
    port: int,
    servo_extra: str = "",
    head_latency_ms: float = 5,
    baud: int = 115200,
    odometry_rate_hz: float = 50,
) -> Path:
    name = unique_rig_name("servo")
    path = tmp_path / f"{name}.toml"
    path.write_text(
        f"""
[rig]
name = "{name}"
[bus]
listen = ["tcp/127.0.0.1:{port}"]
[servo]
protocol = "{protocol}"
port = "{tmp_path / "head"}"
baud = {baud}
timeout_ms = 100
command_timeout_ms = 300
odometry_rate_hz = {odometry_rate_hz}
reconnect_max_s = 0.5
{SERVO_KEYS[protocol]}
{servo_extra}
{HEAD_SECTION}[sim]
head_latency_ms = {head_latency_ms}
"""
    )
    return path


class Loop:
    """The test's side of the bus: publishes demands, keeps the newest odometry, status and
    written command."""

    def __init__(self, bus: Bus) -> None:
        self.bus = bus
        self.wakeup = Wakeup()  # its pipe lives as long as the test
        bus.on_arrival(self.wakeup.notify)
        self.demands = bus.publisher(GAZE_DEMAND)
        self._odometry = bus.subscribe(SERVO_ODOMETRY)
        self._status = bus.subscribe(SERVO_STATUS)
        self._commands = bus.subscribe(SERVO_COMMAND)
        self.odometry = None
        self.status = None
        self.command = None
        self.odometry_count = 0

    def update(self) -> Loop:
        for message in self._odometry.take():
            self.odometry = message
            self.odometry_count += 1
        for message in self._status.take():
            self.status = message
        for message in self._commands.take():
            self.command = message
        return self

    def demand(
        self, pan_deg: float, tilt_deg: float, kind: str = "position", pan_rate_deg_s: float = 0.0
    ) -> None:
        self.demands.put(demand(pan_deg, tilt_deg, kind, pan_rate_deg_s))

    def until(self, predicate, timeout_s: float = 10.0, keep_demanding: tuple | None = None):
        """Wait (on bus arrivals) until `predicate(self)`; optionally re-publish a demand as a
        gaze process would, so the servo never times out into holding meanwhile."""

        def check():
            if keep_demanding is not None:
                self.demand(*keep_demanding)
            self.wakeup.wait(0.02)
            return predicate(self.update())

        return poll_until(check, timeout_s, interval_s=0.0)


def start_servo(rig_path: Path) -> subprocess.Popen[str]:
    return start_service("servo", rig_path)


def stop(process: subprocess.Popen) -> str:
    process.terminate()
    try:
        out, _ = process.communicate(timeout=10)
    except subprocess.TimeoutExpired:
        process.kill()
        out, _ = process.communicate()
        raise AssertionError(f"servo did not stop on SIGTERM:\n{out}") from None
    assert process.returncode == 0, out
    return out


def near(a_rad: float, b_deg: float, unit_rad: float) -> bool:
    return abs(a_rad - math.radians(b_deg)) <= unit_rad / 2 + 1e-9


@pytest.mark.parametrize("protocol", list(PORTS))
def test_reaches_commanded_angles_and_parks_on_sigterm(tmp_path: Path, protocol: str) -> None:
    rig_path = write_servo_rig(tmp_path, protocol, PORTS[protocol])
    rig = load_rig(rig_path)
    pan_unit, tilt_unit = make_codec(protocol, **rig.servo_params()).resolution_rad
    with Bus(rig, "test", router=True) as bus, HeadEmulator(rig) as head:
        loop = Loop(bus)
        servo = start_servo(rig_path)
        try:
            loop.until(lambda s: s.status is not None and s.status.link == "connected")
            target = (-33.33, 12.345)
            loop.until(
                lambda s: (
                    s.odometry is not None
                    and near(s.odometry.pan_rad, target[0], pan_unit)
                    and near(s.odometry.tilt_rad, target[1], tilt_unit)
                    # at rest there, not passing through it on the way
                    and s.odometry.pan_rate_rad_s == s.odometry.tilt_rate_rad_s == 0.0
                ),
                keep_demanding=target,
            )
            truth = head.pose_at(time.monotonic())
            assert near(truth.pan_rad, target[0], pan_unit)
            assert near(truth.tilt_rad, target[1], tilt_unit)
            # servo/command carries the demand's stamps and the moment its bytes were written
            stamps = loop.command.stamps
            assert [stage for stage, _ in stamps] == ["test", "servo"]
            assert 0 < stamps[1][1] - stamps[0][1] < 2_000_000_000
            assert loop.odometry.dead_reckoned is False
        finally:
            stop(servo)
        poll_until(lambda: head.settled, timeout_s=5.0)
        parked = head.pose_at(time.monotonic())
        assert near(parked.pan_rad, 5.0, pan_unit) and near(parked.tilt_rad, -5.0, tilt_unit)


def nan_demand_payload() -> bytes:
    return (
        json.dumps({"t_capture_ns": 1, "kind": "position", "pan_rad": 0.1, "tilt_rad": 0.0})
        .replace("0.1", "NaN")
        .encode()
    )


def test_limits_refusals_hold_and_link_loss(tmp_path: Path) -> None:
    rig_path = write_servo_rig(tmp_path, "visca", 17515)
    rig = load_rig(rig_path)
    unit = make_codec("visca", **rig.servo_params()).resolution_rad[0]
    with Bus(rig, "test", router=True) as bus:
        head = HeadEmulator(rig)
        head.open()
        head.start()
        loop = Loop(bus)
        servo = start_servo(rig_path)
        try:
            loop.until(lambda s: s.status is not None and s.status.link == "connected")

            # out of the joint limits: clamped one device unit inside them, counted
            loop.until(
                lambda s: s.odometry is not None and s.odometry.pan_rad > math.radians(59),
                keep_demanding=(75.0, 0.0),
            )
            loop.until(lambda s: s.status.clamps >= 1)
            # the demands stopped: once the servo holds and the head is at rest, no set-point
            # is left to write (else the hold's own could land after the count below)
            loop.until(lambda s: s.status.holding, timeout_s=5.0)
            poll_until(lambda: head.settled, timeout_s=5.0)
            assert head.mechanics.pan.target_rad <= math.radians(60.0)
            assert head.mechanics.pan.clamps == 0  # nothing beyond the limit reached the head

            # non-finite: refused at the bus, counted, the head does not move
            commands = head.mechanics.commands
            key = GAZE_DEMAND.key(rig.name)
            encoding = zenoh.Encoding("application/json").with_schema(GazeDemand.schema_id())
            bus.session.put(key, nan_demand_payload(), encoding=encoding)
            loop.until(lambda s: s.status.refused >= 1)
            assert head.mechanics.commands == commands

            # pursuit, then silence: the servo holds instead of following the stale rate
            loop.until(lambda s: not s.status.holding, keep_demanding=(0.0, 0.0, "pursuit", 30.0))
            loop.until(lambda s: s.status.holding, timeout_s=5.0)
            poll_until(lambda: head.settled, timeout_s=5.0)
            held = head.pose_at(time.monotonic()).pan_rad
            assert held < math.radians(20.0)  # 30°/s for the 0.3 s timeout, then braking

            # link loss: the pty goes away, then comes back
            errors = loop.status.errors
            head.close()
            loop.until(lambda s: s.status.link != "connected" and s.status.errors > errors)
            head = HeadEmulator(rig)
            head.open()
            head.start()
            loop.until(lambda s: s.status.link == "connected" and s.status.reconnects == 1)
            count = loop.odometry_count
            loop.until(lambda s: s.odometry_count > count + 5)
            assert abs(loop.odometry.pan_rad - math.radians(5.0)) <= unit  # the new head: parked
        finally:
            stop(servo)
            head.close()


def test_dead_reckoned_odometry_without_position_feedback(tmp_path: Path) -> None:
    rig_path = write_servo_rig(tmp_path, "pelco-d", 17516, "position_feedback = false")
    rig = load_rig(rig_path)
    with Bus(rig, "test", router=True) as bus, HeadEmulator(rig) as head:
        loop = Loop(bus)
        servo = start_servo(rig_path)
        try:
            loop.until(lambda s: s.status is not None and s.status.link == "connected")
            assert loop.status.dead_reckoned
            loop.until(
                lambda s: (
                    s.odometry is not None
                    and s.odometry.dead_reckoned
                    and abs(s.odometry.pan_rad - math.radians(20.0)) < 1e-9
                ),
                keep_demanding=(20.0, -10.0),
            )
            poll_until(
                lambda: abs(head.pose_at(time.monotonic()).pan_rad - math.radians(20.0)) < 1e-4,
                timeout_s=5.0,
            )
        finally:
            stop(servo)


def test_response_lag_measured_while_the_head_pursues(tmp_path: Path) -> None:
    """A pursuit at 20°/s on a head with a 40 ms command latency: `servo/status` reports a
    response lag of at least that latency (plus the head's own following), none before."""
    rig_path = write_servo_rig(tmp_path, "dynamixel", 17517, head_latency_ms=40)
    rig = load_rig(rig_path)
    with Bus(rig, "test", router=True) as bus, HeadEmulator(rig) as head:
        loop = Loop(bus)
        servo = start_servo(rig_path)
        try:
            loop.until(lambda s: s.status is not None and s.status.link == "connected")
            assert loop.status.response_lag_s is None
            started_s, started_ns = time.monotonic(), time.time_ns()
            bytes_before = head.bytes_received + head.bytes_sent

            def pursue(s: Loop) -> bool:  # a gaze process's demands: where the target is now
                s.demand(-50.0 + 20.0 * (time.monotonic() - started_s), 0.0, "pursuit", 20.0)
                # a status from 1.5 s on: the move to the start is over, the pursuit steady
                return s.status.response_lag_s is not None and (
                    s.status.t_capture_ns > started_ns + 1_500_000_000
                )

            loop.until(pursue, timeout_s=5.0)  # to +50°, inside the 60° limit
            print(f"response lag {loop.status.response_lag_s * 1e3:.1f} ms")
            assert 0.04 <= loop.status.response_lag_s < 0.15, loop.status
            # the line's share as the head's end of it counted the bytes, both ways (a fresh
            # demand every bus wake-up and a poll each 20 ms)
            line_s = (
                (head.bytes_received + head.bytes_sent - bytes_before)
                * BITS_PER_BYTE
                / rig.servo.baud
            )
            expected = line_s / (time.monotonic() - started_s)
            print(f"line load {loop.status.line_load:.2f}, at the head {expected:.2f}")
            assert abs(loop.status.line_load - expected) < 0.25 * expected, loop.status
        finally:
            stop(servo)


def test_a_slow_line_is_not_overrun_by_set_points(tmp_path: Path) -> None:
    """Pelco-D at 2400 baud without position feedback, where a set-point takes 58 ms on the
    line, pursuing a ramp demanded at about 50 Hz: a set-point may queue behind the one on the
    line but not behind one more (the newest replaces it), so the head follows the ramp a
    set-point or two late instead of falling further behind with every second."""
    rig_path = write_servo_rig(
        tmp_path,
        "pelco-d",
        17518,
        "position_feedback = false\ncommand_rate_hz = 20",
        head_latency_ms=20,
        baud=2400,
    )
    rig = load_rig(rig_path)
    with Bus(rig, "test", router=True) as bus, HeadEmulator(rig) as emulator:
        loop = Loop(bus)
        servo_health = bus.subscribe(health("servo"))
        servo = start_servo(rig_path)
        try:
            loop.until(lambda s: s.status is not None and s.status.link == "connected")
            loop.until(lambda s: True, keep_demanding=(-30.0, 0.0), timeout_s=1.0)
            poll_until(lambda: emulator.settled, timeout_s=5.0)
            started_s = time.monotonic()

            def ramp_deg() -> float:
                return -30.0 + 10.0 * (time.monotonic() - started_s)

            def pursue(s: Loop) -> bool:
                s.demand(ramp_deg(), 0.0, "pursuit", 10.0)
                return time.monotonic() - started_s > 4.0

            loop.until(pursue, timeout_s=10.0)
            behind_deg = ramp_deg() - math.degrees(
                emulator.device_pose_at(time.monotonic()).pan_rad
            )
            counters = poll_until(servo_health.take, timeout_s=3.0)[-1].counters
            print(f"head {behind_deg:.2f} deg behind the ramp; servo {counters}")
            assert counters["held_for_the_line"] > 0
            # 58 ms for the set-point on the line, as much for one queued, the head's 20 ms
            # and its acceleration: about 2 degrees at 10 deg/s (a backlog: 8 after 4 s)
            assert 0.0 < behind_deg < 4.0
            # set-points written as soon as the line is free: it is full, and said to be
            print(f"line load {loop.status.line_load:.2f}")
            assert 0.95 < loop.status.line_load < 1.15, loop.status
            assert counters["line_overloaded_s"] >= 1
        finally:
            out = stop(servo)
        assert "busy over the last second" in out
