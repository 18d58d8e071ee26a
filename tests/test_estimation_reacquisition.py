"""A person's id kept across a gap longer than a track may coast (`reacquisition`)."""

from __future__ import annotations

import numpy as np
import pytest
from bench.crossing_people import SIM_RIG

from gazed.config import load_rig
from gazed.estimation.association import gate_threshold
from gazed.estimation.measurement import Measurement
from gazed.estimation.reacquisition import Departures, propagated
from gazed.estimation.results import PredictedState
from gazed.estimation.tracks import PERSON_EXTENT_COV_M2, Sighting, TrackSet

GATE = gate_threshold(0.999, 4)


def state(t_s: float, xy: tuple[float, float], v: tuple[float, float]) -> PredictedState:
    return PredictedState(t_s, np.array(xy, float), np.array(v, float), np.eye(4) * 0.01)


def test_a_departed_state_walks_on_and_grows_uncertain() -> None:
    then = propagated(state(1.0, (0.0, 0.0), (1.0, 0.5)), 3.0, accel_noise_m_s2=0.5)
    assert then.t_s == 3.0
    assert then.position == pytest.approx([2.0, 1.0]) and then.velocity == pytest.approx([1.0, 0.5])
    # position: P + dt² P_v + q dt³/3; velocity: P_v + q dt
    assert then.covariance[0, 0] == pytest.approx(0.01 + 4 * 0.01 + 0.25 * 8 / 3)
    assert then.covariance[2, 2] == pytest.approx(0.01 + 0.25 * 2)
    assert np.allclose(then.covariance, then.covariance.T)


def test_a_new_track_takes_the_id_of_the_departed_one_it_continues() -> None:
    departures = Departures(2.0, 0.5, GATE, PERSON_EXTENT_COV_M2)
    departures.leave(4, state(1.0, (0.0, 0.0), (1.0, 0.0)))
    departures.leave(7, state(1.0, (0.0, 3.0), (-1.0, 0.0)))
    assert departures.claim(state(2.0, (5.0, 0.0), (1.0, 0.0))) is None  # nobody walked there
    assert departures.claim(state(2.0, (1.1, 0.1), (1.0, 0.0))) == 4
    assert departures.claim(state(2.0, (1.0, 0.0), (1.0, 0.0))) is None  # 4 is taken
    assert [d.id for d in departures.departed] == [7]
    assert departures.claim(state(3.5, (-2.5, 3.0), (-1.0, 0.0))) is None  # forgotten by then
    assert departures.departed == []


def walking(t_s: float) -> Sighting:
    cov = np.eye(2) * 0.0004
    return Sighting(Measurement.ground(t_s, (t_s, 1.0), cov, (1.0, 0.0), np.eye(2) * 0.01))


def test_a_person_unseen_past_coast_max_comes_back_under_their_id() -> None:
    section = load_rig(SIM_RIG).estimator.model_copy(update={"coast_max_ms": 400.0})
    tracks = TrackSet(section)

    def other(t_s: float) -> Sighting:
        return Sighting(Measurement.ground(t_s, (0.0, 8.0), np.eye(2) * 0.0004))

    for k in range(10):  # someone standing far off, and a walker at 1 m/s
        t = k * 0.04
        tracks.step(t, [walking(t), other(t)])
    assert [t.id for t in tracks.tracks] == [0, 1]
    for k in range(10, 22):  # the walker is hidden for 0.48 s: its track ends
        tracks.step(k * 0.04, [other(k * 0.04)])
    assert [t.id for t in tracks.tracks] == [1]
    for k in range(22, 26):  # seen again where they walked to: a new track, the old id
        t = k * 0.04
        tracks.step(t, [walking(t), other(t)])
    assert sorted(t.id for t in tracks.tracks) == [0, 1]
    assert tracks.counts["tracks_reclaimed"] == 1
