"""The appearance gate of a continuation: the gamma tail against scipy's, the cost the
estimator's association gives (above its mode's), and no judgement without an appearance."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import gamma

from gazed.estimation.appearance_model import appearance_costs
from gazed.gaze.look_gate import h2_upper_tail, look_cost
from gazed.messages import TrackLook

PROBABILITY = 0.999


@pytest.mark.parametrize(
    ("h2", "mean", "shape"),
    [(0.1, 0.05, 1.0), (0.2, 0.05, 3.8), (0.05, 0.05, 2.5), (0.01, 0.05, 6.1), (0.9, 0.02, 31.5)],
)
def test_the_upper_tail_is_the_gamma_distributions(h2: float, mean: float, shape: float) -> None:
    expected = gamma.sf(h2, shape, scale=mean / shape)
    assert h2_upper_tail(h2, mean, shape) == pytest.approx(expected, rel=1e-9, abs=1e-300)


def look(template: np.ndarray, mean: float = 0.05, shape: float = 4.0) -> TrackLook:
    return TrackLook(
        template=tuple((template / template.sum()).tolist()), h2_mean=mean, h2_shape=shape
    )


def test_a_look_within_the_gate_costs_what_the_association_says() -> None:
    rng = np.random.default_rng(11)
    person = rng.dirichlet(np.full(64, 0.5))
    costs = []
    for away in (0.0, 0.3, 0.5):
        other = (1 - away) * person + away * rng.dirichlet(np.full(64, 0.5))
        h2 = 1.0 - np.sqrt(person * other / other.sum()).sum()
        assert h2_upper_tail(h2, 0.05, 4.0) > 1.0 - PROBABILITY
        cost = look_cost(look(person), look(other), PROBABILITY)
        both = appearance_costs(np.array([[h2, 0.0]]), np.array([0.05]), np.array([4.0]))
        assert cost == pytest.approx(both[0, 0] - both[0, 1], abs=1e-9)  # above the mode's
        costs.append(cost)
    assert costs[0] == pytest.approx(0.0, abs=1e-12)  # as near as the person's own movers
    assert 0.0 < costs[1] < costs[2]


def test_a_look_beyond_the_gate_is_not_the_person() -> None:
    rng = np.random.default_rng(12)
    person, other = rng.dirichlet(np.full(64, 0.5), size=2)
    h2 = 1.0 - np.sqrt(person * other).sum()
    assert h2_upper_tail(h2, 0.05, 4.0) < 1.0 - PROBABILITY
    assert look_cost(look(person), look(other), PROBABILITY) == math.inf
    # a person whose own movers vary as much is not told from them by it
    assert h2_upper_tail(h2, 0.3, 1.0) > 1.0 - PROBABILITY
    assert math.isfinite(look_cost(look(person, 0.3, 1.0), look(other), PROBABILITY))


def test_without_an_appearance_to_compare_nothing_is_judged() -> None:
    person = look(np.arange(1.0, 65.0))
    assert look_cost(person, None, PROBABILITY) == 0.0
    assert look_cost(None, person, PROBABILITY) == 0.0
    assert look_cost(person, look(np.arange(1.0, 33.0)), PROBABILITY) == 0.0  # another length
