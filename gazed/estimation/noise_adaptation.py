"""Each track's measurement noise and process-noise scale, learnt from its own innovations.

Two per-track estimates, both recursive over an exponentially fading window of
`window_obs` observations (forgetting factor ρ = 1 - 1/window_obs) and both starting from a
prior worth `prior_obs` observations:

- **Measurement noise** r (m², the variance of each position axis): the variational-Bayes
  adaptive Kalman filter of Särkkä & Nummenmaa (2009, IEEE TAC 54(3)), with an inverse-gamma
  density IG(α, β) on r. At each observation its prediction fades the evidence, α <- ρα,
  β <- ρβ, and its update adds the two axes: α += 1, β += ½(|ε|² + tr H P⁺ Hᵀ), with ε = z - H x⁺
  the residual after the update. The estimate is r̂ = β/α. The same statistic,
  E[εεᵀ] + H P⁺ Hᵀ = R, is the residual form of covariance matching (Myers & Tapley 1976, IEEE
  TAC 21(4)). One pass per observation replaces the paper's fixed-point iteration (its
  first iterate). The prior is IG(n₀, n₀ r₀): mean r₀ (`prior_variance_m2`), n₀ = prior_obs.
- **Process-noise scale** λ, a common factor on every model's Q: covariance matching of the
  innovation (Mehra 1972, IEEE TAC 17(5); the scale-factor form of Ding et al. 2007, J. Navigation
  60(3)). A consistent filter has E|ν|² = tr(H P⁻ Hᵀ) + tr R with ν = z - H x⁻, so each accepted
  observation proposes λ·(|ν|² - tr R) / tr(H P⁻ Hᵀ), the value that would make it consistent
  given the λ it was predicted with. λ̂ is the fading average of the proposals with the prior
  value 1 counted n₀ times, kept within [1/scale_max, scale_max]. A common factor leaves the
  ratios between the models' noises, which is what the IMM's model probabilities compare, as
  configured; the bound keeps one model from covering every maneuver with its noise.

The measurement's own covariance (the geometry's, in the live loop) is a floor: the filter
uses R + max(r̂ - tr R / 2, 0) I on the position block. Only the position components are
adapted; a measured velocity keeps its own covariance.
"""

from __future__ import annotations

import numpy as np

Index = slice | np.ndarray


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
        self.scale_bounds = (1.0 / scale_max, scale_max)
        self.alpha = np.full(n_tracks, prior_obs)
        self.beta = np.full(n_tracks, prior_obs * prior_variance_m2)
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

    def observe(
        self,
        idx: Index,
        innovation: np.ndarray,
        predicted_cov: np.ndarray,
        R: np.ndarray,
        residual: np.ndarray,
        updated_cov: np.ndarray,
    ) -> None:
        """One accepted observation of the tracks idx: the position innovation ν (K, 2) and the
        predicted covariance H P⁻ Hᵀ (K, 2, 2) it was judged with, the position block of R used
        (K, 2, 2), the residual ε (K, 2) and H P⁺ Hᵀ (K, 2, 2) after the update."""
        rho = self.forgetting
        predicted = np.trace(predicted_cov, axis1=1, axis2=2)
        energy = np.sum(innovation**2, axis=-1)
        # zero lag: E|ν|² = tr H P⁻ Hᵀ + tr R  ->  the measurement noise
        self.alpha[idx] = rho * self.alpha[idx] + 1.0
        self.beta[idx] = rho * self.beta[idx] + 0.5 * np.maximum(energy - predicted, 0.0)
        # lag one: white innovations (Mehra 1970) -> the process-noise scale
        lag = np.sum(innovation * self.previous[idx], axis=-1)
        self.energy[idx] = rho * self.energy[idx] + energy
        self.lag[idx] = rho * self.lag[idx] + lag
        self.previous[idx] = innovation
        correlation = self.lag[idx] / np.maximum(self.energy[idx], 1e-300)
        self.log_scale[idx] = np.clip(
            self.log_scale[idx] + correlation * (1.0 - rho) * 4, *np.log(self.scale_bounds)
        )
