"""A track's appearance model: the template and the gamma distribution of its movers' distances
from it, fitted by moments, and the cost of a mover under it."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import gamma

from gazed.estimation.appearance_model import (
    INITIAL_MEAN,
    SMOOTHING,
    TrackAppearance,
    appearance_costs,
    fits,
)
from gazed.estimation.association import hellinger_squared

BINS = 64


def colours(seed: int) -> np.ndarray:
    return np.random.default_rng(seed).dirichlet(np.full(BINS, 0.5))


def test_the_cost_is_the_gamma_distributions_negative_log_density_above_its_mode() -> None:
    mean, shape = np.array([0.05, 0.08]), np.array([4.0, 2.5])
    h2 = np.array([[0.04, 0.1, 0.3], [0.05, 0.2, 0.6]])
    expected = -2.0 * gamma.logpdf(h2, shape[:, None], scale=(mean / shape)[:, None])
    assert np.allclose(appearance_costs(h2, mean, shape), expected)


def test_shape_one_is_the_exponential_distribution() -> None:
    mean, h2 = np.array([0.05]), np.array([[0.0, 0.02, 0.4]])
    expected = 2.0 * h2 / mean[:, None] + 2.0 * np.log(mean[:, None])
    assert np.allclose(appearance_costs(h2, mean, np.ones(1)), expected)


def test_below_the_mode_a_closer_match_costs_what_the_mode_costs() -> None:
    mean, shape = np.array([0.05]), np.array([5.0])
    mode = (shape - 1) / shape * mean  # (α - 1) θ
    h2 = np.array([[0.0, 0.01, float(mode[0]), 0.06, 0.1, 0.2]])
    costs = appearance_costs(h2, mean, shape)[0]
    assert np.isfinite(costs).all()
    assert costs[0] == pytest.approx(costs[1]) == pytest.approx(costs[2])
    assert np.all(np.diff(costs[2:]) > 0)


def test_a_track_whose_colours_hold_counts_an_unusual_mover_more_strongly() -> None:
    mean = np.full(2, 0.05)
    steady, varying = np.array([[8.0], [1.0]])
    costs = appearance_costs(np.array([[0.05, 0.2]] * 2), mean, np.array([steady[0], varying[0]]))
    excess = costs[:, 1] - costs[:, 0]  # a mover at four times the mean against one at it
    assert excess[0] > 2.0 * excess[1] > 0


def test_the_shape_is_one_until_the_moments_are_measured_then_their_fit() -> None:
    look = TrackAppearance(colours(0))
    assert look.shape == 1.0 and look.mean == INITIAL_MEAN
    look.mean, look.variance = 0.05, 0.05**2 / 6.0
    look.taken = round(1 / SMOOTHING) - 1
    assert look.shape == 1.0
    look.taken += 1
    assert look.shape == pytest.approx(6.0)
    look.variance = 1e-9  # as steady as can be: at most half the histogram's degrees of freedom
    assert look.shape == (BINS - 1) / 2
    look.variance = 1.0  # wilder than the exponential: the exponential
    assert look.shape == 1.0


def test_learning_a_persons_movers_measures_how_far_they_lie_from_their_colours() -> None:
    rng = np.random.default_rng(1)
    person = colours(2)
    seen = [rng.dirichlet(person * 300 + 0.05) for _ in range(200)]
    look = TrackAppearance(seen[0])
    for histogram in seen[1:]:
        look.take(histogram)
    truth = hellinger_squared(person[None], np.array(seen[-60:]))[0]
    assert look.mean == pytest.approx(float(truth.mean()), rel=0.4)
    assert look.shape > 3.0  # many bins differ a little: far from the exponential
    other = hellinger_squared(look.template[None], colours(3)[None])[0, 0]
    assert other > 5 * look.mean  # and another person's colours lie far off


def test_fits_stacks_the_tracks_and_leaves_nan_rows_for_those_without() -> None:
    look = TrackAppearance(colours(4))
    templates, means, shapes = fits([look, None, TrackAppearance(np.ones(8) / 8)], BINS)
    assert np.allclose(templates[0], look.template)
    assert np.isnan(templates[1:]).all()
    assert means[0] == look.mean and shapes[0] == look.shape
