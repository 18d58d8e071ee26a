"""Speed mode on a recording device and a virtual clock: rates quantised to the table's steps
(never past a cap), the set-points' rate plus the gap predicted when a command acts (the
device model: latency and acceleration ramp; the set-points' trend), never a step towards a
limit the head could not brake before, commands renewed before the device's timeout and not
repeated otherwise, Stop once the set-points come to rest, a set-point older than the command
timeout held still; the set-points' future as their generator plans it; and on the emulated
head's mechanism, a pursuit followed within a step's travel over the horizon, and a move of the
set-points at the head's limits followed without overshoot however irregularly the loop looks
at the head."""

from __future__ import annotations

import math
import random

import pytest
from conftest import REPO
from hypothesis import given
from hypothesis import strategies as st
from servo_link_support import link_rig
from speed_head_support import Mechanism, StubSpeedDevice, follow

from gazed.config import load_rig
from gazed.servo.drive_model import DriveModel
from gazed.servo.driver import DevicePosition
from gazed.servo.limits import Target
from gazed.servo.setpoint_trend import planned, run_on, set_point_rates
from gazed.servo.setpoints import SetpointGenerator
from gazed.servo.speed_mode import SpeedHead, speed_head
from gazed.servo.speed_steps import SpeedSteps, rig_speed_steps
from gazed.sim.head_mechanics import HeadMechanics

RAD = math.radians
STEPS = SpeedSteps([RAD(r) for r in (1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0)])
TIMEOUT_S = 0.5
LATENCY_S = 0.03


class Device(StubSpeedDevice):
    """Records speed commands (as steps of 7) and Stops; reports the position it is given."""

    def __init__(self) -> None:
        super().__init__([0.0])
        self.commands: list[tuple[float, float] | str] = []
        self.position = (0.0, 0.0)

    def set_speed(self, pan_fraction: float, tilt_fraction: float, timeout_s: float) -> int:
        assert timeout_s == TIMEOUT_S
        self.commands.append((round(pan_fraction * 7), round(tilt_fraction * 7)))
        return 1

    def stop(self) -> int:
        self.commands.append("stop")
        return 1

    def query_position(self, between=None) -> DevicePosition:
        return DevicePosition(*self.position, self.now_ns, self.now_ns)


def recording_head(
    command_period_s: float = 0.0, by_speed: bool = True
) -> tuple[SpeedHead, Device, list[float]]:
    """A head of ±60° pan, -40..20° tilt and 3000°/s² (`link_rig`), polled at 50 Hz, driven by
    speed unless `by_speed` is false."""
    device = Device()
    now = device.now
    head = SpeedHead(
        device,
        link_rig().head,
        (STEPS, STEPS),
        latency_s=LATENCY_S,
        command_timeout_s=TIMEOUT_S,
        poll_period_s=0.02,
        command_period_s=command_period_s,
        mono_s=lambda: now[0],
        wall_ns=lambda: round(now[0] * 1e9),
        by_speed=lambda _device: by_speed,
    )
    head.connect()
    return head, device, now


def test_quantise_takes_the_nearest_step_with_its_sign_and_none_past_the_cap() -> None:
    assert STEPS.quantise(RAD(0.4)) == 0
    assert STEPS.quantise(RAD(0.6)) == 1
    assert STEPS.quantise(RAD(-12.0)) == -4
    assert STEPS.quantise(RAD(16.0)) == 5
    assert STEPS.quantise(RAD(500.0)) == 7
    assert STEPS.quantise(RAD(16.0), cap_rad_s=RAD(19.0)) == 4
    assert STEPS.quantise(RAD(-80.0), cap_rad_s=0.0) == 0
    assert STEPS.rate_rad_s(-3) == -RAD(5.0)
    assert SpeedSteps.even(RAD(64.0), 32).rate_rad_s(16) == pytest.approx(RAD(32.0))
    with pytest.raises(ValueError):
        SpeedSteps([RAD(2.0), RAD(1.0)])


@given(st.floats(-10.0, 10.0), st.floats(0.0, 10.0))
def test_a_quantised_step_never_runs_faster_than_its_cap(rate: float, cap: float) -> None:
    step = STEPS.quantise(rate, cap)
    assert abs(STEPS.rate_rad_s(step)) <= cap + 1e-9
    assert step == 0 or math.copysign(1.0, step) == math.copysign(1.0, rate)


def test_the_rate_is_the_set_points_rate_plus_the_gap_predicted_when_it_acts() -> None:
    head, device, now = recording_head()
    head.set_position(0.0, 0.0)
    head.query_position()
    assert device.commands == []  # at rest on its set-point: nothing to send
    assert head.horizon_s == pytest.approx(0.02 + LATENCY_S)  # a poll period and the latency
    now[0] = 0.1
    head.set_position(RAD(1.0), 0.0)  # the set-points run at 10 deg/s, the head 1 deg behind
    # the loop last looked at the head 0.1 s ago: the step may run that long
    assert head.horizon_s == pytest.approx(0.1 + LATENCY_S)
    # when a command sent now acts (30 ms on), the set-point is at 1.3 deg and the head still
    # at 0: 10 deg/s and 1.3 deg over the horizon
    assert head.rates_rad_s(0.1) == pytest.approx((RAD(10.0 + 1.3 / 0.13), 0.0))
    assert device.commands == [(5, 0)]  # 20 deg/s
    for i in range(1, 300):  # looking every 10 ms, the long gap fades from the horizon
        now[0] = 0.1 + i * 0.01
        head.query_position()
    assert head.horizon_s == pytest.approx(0.02 + LATENCY_S)


def test_the_head_is_predicted_from_its_reading_with_each_rate_told_latency_and_ramp() -> None:
    head, _device, now = recording_head()
    head.set_position(0.0, 0.0)
    head.query_position()
    now[0] = 0.1
    head.set_position(RAD(1.0), 0.0)  # a step told at 0.1 s
    rate = STEPS.rate_rad_s(head.sent[0])
    now[0] = 0.12
    head.query_position()  # read at 0 deg at 0.12 s: the step has not acted yet
    assert head.where(0.13) == pytest.approx((0.0, 0.0))
    ramp_s = rate / RAD(3000.0)  # link_rig's acceleration limit
    moved = rate * (0.02 - ramp_s / 2.0)
    assert head.where(0.15) == pytest.approx((moved, 0.0))


def test_a_running_command_is_renewed_before_the_devices_timeout() -> None:
    head, device, now = recording_head()
    head.set_position(0.0, 0.0)
    for i in range(1, 40):
        now[0] = i * 0.05
        device.position = (RAD(10.0 * now[0] - 0.5), 0.0)
        head.set_position(RAD(10.0 * now[0]), 0.0)
    renewals = [c for c in device.commands if c != "stop"]
    assert 4 <= len(renewals) <= 12  # about every half timeout over 1.95 s, never each set-point


def test_at_most_one_command_a_command_period_but_stop_at_once() -> None:
    head, device, now = recording_head(command_period_s=0.1)
    assert head.horizon_s == pytest.approx(0.1 + LATENCY_S)  # a command period and the latency
    head.set_position(0.0, 0.0)
    head.query_position()
    now[0] = 0.1
    head.set_position(RAD(1.0), 0.0)  # 10 + 1.3 / 0.13 deg/s: step 5
    now[0] = 0.12
    head.set_position(RAD(3.0), 0.0)  # 100 deg/s and more: held back, too soon
    assert device.commands == [(5, 0)]
    now[0] = 0.14
    head.set_position(RAD(3.0), 0.0)
    now[0] = 0.16
    device.position = (RAD(2.4), 0.0)
    head.query_position()
    head.set_position(RAD(3.0), 0.0)  # the 20 deg/s running lands it on 3 deg when Stop acts
    assert device.commands[-1] == "stop"  # at once, not held back
    now[0] = 0.3
    head.set_position(RAD(5.0), 0.0)  # a command period on: the next step goes out
    assert device.commands[-1][0] > 0


def test_a_stale_set_point_stands_still_and_the_head_stops_on_it() -> None:
    head, device, now = recording_head()
    head.set_position(0.0, 0.0)
    now[0] = 0.1
    head.set_position(RAD(2.0), 0.0)  # 20 deg/s
    assert device.commands[-1] == (5, 0)
    now[0] = 0.1 + TIMEOUT_S + 0.01  # no set-point since: the target stands at 2 deg
    device.position = (RAD(1.9), 0.0)
    head.query_position()
    pan_at = head.where(now[0] + LATENCY_S)[0]
    assert head.rates_rad_s(now[0]) == pytest.approx(((RAD(2.0) - pan_at) / head.horizon_s, 0.0))
    device.position = (RAD(2.0), 0.0)
    for _ in range(5):  # the head told to stop where it stands, on its set-point
        head.stop() if device.commands[-1] != "stop" else None
        now[0] += 0.02
        head.query_position()
    assert device.commands[-1] == "stop"


def test_no_step_towards_a_limit_the_head_could_not_brake_before() -> None:
    head, device, now = recording_head()
    pan_max, start = RAD(60.0), RAD(55.0)
    device.position = (start, 0.0)
    head.set_position(start, 0.0)
    rate = 0.0
    for i in range(1, 60):  # set-points run into the limit at 100 deg/s, the head after them
        now[0] = i * 0.02
        device.position = (min(pan_max, device.position[0] + rate * 0.02), 0.0)
        head.query_position()
        head.set_position(min(pan_max, start + RAD(100.0) * now[0]), 0.0)
        pan_step = 0 if device.commands[-1] == "stop" else device.commands[-1][0]
        rate = STEPS.rate_rad_s(pan_step)
        room = pan_max - device.position[0] if pan_step > 0 else RAD(60.0) + device.position[0]
        assert rate**2 <= 2 * RAD(3000.0) * max(room, 0.0) + 1e-12
    assert any(c != "stop" and c[0] >= 6 for c in device.commands)  # it did run fast
    assert device.commands[-1] == "stop"  # and stands at the limit
    head.set_position(pan_max - RAD(0.2), 0.0)  # away from the limit it moves again
    assert device.commands[-1][0] < 0


def test_a_running_head_is_stopped_before_the_link_closes() -> None:
    head, device, now = recording_head()
    head.set_position(0.0, 0.0)
    now[0] = 0.1
    head.set_position(RAD(2.0), 0.0)
    head.disconnect()
    assert device.commands == [(5, 0), "stop"] and not device.is_connected
    head.connect()
    head.disconnect()  # at rest: nothing to stop
    assert device.commands == [(5, 0), "stop"]


def test_a_head_that_takes_positions_gets_them_unchanged() -> None:
    head, _device, _now = recording_head(by_speed=False)
    with pytest.raises(AssertionError, match="no positions"):
        head.set_position(0.1, 0.1)


def test_speed_mode_is_for_heads_that_take_speed_commands() -> None:
    from gazed.config import RigError

    assert link_rig(protocol="visca", mode='"speed"').servo.mode == "speed"
    with pytest.raises(RigError, match="take no speed commands"):
        link_rig(protocol="flir-ptu", mode='"speed"')
    with pytest.raises(RigError, match="rising with the step"):
        link_rig(protocol="pelco-d", pan_speed_steps_deg_s="[2.0, 1.0]")
    with pytest.raises(RigError, match="onvif://"):
        link_rig(protocol="visca", port="onvif://127.0.0.1:80")


def test_a_visca_camera_in_speed_mode_is_driven_by_pan_tilt_drives_only(tmp_path) -> None:
    import time

    from servo_link_support import Demands, demand
    from test_servo_visca_ip_link import udp_rig

    from gazed.servo.head_link import HeadLink
    from gazed.sim.head_emulator import HeadEmulator

    rig = udp_rig(tmp_path, mode='"speed"')
    demands = Demands()
    with HeadEmulator(rig) as camera:
        link = HeadLink(rig, demands.take, lambda *_: None)

        def no_positions(*_args: object) -> list[bytes]:
            raise AssertionError("an absolute move in speed mode")

        link.codec.encode_set_position = no_positions  # type: ignore[method-assign]

        class Now:
            immediate = False
            mono_s = property(lambda _self: time.monotonic())
            wall_ns = property(lambda _self: time.time_ns())

        started = time.monotonic()
        while time.monotonic() - started < 1.0:
            demands.put(demand(15.0, 5.0))
            link.step(Now())
            time.sleep(0.01)
        pose = camera.pose_at(time.monotonic())
        link.driver.disconnect()
    assert link.counts["errors"] == 0, link.last_error
    assert math.degrees(pose.pan_rad) == pytest.approx(15.0, abs=1.0)
    assert math.degrees(pose.tilt_rad) == pytest.approx(5.0, abs=1.0)


def test_a_head_with_latency_and_coarse_steps_follows_a_pursuit_closely() -> None:
    rig = link_rig()
    sim = rig.sim.model_copy(update={"head_latency_ms": 30.0})
    now = [0.0]
    mechanics = HeadMechanics(rig.head, sim, 0.0)
    steps = SpeedSteps.even(RAD(120.0), 24)  # 5 deg/s a step, as a VISCA camera's drive
    device = Mechanism(mechanics, (RAD(120.0), RAD(120.0)), now)
    head = SpeedHead(
        device,
        rig.head,
        (steps, steps),
        latency_s=0.03,
        command_timeout_s=TIMEOUT_S,
        poll_period_s=0.02,
        command_period_s=0.02,
        mono_s=lambda: now[0],
        wall_ns=lambda: round(now[0] * 1e9),
    )
    head.connect()

    def setpoint(t_s: float) -> tuple[float, float]:
        return RAD(20.0) * math.sin(t_s * math.pi / 2.0), RAD(5.0) * math.sin(t_s * math.pi)

    samples = follow(head, mechanics, now, setpoint, 4.0, 1.0)
    errors = [a - b for _, head_at, sp in samples for a, b in zip(head_at, sp, strict=True)]
    rms_deg = math.degrees(math.sqrt(sum(e * e for e in errors) / len(errors)))
    # the quantisation's share is a step over the horizon (5 deg/s over 50 ms), not a step
    # over a small gain; the head's 30 ms to act is predicted, not lagged
    assert rms_deg < 0.15
    assert device.counters["commands"] <= 4 * 50  # never above the command rate


def test_the_set_points_rate_and_its_change_come_from_the_last_three() -> None:
    def parabola(t_s: float) -> float:  # rate 2 - 10 t, its change -10
        return 2.0 * t_s - 5.0 * t_s * t_s

    _, _, middle = set_point_rates((parabola(0.02), 0.0), (parabola(0.0), 0.0), 0.02, None)
    rates, accels, _ = set_point_rates(
        (parabola(0.05), 0.0), (parabola(0.02), 0.0), 0.03, (middle, 0.02)
    )
    assert rates[0] == pytest.approx(2.0 - 10.0 * 0.05)
    assert accels[0] == pytest.approx(-10.0)


def test_set_points_run_on_until_they_rest_or_reach_the_rate_limit() -> None:
    braking = run_on(1.0, 2.0, -10.0, 5.0, 1.0)  # at rest after 0.2 s, 0.2 rad on
    assert braking == pytest.approx((1.2, 0.0, 0.0))
    speeding = run_on(0.0, 4.0, 10.0, 5.0, 1.0)  # at the 5 rad/s limit after 0.1 s
    assert speeding == pytest.approx((0.45 + 5.0 * 0.9, 5.0, 0.0))
    assert run_on(0.0, 1.0, 0.0, 5.0, 0.5) == pytest.approx((0.5, 1.0, 0.0))


def test_a_told_rate_acts_after_the_latency_at_the_acceleration_limit() -> None:
    model = DriveModel(0.05, (10.0, 10.0), 0.0)
    model.tell(0.0, 1.0, -1.0)
    assert model.run(0.05)[0] == pytest.approx((0.0, 0.0))
    moved, rates, targets = model.run(0.1)  # 0.05 s of ramp at 10 rad/s^2
    assert moved == pytest.approx((0.0125, -0.0125))
    assert rates == pytest.approx((0.5, -0.5)) and targets == (1.0, -1.0)
    model.read(0.1)  # a reading: the model runs on from its state then
    assert model.run(0.2)[0] == pytest.approx((0.0375 + 0.05, -0.0875))  # ramp, then steady


def test_the_set_points_are_planned_as_their_generator_moves_them_in_device_angles() -> None:
    head = link_rig().head.model_copy(update={"pan_sign": -1, "pan_zero_deg": 10.0})
    generator = SetpointGenerator(head, 0.0)
    generator.reset(0.0, 0.0, 0.0)
    generator.track(Target("position", RAD(20.0), 0.0, 0.0, 0.0), 0.0)
    (pan, tilt), (pan_rate, tilt_rate), (pan_accel, _) = planned(generator, head, 0.05)
    assert generator.t_s == 0.0 and generator.rates_rad_s == (0.0, 0.0)  # left as it was
    # 50 ms at 3000 deg/s^2 from rest: 3.75 deg on at 150 deg/s, still gathering speed
    assert pan == pytest.approx(RAD(10.0 - 3.75), abs=RAD(0.2))
    assert pan_rate == pytest.approx(-RAD(150.0), abs=RAD(4.0))
    assert pan_accel == pytest.approx(-RAD(3000.0))  # the device's pan runs the other way
    assert (tilt, tilt_rate) == (0.0, 0.0)
    generator.advance(0.05)
    assert generator.pan.position_rad == pytest.approx(RAD(10.0) - pan)


def overshoot_after_a_jump_deg(follows: bool, seed: int) -> float:
    """The sim ONVIF rig's head at rest, then a pursuit demand 6 deg ahead moving at 5 deg/s:
    how far past the target the head runs, when the loop looks at it every 10 ms plus a busy
    host's delays (exponential, 5 ms on average), speed mode following the set-points'
    generator or only the set-points written."""
    rig = load_rig(REPO / "configs" / "sim-onvif.toml")
    rng = random.Random(seed)
    now = [0.0]
    mechanics = HeadMechanics(rig.head, rig.sim.model_copy(update={"head_latency_ms": 20.0}), 0.0)
    steps = rig_speed_steps(rig)
    device = Mechanism(mechanics, (steps[0].rates_rad_s[-1], steps[1].rates_rad_s[-1]), now)
    head = speed_head(rig, device, mono_s=lambda: now[0], wall_ns=lambda: device.now_ns)
    head.connect()
    generator = SetpointGenerator(rig.head, 0.0)
    generator.reset(0.0, 0.0, 0.0)
    if follows:
        head.follow(generator)

    def target(t_s: float) -> float:
        return RAD(6.0) + RAD(5.0) * (t_s - 0.1) if t_s >= 0.1 else 0.0

    overshoot_rad, next_demand_s = 0.0, 0.1
    for i in range(100):
        now[0] += 0.01 + rng.expovariate(1.0 / 0.005)
        if now[0] >= next_demand_s:  # the gaze's demands at 25 Hz
            generator.track(Target("pursuit", target(now[0]), 0.0, RAD(5.0), 0.0), now[0])
            next_demand_s += 0.04
        if i % 2:
            head.query_position()
        else:
            head.set_position(*generator.advance(now[0]))
        mechanics.advance(now[0])
        overshoot_rad = max(overshoot_rad, mechanics.encoder()[0] - target(now[0]))
    return math.degrees(overshoot_rad)


def test_a_move_at_the_heads_limits_is_followed_without_overshoot_on_a_busy_host() -> None:
    # the set-points brake at the head's limit; extrapolated from the last ones written, long
    # apart, they seem to run on, and the head runs past them by degrees
    assert max(overshoot_after_a_jump_deg(True, seed) for seed in range(4)) < 1.5
    assert max(overshoot_after_a_jump_deg(False, seed) for seed in range(4)) > 3.0
