"""When the gaze ticks (gazed.gaze.schedule): at its rate, at once after a prediction or a
command, and after a prediction not a moment before the next one is due."""

from __future__ import annotations

import pytest

from gazed.gaze.schedule import TickSchedule


def test_it_ticks_at_its_rate_without_predictions() -> None:
    schedule = TickSchedule(rate_hz=50.0, frame_period_s=0.04)
    assert schedule.due(10.0, fresh_prediction=False)  # the first tick
    assert schedule.wait_s(10.0) == pytest.approx(0.02)
    assert not schedule.due(10.019, fresh_prediction=False)
    assert schedule.due(10.02, fresh_prediction=False)
    assert schedule.wait_s(10.05) == 0.0  # overdue: no negative wait


def test_a_prediction_ticks_at_once_and_the_timer_waits_half_a_frame_past_the_next() -> None:
    """At 25 Hz with a 25 Hz camera the next prediction is due a period later; the timer waits
    half a frame longer, so it fills in only for a missing prediction."""
    schedule = TickSchedule(rate_hz=25.0, frame_period_s=0.04)
    schedule.due(10.0, fresh_prediction=False)
    assert schedule.due(10.001, fresh_prediction=True)  # not yet due, but a prediction came
    assert schedule.wait_s(10.001) == pytest.approx(0.04 + 0.02)
    assert not schedule.due(10.05, fresh_prediction=False)
    assert schedule.due(10.062, fresh_prediction=False)
    assert schedule.wait_s(10.062) == pytest.approx(0.04)


def test_faster_than_the_camera_the_timer_fills_in_between_predictions() -> None:
    schedule = TickSchedule(rate_hz=50.0, frame_period_s=0.04)
    assert schedule.due(10.0, fresh_prediction=True)
    assert schedule.wait_s(10.0) == pytest.approx(0.02)


def test_a_command_makes_the_next_step_tick() -> None:
    schedule = TickSchedule(rate_hz=10.0, frame_period_s=0.04)
    schedule.due(10.0, fresh_prediction=False)
    assert not schedule.due(10.01, fresh_prediction=False)
    schedule.act_now(10.01)
    assert schedule.wait_s(10.01) == 0.0
    assert schedule.due(10.01, fresh_prediction=False)
