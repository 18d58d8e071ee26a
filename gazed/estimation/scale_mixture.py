"""A mover's point as a two-Gaussian scale mixture: most movers' points lie close to their
person, a few far off (a mask that splits, merges, or shows a part of its person).

Measured against annotated walkers (`tests/bench/mover_extent.py`) the offset of a mask's
centroid from its person, over the mask's box, is far from one Gaussian: its std is several
times its MAD-based std, most of all along v, the image axis that maps onto the ground's range.
One Gaussian of that std widens every mover's gate and shrinks every mover's weight to the
few's; one of the MAD-based std puts the few outside every gate. The model that fits both is a
mixture of a core R_c (weight 1 - ε) and a tail R_t (weight ε) on one point, both taken to the
filter's plane by the geometry's Jacobian (West, "Outlier models and prior distributions in
Bayesian linear regression", JRSS B 46(3), 1984; Bar-Shalom, Willett & Tian, "Tracking and Data
Fusion", 2011, §2.3 for the gate):

- association: a pair's cost is the mixture's negative log-likelihood, doubled and without
  constants, `-2 ln((1 - ε) N(ν; 0, S_c) + ε N(ν; 0, S_t))` with `S = P + R` (`pair_costs` of
  each component, the appearance term common to both), and the gate is the tail's: a mover off
  by the tail's spread is still a candidate, but costs what its rarity says;
- update: the filter takes the point with the precision expected under the posterior of the
  two components given the innovation, `R⁻¹ = (1 - w) R_c⁻¹ + w R_t⁻¹`, `w` the tail's
  posterior probability (the E-step of the EM treatment of scale mixtures, Dempster, Laird &
  Rubin 1977, as in robust Kalman filters with heavy-tailed noise, Agamennoni, Nieto & Nebot,
  IEEE TSP 60(2), 2012): a point that agrees with the prediction is taken at the core's
  precision, one far off along range at the tail's, and a new track's first point at the
  prior's (w = ε).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from gazed.estimation.association import pair_costs
from gazed.estimation.measurement import Measurement
from gazed.estimation.results import PredictedState


def mixture_costs(
    predicted: np.ndarray,
    P: np.ndarray,
    measured: np.ndarray,
    core_R: np.ndarray,
    tail_R: np.ndarray,
    tail_weight: np.ndarray,
    gate_d2: float,
    *looks: np.ndarray,
) -> np.ndarray:
    """(T, D) costs of the predictions (T, m) with covariances P (T, m, m) against the points
    (D, m) with their core and tail covariances (D, m, m) and tail weights (D,) (0: the core
    alone), inf where the d² of the tail (of the core where ε = 0) is outside the gate; `looks`
    as `pair_costs` takes them."""
    S_core = P[:, None] + core_R[None, :]
    eps = np.asarray(tail_weight, dtype=float)[None, :]
    if not (eps > 0).any():  # one Gaussian for every point: the core's costs alone
        return pair_costs(predicted, S_core, measured, gate_d2, *looks)
    S_tail = P[:, None] + tail_R[None, :]
    core = pair_costs(predicted, S_core, measured, math.inf, *looks)
    tail = pair_costs(predicted, S_tail, measured, gate_d2, *looks)
    with np.errstate(divide="ignore"):
        mixed = -2.0 * np.logaddexp(np.log1p(-eps) - core / 2.0, np.log(eps) - tail / 2.0)
    mixed = np.where(np.isfinite(tail), mixed, np.inf)
    if (eps > 0).all():
        return mixed
    alone = pair_costs(predicted, S_core, measured, gate_d2, *looks)  # ε = 0: one Gaussian
    return np.where(eps > 0, mixed, alone)


def tail_posterior(
    innovation: np.ndarray, S_core: np.ndarray, S_tail: np.ndarray, tail_weight: float
) -> float:
    """The tail's posterior probability given one innovation (m,) and each component's
    innovation covariance (m, m)."""
    if tail_weight <= 0.0:
        return 0.0
    logs = []
    for S in (S_core, S_tail):
        sign, log_det = np.linalg.slogdet(S)
        if sign <= 0:
            return 1.0  # a core without spread explains nothing
        logs.append(-0.5 * (float(innovation @ np.linalg.solve(S, innovation)) + log_det))
    core, tail = math.log1p(-tail_weight) + logs[0], math.log(tail_weight) + logs[1]
    return 1.0 / (1.0 + math.exp(min(core - tail, 700.0)))


def expected_precision(
    measurement: Measurement,
    tail_cov: np.ndarray | None,
    tail_weight: float,
    predicted: PredictedState | None,
) -> Measurement:
    """The measurement with its position's covariance `((1 - w) R_c⁻¹ + w R_t⁻¹)⁻¹`: w the
    tail's posterior against `predicted` (its position and covariance), or its prior
    `tail_weight` without a prediction (a new track). Unchanged without a tail."""
    if tail_cov is None or tail_weight <= 0.0:
        return measurement
    R_core = measurement.position_cov
    w = tail_weight
    if predicted is not None:
        P = predicted.covariance[:2, :2]
        innovation = measurement.position - predicted.position
        w = tail_posterior(innovation, P + R_core, P + tail_cov, tail_weight)
    precision = (1.0 - w) * np.linalg.inv(R_core) + w * np.linalg.inv(tail_cov)
    R = np.linalg.inv(precision)
    return replace(measurement, position_cov=(R + R.T) / 2.0)
