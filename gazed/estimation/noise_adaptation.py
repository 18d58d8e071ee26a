"""Each track's measurement noise and process-noise scale, learnt from its own innovations.

A consistent filter's innovations ν = z - H x⁻ are white with covariance H P⁻ Hᵀ + R (Mehra
1970, IEEE TAC 15(2); 1972, IEEE TAC 17(5)). The two conditions give two per-track estimates,
both over an exponentially fading window of `window_obs` observations (forgetting factor
ρ = 1 - 1/window_obs), on the position components:

- **Measurement noise** r (m², the variance of each position axis), from the zero lag:
  covariance matching of the innovation, R̂ = E[ννᵀ] - H P⁻ Hᵀ (Myers & Tapley 1976, IEEE TAC
  21(4)), kept in the conjugate inverse-gamma form of the variational-Bayes adaptive filter
  (Särkkä & Nummenmaa 2009, IEEE TAC 54(3)): r ~ IG(α, β), each observation fades the
  evidence, α <- ρα, β <- ρβ (their heuristic dynamics), and adds its two axes, α += 1,
  β += ½ max(|ν|² - tr H P⁻ Hᵀ, 0); r̂ = β/α. The prior IG(n₀, n₀ r₀) has the mean r₀
  (`prior_variance_m2`) and the weight of n₀ = `prior_obs` observations. A noise cannot be
  negative: each observation's share is clipped at 0, which errs towards more smoothing where
  the models predict more spread than the innovations show.
- **Process-noise scale** λ, a common factor on every model's Q, from the lag one: a filter
  whose process noise is too small lags, and its successive innovations correlate positively;
  one whose process noise is too large overshoots, and they alternate. c₁ = Σ ν_k·ν_{k-1} /
  Σ |ν_k|² (both fading) is their lag-one correlation coefficient, and log λ moves by
  c₁ · SCALE_RATE / window_obs per observation towards white innovations (a stochastic
  approximation of Mehra's whiteness condition), within [1/scale_max, scale_max]. A common
  factor leaves the ratios between the models' noises, which the IMM's model probabilities
  compare, as configured; the bound keeps the noise from covering every maneuver. Smooth,
  correlated accelerations (a walker's gait) keep c₁ positive at any λ, so on clean tracks λ
  rests on its upper bound.

Only the innovations the chi-square gate accepts are evidence: an outlier (a detection of
something else) moves neither estimate, so it cannot widen the gate for the next one. The prior
in a track's first covariance (`start_cov`) keeps a track whose noise exceeds the floor inside
its gate while the estimate grows.

The measurement's own covariance (the geometry's, in the live loop) is a floor: the filter
uses R + max(r̂ - tr R / 2, 0) I on the position block. A measured velocity keeps its own
covariance.
"""

from __future__ import annotations

import numpy as np

Index = slice | np.ndarray

# windows over which a fully correlated innovation sequence changes λ by a factor e: a quarter
SCALE_RATE = 4.0


class NoiseAdaptation:
    """The per-track estimates r̂ (m²) and λ for n_tracks tracks; see the module docstring."""

    def __init__(
        self,
        n_tracks: int,
        *,
        prior_variance_m2: float,
        prior_obs: float,
        window_obs: float,
        scale_max: float,
    ) -> None:
        if not (prior_variance_m2 > 0 and prior_obs > 0 and window_obs >= 1 and scale_max >= 1):
            raise ValueError(
                "noise adaptation needs a prior variance > 0, prior_obs > 0, window_obs >= 1 "
                f"and scale_max >= 1, got {prior_variance_m2}, {prior_obs}, {window_obs}, "
                f"{scale_max}"
            )
        self.prior_variance_m2 = prior_variance_m2
        self.prior_obs = prior_obs
        self.forgetting = 1.0 - 1.0 / window_obs
        self.log_scale_bounds = (-np.log(scale_max), np.log(scale_max))
        self.alpha = np.full(n_tracks, prior_obs)
        self.beta = np.full(n_tracks, prior_obs * prior_variance_m2)
        # the lag-one sums start from the prior's innovation energy, uncorrelated, so that the
        # first few innovations do not swing λ
        self.previous = np.zeros((n_tracks, 2))
        self.energy = np.full(n_tracks, 2.0 * prior_obs * prior_variance_m2)
        self.lag = np.zeros(n_tracks)
        self.log_scale = np.zeros(n_tracks)

    def reset(self, idx: Index) -> None:
        """The tracks idx start again from the prior."""
        self.alpha[idx] = self.prior_obs
        self.beta[idx] = self.prior_obs * self.prior_variance_m2
        self.previous[idx] = 0.0
        self.energy[idx] = 2.0 * self.prior_obs * self.prior_variance_m2
        self.lag[idx] = 0.0
        self.log_scale[idx] = 0.0

    def variance_m2(self, idx: Index = slice(None)) -> np.ndarray:
        """r̂ (K,): the estimated variance of each position axis."""
        return self.beta[idx] / self.alpha[idx]

    def q_scale(self, idx: Index = slice(None)) -> np.ndarray:
        """λ̂ (K,): the factor on every model's process noise."""
        return np.exp(self.log_scale[idx])

    def measurement_cov(self, idx: Index, R: np.ndarray) -> np.ndarray:
        """The covariance (K, m, m) the filter uses: R with its position block raised to r̂ on
        average, never lowered."""
        position = R[:, :2, :2]
        extra = np.maximum(self.variance_m2(idx) - np.trace(position, axis1=1, axis2=2) / 2, 0.0)
        R = R.copy()
        R[:, 0, 0] += extra
        R[:, 1, 1] += extra
        return R

    def start_cov(self, Rv: np.ndarray, interval_s: np.ndarray) -> np.ndarray:
        """The covariance (K, 4, 4) of a track's first [p, v] with the prior noise r₀ as the
        floor of each position: a velocity from two positions dt apart (interval_s, NaN when
        the velocity was measured) shares it as v = (z1 - z0)/dt does."""
        extra = np.maximum(
            self.prior_variance_m2 - np.trace(Rv[:, :2, :2], axis1=1, axis2=2) / 2, 0
        )
        differenced = np.isfinite(interval_s)
        dt = np.where(differenced, interval_s, 1.0)
        cross = np.where(differenced, extra / dt, 0.0)
        velocity = np.where(differenced, 2.0 * extra / dt**2, 0.0)
        Rv = Rv.copy()
        for axis in (0, 1):
            Rv[:, axis, axis] += extra
            Rv[:, axis, axis + 2] += cross
            Rv[:, axis + 2, axis] += cross
            Rv[:, axis + 2, axis + 2] += velocity
        return Rv

    def observe(self, idx: Index, innovation: np.ndarray, predicted_m2: np.ndarray) -> None:
        """One accepted observation of the tracks idx: the position innovation ν (K, 2) and
        tr H P⁻ Hᵀ (K,) of its prediction."""
        rho = self.forgetting
        energy = np.einsum("ki,ki->k", innovation, innovation)
        # zero lag: E|ν|² = tr H P⁻ Hᵀ + tr R  ->  the measurement noise
        self.alpha[idx] = rho * self.alpha[idx] + 1.0
        self.beta[idx] = rho * self.beta[idx] + 0.5 * np.maximum(energy - predicted_m2, 0.0)
        # lag one: white innovations (Mehra 1970) -> the process-noise scale
        lag = np.einsum("ki,ki->k", innovation, self.previous[idx])
        self.previous[idx] = innovation
        energy = self.energy[idx] = rho * self.energy[idx] + energy
        lag = self.lag[idx] = rho * self.lag[idx] + lag
        step = SCALE_RATE * (1.0 - rho) * lag / energy
        self.log_scale[idx] = np.clip(self.log_scale[idx] + step, *self.log_scale_bounds)
