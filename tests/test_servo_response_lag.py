"""The head's lag behind its set-points, from its position reports (`gazed.servo.response_lag`):
measured to the ms on a head that follows a fixed time late, not measured where a rate says
nothing, the short way round a pan that wraps, stalls counted; and on the emulated head, the
lag it measures is the one that lines the set-points up with where the head is."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gazed.config import HeadSection, SimSection
from gazed.servo.limits import Target
from gazed.servo.response_lag import ResponseLag
from gazed.servo.setpoints import SetpointGenerator
from gazed.sim.head_mechanics import HeadMechanics

POLL_S = 0.02
ENCODER_STEP_RAD = 2.0 * math.pi / 4096  # a Dynamixel X's encoder


def quantised(angle_rad: float) -> float:
    return round(angle_rad / ENCODER_STEP_RAD) * ENCODER_STEP_RAD


def wrapped(angle_rad: float) -> float:
    return math.remainder(angle_rad, 2.0 * math.pi)


def rms(errors: np.ndarray) -> float:
    return float(np.sqrt(np.mean(errors**2)))


def test_a_head_that_follows_a_fixed_time_late_is_measured_to_the_ms() -> None:
    lag = ResponseLag()
    rate = math.radians(10.0)
    for k in range(200):
        t = k * POLL_S
        lag.observe((rate * t, 0.3), (rate, 0.0), (quantised(rate * (t - 0.045)), 0.3))
    assert lag.lag_s == pytest.approx(0.045, abs=0.003)
    assert lag.outliers == 0


def test_nothing_is_measured_at_rest_too_slowly_or_while_the_rate_changes() -> None:
    lag = ResponseLag()
    for _ in range(100):  # at rest, and a tilt at 2°/s (an encoder step is 45 ms of it)
        lag.observe((0.1, 0.2), (0.0, math.radians(2.0)), (0.09, 0.19))
    for k in range(100):  # a rate that doubles and halves from one report to the next
        rate = math.radians(10.0 if k % 2 else 20.0)
        lag.observe((1.0, 0.0), (rate, 0.0), (0.99, 0.0))
    assert lag.lag_s is None
    lag.observe((1.0, 0.0), (math.radians(10.0), 0.0), (0.99, 0.0))
    assert lag.lag_s is None  # one steady report after all that is not enough


def test_a_pan_that_wraps_is_measured_the_short_way_round() -> None:
    lag = ResponseLag()
    rate = math.radians(20.0)
    start = math.pi - 0.2  # crosses +π -> -π after 0.57 s
    for k in range(100):
        t = k * POLL_S
        lag.observe(
            (wrapped(start + rate * t), 0.0), (rate, 0.0), (wrapped(start + rate * (t - 0.03)), 0.0)
        )
    assert lag.lag_s == pytest.approx(0.03, abs=1e-9)


def test_a_stall_is_counted_not_measured_and_a_head_ahead_has_no_lag() -> None:
    lag = ResponseLag()
    rate = math.radians(10.0)
    stuck = -0.005 * rate  # the head stuck while its set-point runs away: lags of 25 ms, 45 ms...
    for k in range(300):
        lag.observe((rate * k * POLL_S, 0.0), (rate, 0.0), (stuck, 0.0))
    assert lag.outliers == 250  # from k = 50 on: over a second behind
    assert lag.lag_s == pytest.approx(0.505)  # the median of the 49 before, the stall left out
    ahead = ResponseLag()
    for k in range(100):
        t = k * POLL_S
        ahead.observe((rate * t, 0.0), (rate, 0.0), (rate * (t + 0.01), 0.0))
    assert ahead.lag_s == 0.0


def test_reset_forgets_the_last_head() -> None:
    lag = ResponseLag()
    rate = math.radians(10.0)
    for k in range(100):
        lag.observe((rate * k * POLL_S, 0.0), (rate, 0.0), (rate * (k * POLL_S - 0.05), 0.0))
    assert lag.lag_s is not None
    lag.reset()
    assert lag.lag_s is None


def test_the_measured_lag_lines_the_set_points_up_with_the_emulated_head() -> None:
    """Set-points of a pursuit at 15°/s written at 50 Hz as goal positions to the emulator's
    mechanism (30 ms command latency, moves at the head's limits, a Dynamixel's encoder) and
    polled at 50 Hz, as the servo process does: the head runs behind its set-points by more
    than the command latency, and shifting the set-points by the measured lag leaves a small
    fraction of the error that the lag explains."""
    head = HeadSection()
    mechanics = HeadMechanics(
        head, SimSection(head_latency_ms=30.0, head_encoder_resolution_deg=360.0 / 4096), 0.0
    )
    setpoints = SetpointGenerator(head, 0.0)
    rate = math.radians(15.0)
    setpoints.track(Target("pursuit", 0.0, 0.0, rate, 0.0), 0.0)
    lag = ResponseLag()
    times, written, reported = [], [], []
    for k in range(1, 300):
        t = k * POLL_S
        goal = setpoints.advance(t)
        mechanics.schedule(t, lambda m, g=goal: (m.pan.move_to(g[0]), m.tilt.move_to(g[1])))
        t_answer = t + POLL_S / 2  # the poll, between two writes
        mechanics.advance(t_answer)
        pan, tilt = mechanics.encoder()
        lag.observe(setpoints.advance(t_answer), setpoints.rates_rad_s, (pan, tilt))
        times += [t, t_answer]
        written += [goal[0], setpoints.advance(t_answer)[0]]
        reported.append((t_answer, pan))
    assert lag.lag_s is not None
    assert 0.03 < lag.lag_s < 0.1  # the command latency and then some
    steady = [(t, p) for t, p in reported if t > 1.0]
    t_s, pan = (np.array(v) for v in zip(*steady, strict=True))
    behind = pan - np.interp(t_s, times, written)
    shifted = pan - np.interp(t_s - lag.lag_s, times, written)
    assert rms(shifted) < 0.15 * rms(behind), (rms(shifted), rms(behind))
