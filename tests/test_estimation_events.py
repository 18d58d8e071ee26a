"""Maneuver events: the most likely model changes, with the previous segment's signature."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gazed.config import EstimatorSection
from gazed.estimation import Measurement, build_estimator
from gazed.estimation.events import ManeuverTracker
from gazed.eval.scenarios import rounded_square


def test_tracker_reports_segment_duration_and_mean_rates() -> None:
    tracker = ManeuverTracker(2, ("A", "B"))
    idx = np.array([0, 1])
    for k, (m0, m1) in enumerate([(0, 1), (0, 1), (0, 1), (1, 1), (1, 0)]):
        tracker.observe(idx, np.full(2, k * 0.5), np.array([m0, m1]), np.full((2, 2), [k, -k]))
    events = tracker.drain()
    assert [(e.track, e.previous_model, e.model) for e in events] == [(0, "A", "B"), (1, "B", "A")]
    first = events[0]
    assert first.t_start_s == 1.5 and first.previous_start_s == 0.0
    assert first.previous_duration_s == 1.5 and first.previous_steps == 3
    assert first.mean_s_dot_m_s2 == pytest.approx(
        1.0
    ) and first.mean_theta_dot_rad_s == pytest.approx(-1.0)
    assert events[1].previous_steps == 4
    assert tracker.drain() == []
    tracker.reset(np.array([0]))
    tracker.observe(idx, np.full(2, 9.0), np.array([1, 0]), np.zeros((2, 2)))
    assert tracker.drain() == []  # a restarted track starts a segment without an event


def test_imm_on_the_rounded_square_reports_turns() -> None:
    """Each turn that the IMM recognises ends in an event whose signature is a turn of about
    45°/s lasting about 50 observations."""
    scenario = rounded_square(seed=2)
    estimator = build_estimator(EstimatorSection(), mode="imm")
    R_p, R_v = np.eye(2) * 0.05**2, np.eye(2) * 0.2**2
    events = []
    for k, t in enumerate(scenario.t_s):
        estimator.update(
            Measurement.ground(t, scenario.z_position[k], R_p, scenario.z_velocity[k], R_v)
        )
        events += estimator.drain_events()
    turns = [e for e in events if e.previous_model == "CS" and e.previous_steps > 20]
    assert len(turns) >= 2
    for e in turns:
        assert e.previous_duration_s == pytest.approx(2.0, abs=0.8)
        assert e.mean_theta_dot_rad_s == pytest.approx(math.radians(45), rel=0.3)
        assert abs(e.mean_s_dot_m_s2) < 0.1
    straights = [e for e in events if e.previous_model == "CSD" and e.previous_steps > 20]
    assert straights and all(abs(e.mean_theta_dot_rad_s) < 0.1 for e in straights)


def test_tracker_takes_a_slice_of_tracks() -> None:
    """The batch step passes a slice when every track stepped: same segments as indices."""
    by_slice, by_index = ManeuverTracker(3, ("A", "B")), ManeuverTracker(3, ("A", "B"))
    for k, models in enumerate([(0, 1, 0), (0, 1, 1), (1, 1, 1)]):
        m = np.array(models)
        by_slice.observe(slice(None), np.full(3, float(k)), m, np.full((3, 2), [0.0, 0.5]))
        by_index.observe(np.arange(3), np.full(3, float(k)), m, np.full((3, 2), [0.0, 0.5]))
    assert by_slice.drain() == by_index.drain() != []
