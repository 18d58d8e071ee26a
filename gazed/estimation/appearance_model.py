"""A track's appearance: a template of its movers' histograms, and how far its own movers lie
from it.

The template is the exponentially weighted mean of the histograms (`gazed.vision.appearance`)
the track has taken. How far a new mover of the same person lies from it, h² (the squared
Hellinger distance, `association.hellinger_squared`), is a sum of many small differences, one
per bin, so it is modelled as a gamma distribution (a scaled χ² of as many degrees of freedom as
the differences effectively have), fitted to the track's own distances by their moments: the
running mean m and variance of h² give the shape α = m² / var and the scale θ = var / m. The
shape is at least 1 (the exponential distribution, the loosest) and at most half the
histogram's degrees of freedom, (bins - 1) / 2 (a χ² cannot have more than the bins that
differ). A new track starts at α = 1 and `INITIAL_MEAN`, until its own movers measure it.

The cost of pairing a mover with the track is that distribution's negative log-likelihood,
doubled, in the unit of the positions' d² (`association.pair_costs`):
`-2 ln p(h²) = 2 h² / θ - 2 (α - 1) ln h² + 2 α ln θ + 2 ln Γ(α)`, from the distribution's mode
up; a mover closer than the mode costs what the mode costs, as a closer match than usual is no
evidence against the pairing. A track whose colours hold (α large: its distances gather about
their mean) counts a mover well past its usual distance as strongly against it; one whose
colours vary (a turning body, changing light, α near 1) counts it loosely.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

SMOOTHING = 0.1  # weight of each new mover in the template and the moments
INITIAL_MEAN = 0.05  # a new track's mean h², until its movers measure it
MEAN_FLOOR = 0.01  # a mean never below this: one colour change is not a different person


@dataclass
class TrackAppearance:
    """The template (B,), summing to 1, and the running mean and variance of h² against it over
    the `taken` movers since it started."""

    template: np.ndarray
    mean: float = INITIAL_MEAN
    variance: float = INITIAL_MEAN**2  # shape 1 at the start
    taken: int = 0

    @property
    def shape(self) -> float:
        """α = m² / var, between 1 and (bins - 1) / 2; 1 until the track has taken as many movers
        as its running moments weigh (1 / SMOOTHING)."""
        if self.taken * SMOOTHING < 1.0:
            return 1.0
        alpha = self.mean**2 / max(self.variance, 1e-12)
        return min(max(alpha, 1.0), (len(self.template) - 1) / 2.0)

    def take(self, histogram: np.ndarray) -> None:
        """Move the template toward a mover's histogram, and the moments toward its h²: at the
        rate 1 / (n + 1) for the n-th (the start counting as one) until that falls to
        SMOOTHING, then at SMOOTHING (an exponentially weighted mean and variance)."""
        h2 = max(0.0, 1.0 - float(np.sqrt(self.template * histogram).sum()))
        self.taken += 1
        rate = max(1.0 / (self.taken + 1), SMOOTHING)
        step = h2 - self.mean
        self.mean = max(MEAN_FLOOR, self.mean + rate * step)
        self.variance = (1 - rate) * (self.variance + rate * step * step)
        template = (1 - rate) * self.template + rate * histogram
        self.template = template / template.sum()


def appearance_costs(h2: np.ndarray, mean: np.ndarray, shape: np.ndarray) -> np.ndarray:
    """(T, D) costs `-2 ln p(h²)` of the distances h² (T, D) under each track's gamma
    distribution of mean (T,) and shape (T,), constant below its mode (module docstring)."""
    alpha = shape[:, None]
    theta = (mean / shape)[:, None]
    at = np.maximum(h2, (alpha - 1.0) * theta)  # the mode, (α - 1) θ
    with np.errstate(divide="ignore", invalid="ignore"):
        log_at = np.where(alpha > 1.0, np.log(at), 0.0)  # α = 1: the term vanishes
    log_gamma = np.array([math.lgamma(a) for a in shape])[:, None]
    return 2.0 * (at / theta - (alpha - 1.0) * log_at + alpha * np.log(theta) + log_gamma)


def fits(appearances: list[TrackAppearance | None], bins: int) -> tuple[np.ndarray, ...]:
    """The tracks' templates (T, bins), means (T,) and shapes (T,): NaN rows for a track without
    one of `bins` bins."""
    templates = np.full((len(appearances), bins), math.nan)
    means, shapes = np.ones(len(appearances)), np.ones(len(appearances))
    for k, look in enumerate(appearances):
        if look is not None and len(look.template) == bins:
            templates[k], means[k], shapes[k] = look.template, look.mean, look.shape
    return templates, means, shapes
