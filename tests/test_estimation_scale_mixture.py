"""A mover's point as a two-Gaussian scale mixture (`scale_mixture`): the gate is the tail's,
the cost the mixture's, and a filter takes a point at the precision its posterior expects; and
a track started from a velocity within its noise of zero (`Measurement.moving`)."""

from __future__ import annotations

import numpy as np
import pytest
from bench.crossing_people import SIM_RIG

from gazed.config import load_rig
from gazed.estimation.association import gate_threshold, pair_costs
from gazed.estimation.measurement import Measurement
from gazed.estimation.results import PredictedState
from gazed.estimation.scale_mixture import expected_precision, mixture_costs, tail_posterior
from gazed.estimation.tracks import Sighting, TrackSet

CORE = np.diag([0.01, 0.04])  # m²: most movers' points
TAIL = np.diag([0.05, 2.0])  # m²: the few far off along the range axis (y here)
GATE = gate_threshold(0.999, 2)


def prediction(xy: tuple[float, float], var: float = 0.01) -> PredictedState:
    return PredictedState(0.0, np.array(xy, float), np.zeros(2), np.eye(4) * var)


def test_a_point_off_by_the_tails_spread_is_a_candidate_at_the_cost_of_its_rarity() -> None:
    """Along range, 2 m off: outside the core's gate, inside the tail's; near the prediction
    the mixture costs about what the core alone does (its weight is 1 - ε)."""
    predicted, P = np.zeros((1, 2)), np.eye(2)[None] * 0.01
    measured = np.array([[0.0, 0.05], [0.0, 2.0]])
    core, tail = np.stack([CORE, CORE]), np.stack([TAIL, TAIL])
    alone = pair_costs(predicted, P[:, None] + core[None], measured, GATE)
    assert np.isfinite(alone[0, 0]) and np.isinf(alone[0, 1])
    mixed = mixture_costs(predicted, P, measured, core, tail, np.array([0.07, 0.07]), GATE)
    assert np.isfinite(mixed).all()
    assert mixed[0, 0] == pytest.approx(alone[0, 0] - 2 * np.log(0.93), abs=0.05)
    assert mixed[0, 1] > mixed[0, 0] + 5.0
    off = mixture_costs(predicted, P, measured, core, tail, np.zeros(2), GATE)
    assert off[0, 0] == pytest.approx(alone[0, 0]) and np.isinf(off[0, 1])  # ε = 0: the core


def test_a_point_is_taken_at_the_precision_its_posterior_expects() -> None:
    """A point that agrees with the prediction at nearly the core's precision, one far off
    along range at nearly the tail's, a new track's first at the prior's (w = ε)."""
    near = Measurement.ground(0.0, (0.0, 0.1), CORE)
    far = Measurement.ground(0.0, (0.0, 2.0), CORE)
    w_near = tail_posterior(near.position, CORE + np.eye(2) * 0.01, TAIL + np.eye(2) * 0.01, 0.07)
    w_far = tail_posterior(far.position, CORE + np.eye(2) * 0.01, TAIL + np.eye(2) * 0.01, 0.07)
    assert w_near < 0.05 < 0.95 < w_far
    taken_near = expected_precision(near, TAIL, 0.07, prediction((0.0, 0.0)))
    taken_far = expected_precision(far, TAIL, 0.07, prediction((0.0, 0.0)))
    assert taken_near.position_cov[1, 1] < 1.1 * CORE[1, 1]
    assert taken_far.position_cov[1, 1] > 0.9 * TAIL[1, 1]
    first = expected_precision(near, TAIL, 0.07, None)
    expected = np.linalg.inv(0.93 * np.linalg.inv(CORE) + 0.07 * np.linalg.inv(TAIL))
    assert first.position_cov == pytest.approx(expected)
    assert expected_precision(near, None, 0.07, None) is near


def test_a_track_takes_a_point_off_along_range_without_being_pulled_off() -> None:
    """A walker seen at its true point, but one frame in ten 2 m off along range (a mask that
    shows a part of them): with the tail the track takes every point, those barely moving it;
    with the core alone its filter refuses them as outliers."""
    section = load_rig(SIM_RIG).estimator
    results = []
    for weight in (0.07, 0.0):
        rng = np.random.default_rng(5)
        tracks = TrackSet(section)
        worst = 0.0
        for k in range(60):
            t = k / 7.0
            truth = np.array([1.0 * t, 10.0])
            xy = truth + rng.normal(0.0, np.sqrt(np.diag(CORE))) + (0.0, 2.0 * (k % 10 == 9))
            sighting = Sighting(
                Measurement.ground(t, xy, CORE, (1.0, 0.0), np.eye(2) * 0.04),
                tail_cov=TAIL if weight else None,
                tail_weight=weight,
            )
            tracks.step(t, [sighting])
            state = tracks.tracks[0].estimator.predict(t)
            assert state is not None
            if k > 5:
                worst = max(worst, float(np.linalg.norm(state.position - truth)))
        results.append((tracks.health()["gated"], worst))
    (gated, worst), (gated_core, worst_core) = results
    assert gated == 0 and worst < 0.3
    assert gated_core == 6 and worst_core < 0.3


def test_a_velocity_outside_its_gate_is_left_out_of_the_measurement_taken() -> None:
    """A mover's velocity is tested against the prediction's on its own: one off by more than
    its gate (a mask that split, merged or changed shape) is left out, its position kept; one
    within it, and a new track's first, keep theirs."""
    predicted = PredictedState(0.0, np.zeros(2), np.array([1.0, 0.0]), np.eye(4) * 0.01)
    velocity_cov = np.eye(2) * 0.09
    steady = Sighting(Measurement.ground(0.0, (0.1, 0.0), CORE, (1.2, 0.1), velocity_cov))
    wild = Sighting(Measurement.ground(0.0, (0.1, 0.0), CORE, (-5.0, -3.0), velocity_cov))
    assert steady.taken(predicted, GATE).velocity is not None
    taken = wild.taken(predicted, GATE)
    assert taken.velocity is None and taken.position == pytest.approx((0.1, 0.0))
    assert wild.taken(None, GATE).velocity is not None
    assert wild.taken(predicted).velocity is not None  # no gate given: the whole measurement


def test_a_track_started_at_rest_turns_to_its_persons_heading() -> None:
    """A first velocity within its noise of zero gives no heading: the track starts from two
    points instead, and follows a walker who walks along y (a state started at zero speed and
    heading 0 keeps the heading, and its velocity along y, at 0)."""
    section = load_rig(SIM_RIG).estimator
    tracks = TrackSet(section)
    velocity_cov = np.eye(2) * 1.5**2  # a mover's velocity: noisy
    for k in range(8):
        t = k / 7.0
        v = (0.0, 0.0) if k == 0 else (0.0, 1.5)
        xy = (0.0, 1.5 * t)
        tracks.step(t, [Sighting(Measurement.ground(t, xy, CORE, v, velocity_cov))])
    (track,) = tracks.tracks
    state = track.estimator.predict(1.0)
    assert state is not None
    assert state.velocity[1] == pytest.approx(1.5, abs=0.3)
    assert np.linalg.norm(state.position - (0.0, 1.5)) < 0.3


def test_a_velocity_within_its_noise_of_zero_is_left_out_of_a_first_measurement() -> None:
    cov = np.eye(2)
    still = Measurement.ground(0.0, (1.0, 2.0), CORE, (0.5, 0.5), cov)
    walking = Measurement.ground(0.0, (1.0, 2.0), CORE, (3.0, 0.0), cov)
    d2 = gate_threshold(0.95, 2)
    assert still.moving(d2).velocity is None and still.moving(d2).position_cov is CORE
    assert walking.moving(d2) is walking


def test_the_tail_is_the_wider_component() -> None:
    section = load_rig(SIM_RIG).estimator
    with pytest.raises(ValueError, match="wide component"):
        section.model_validate(
            {
                "mover_extent_noise": (0.1, 0.05),
                "mover_extent_tail": (0.25, 0.03),
                "mover_extent_tail_weight": 0.07,
            }
        )
    with pytest.raises(ValueError, match="share"):
        section.model_validate({"mover_extent_noise": (1.5, 0.05)})
