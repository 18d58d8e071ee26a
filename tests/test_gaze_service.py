"""The gaze process's timing around predictions (`GazeService.step` on a stand-in bus)."""

from __future__ import annotations

import pytest
from stand_in_bus import StandInBus
from test_gaze_controller import Clock, prediction

from gazed.config import parse_rig
from services.gaze import GazeService
from services.runtime import Now


def rig_text(gaze_rate_hz: float) -> str:
    return f'[rig]\nname = "g"\n[camera]\nrate_hz = 25\n[gaze]\nrate_hz = {gaze_rate_hz}\n'


@pytest.mark.parametrize(
    ("gaze_rate_hz", "after_prediction_s"),
    [
        (25.0, 0.04 + 0.02),  # a prediction is due first: wait half a frame past it
        (10.0, 0.1 + 0.02),
        (50.0, 0.02),  # faster than the camera: the timer fills in between predictions
    ],
)
def test_the_timer_after_a_prediction_waits_past_the_next_one(
    gaze_rate_hz: float, after_prediction_s: float
) -> None:
    clock = Clock()
    bus = StandInBus()
    service = GazeService(parse_rig(rig_text(gaze_rate_hz)), bus)  # type: ignore[arg-type]
    service.step(Now(clock.wall_ns, clock.mono_s))  # the first tick
    clock.advance(1.0 / gaze_rate_hz)
    bus.inboxes["estimator/prediction"].items.append(prediction(clock, 1.0, -2.0))
    wait_s = service.step(Now(clock.wall_ns, clock.mono_s))
    assert wait_s == pytest.approx(after_prediction_s)
    clock.advance(wait_s)  # no prediction came: the timer ticks, a period on
    assert service.step(Now(clock.wall_ns, clock.mono_s)) == pytest.approx(1.0 / gaze_rate_hz)
