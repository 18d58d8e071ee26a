"""Whether a track can be another track's person by their appearance: the gate a continuation
takes besides the ground's (`target_choice`'s docstring says when).

A track's appearance (`TrackLook`) is the template of the colour histograms it has taken and
the gamma distribution that its own movers' squared Hellinger distances h² to it follow
(`gazed.estimation.appearance_model`). Another track's template is a mean of that track's
movers, so where it is the same person its h² to the first's template lies no further than one
of that person's movers does: it is tested against the first's distribution, and is not that
person where it lies in the distribution's upper tail beyond the gate's probability. Where it
passes, its cost is the distribution's `-2 ln p(h²)` above that of the distribution's mode, in
the unit of the ground's squared Mahalanobis distance (the estimator's association adds the
same term to its pairs' costs): 0 for a template as near as the person's own movers usually
lie, or nearer, and growing as it lies further. A track without an appearance, or with a
histogram of another length, is not judged by it: it costs 0, as a usual match does.
"""

from __future__ import annotations

import math

import numpy as np

from gazed.estimation.appearance_model import appearance_costs
from gazed.estimation.association import hellinger_squared
from gazed.estimation.chi_square import log_upper_tail
from gazed.messages import TrackLook


def look_cost(person: TrackLook | None, other: TrackLook | None, probability: float) -> float:
    """The cost of `other`'s template under `person`'s distribution above its mode's (module
    docstring): 0 where either has no appearance to compare, infinite beyond the gate of
    `probability`."""
    if person is None or other is None or len(person.template) != len(other.template):
        return 0.0
    h2 = hellinger_squared(np.array([person.template]), np.array([other.template]))
    if h2_upper_tail(float(h2[0, 0]), person.h2_mean, person.h2_shape) < 1.0 - probability:
        return math.inf
    mean, shape = np.array([person.h2_mean]), np.array([person.h2_shape])
    costs = appearance_costs(np.array([[h2[0, 0], 0.0]]), mean, shape)  # 0: below the mode
    return float(costs[0, 0] - costs[0, 1])


def h2_upper_tail(h2: float, mean: float, shape: float) -> float:
    """P(h² > `h2`) under the gamma distribution of `mean` and `shape` α (scale θ = mean / α):
    that of χ² with 2α degrees of freedom beyond 2 h² / θ."""
    theta = mean / shape
    return math.exp(log_upper_tail(2.0 * h2 / theta, 2.0 * shape))
