"""The IMM's noise adaptation: each track learns its position noise and process-noise scale."""

from __future__ import annotations

import numpy as np
import pytest

from gazed.config import EstimatorSection
from gazed.estimation import Measurement, build_estimator
from gazed.estimation.ground_imm import ImmEstimator
from gazed.estimation.noise_adaptation import NoiseAdaptation
from gazed.eval.scenario_reports import rounded_square_report

FLOOR_M2 = 1e-6  # the measurements' own covariance: almost nothing known
ADAPTIVE = EstimatorSection(adapt_noise=True)


def walk(
    seed: int, n: int, period_s: float, noise_m2: np.ndarray | float, scale: float = 0.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A walker at about 1 m/s moving as the CSD model says: each period a speed rate and a turn
    rate drawn with `scale` times the configured CSD variances, held over the period; measured
    with position variance noise_m2 (scalar or (n,))."""
    section = EstimatorSection()
    std = np.sqrt(scale) * np.array(
        [section.csd_speed_rate_noise_m_s2, section.csd_turn_rate_noise_rad_s]
    )
    rng = np.random.default_rng(seed)
    xy, speed, heading = np.zeros(2), 1.0, 0.0
    truth = np.empty((n, 2))
    T = period_s
    for k in range(n):
        truth[k] = xy
        speed_rate, turn_rate = rng.normal(0.0, 1.0, 2) * std
        middle = heading + turn_rate * T / 2
        xy = xy + (speed * T + speed_rate * T * T / 2) * np.array([np.cos(middle), np.sin(middle)])
        speed, heading = abs(speed + speed_rate * T), heading + turn_rate * T
    noise = np.sqrt(np.broadcast_to(noise_m2, (n,)))[:, None]
    return np.arange(n) * T, truth, truth + rng.normal(0.0, 1.0, truth.shape) * noise


def run(section: EstimatorSection, t: np.ndarray, z: np.ndarray) -> ImmEstimator:
    estimator = build_estimator(section)
    assert isinstance(estimator, ImmEstimator)
    for ti, zi in zip(t, z, strict=True):
        estimator.update(Measurement.ground(ti, zi, np.eye(2) * FLOOR_M2))
    return estimator


def prediction_error_m(
    section: EstimatorSection, t: np.ndarray, truth: np.ndarray, z: np.ndarray, ahead: int
) -> float:
    """Mean distance between the prediction `ahead` observations on and the true position; a
    filter that does not adapt is told the configured noise, as `gazed eval estimator` does."""
    estimator = build_estimator(section)
    R = np.eye(2) * (FLOOR_M2 if section.adapt_noise else section.position_noise_m**2)
    errors = []
    for k, (ti, zi) in enumerate(zip(t, z, strict=True)):
        estimator.update(Measurement.ground(ti, zi, R))
        if k >= 10 and k + ahead < len(t):
            p = estimator.predict(t[k + ahead])
            assert p is not None
            errors.append(np.linalg.norm(p.position - truth[k + ahead]))
    return float(np.mean(errors))


@pytest.mark.parametrize("noise_m2", [0.0025, 0.04])
def test_the_position_noise_converges_to_the_injected_noise(noise_m2: float) -> None:
    t, _, z = walk(1, 400, 0.1, noise_m2)
    estimator = run(ADAPTIVE, t, z)
    assert estimator.adaptation is not None
    assert estimator.adaptation.variance_m2()[0] == pytest.approx(noise_m2, rel=0.2)


def test_the_position_noise_follows_a_step_change() -> None:
    noise = np.where(np.arange(400) < 200, 0.0025, 0.04)
    t, _, z = walk(2, 400, 0.1, noise)
    section = ADAPTIVE
    before = run(section, t[:200], z[:200]).adaptation
    after = run(section, t, z).adaptation
    assert before is not None and after is not None
    assert before.variance_m2()[0] == pytest.approx(0.0025, rel=0.3)
    assert after.variance_m2()[0] == pytest.approx(0.04, rel=0.3)


@pytest.mark.parametrize("injected", [0.25, 4.0])
def test_the_process_noise_scale_converges_to_the_injected_scale(injected: float) -> None:
    """A walker whose process noise is `injected` times the configured one: λ̂, averaged (in
    logarithms) over the track after its first 200 observations, is within a factor of two of
    it. (The IMM's CS and CD models add noise of their own, so λ̂ sits somewhat below.)"""
    t, _, z = walk(2, 800, 0.1, 1e-4, injected)
    estimator = build_estimator(ADAPTIVE)
    assert isinstance(estimator, ImmEstimator) and estimator.adaptation is not None
    logs = []
    for k, (ti, zi) in enumerate(zip(t, z, strict=True)):
        estimator.update(Measurement.ground(ti, zi, np.eye(2) * FLOOR_M2))
        if k >= 200:
            logs.append(np.log(estimator.adaptation.q_scale()[0]))
    assert injected / 2 <= np.exp(np.mean(logs)) <= injected * 2


def test_the_process_noise_scale_stays_within_its_bounds() -> None:
    section = ADAPTIVE
    bound = section.process_noise_scale_max
    for injected in (1e-4, 1000.0):
        t, _, z = walk(3, 400, 0.1, 1e-4, injected)
        adaptation = run(section, t, z).adaptation
        assert adaptation is not None
        assert 1.0 / bound - 1e-9 <= adaptation.q_scale()[0] <= bound + 1e-9


def test_adaptation_beats_the_fixed_noise_on_a_clean_track_and_not_worse_on_a_noisy_one() -> None:
    adaptive, fixed = ADAPTIVE, EstimatorSection(adapt_noise=False)
    t, truth, z = walk(4, 300, 0.1, 1e-6, 4.0)
    clean = [prediction_error_m(s, t, truth, z, 4) for s in (adaptive, fixed)]
    assert clean[0] < 0.7 * clean[1]
    t, truth, z = walk(5, 300, 0.1, adaptive.position_noise_m**2, 4.0)
    noisy = [prediction_error_m(s, t, truth, z, 4) for s in (adaptive, fixed)]
    assert noisy[0] <= 1.1 * noisy[1]


def test_model_probabilities_still_switch_on_the_turns() -> None:
    report = rounded_square_report(ADAPTIVE, 0, None)
    for segment in report["true_segments"]:
        p = segment["mean_probability"]
        assert max(p, key=p.__getitem__) == segment["model"]
    assert report["switch_delay_obs"]["median"] <= 12


def test_the_measurement_covariance_stays_a_floor() -> None:
    adaptation = NoiseAdaptation(
        2, prior_variance_m2=0.01, prior_obs=5, window_obs=25, scale_max=10
    )
    R = np.array([np.eye(2) * 0.04, np.eye(2) * 1e-4])
    used = adaptation.measurement_cov(slice(None), R)
    np.testing.assert_allclose(used[0], R[0])  # the geometry's is larger: kept
    np.testing.assert_allclose(used[1], np.eye(2) * 0.01)  # raised to the estimate


def test_bad_settings_are_refused() -> None:
    with pytest.raises(ValueError, match="noise adaptation"):
        NoiseAdaptation(1, prior_variance_m2=0.0, prior_obs=5, window_obs=25, scale_max=10)


def test_a_track_whose_noise_is_underestimated_recovers() -> None:
    """Noise three times the prior's std, a floor of nothing: the gated innovations still count,
    so the estimate finds the noise and the track is not restarted."""
    t, _, z = walk(6, 300, 0.1, 0.09)
    estimator = run(ADAPTIVE, t, z)
    assert estimator.adaptation is not None
    assert estimator.adaptation.variance_m2()[0] == pytest.approx(0.09, rel=0.25)
    assert estimator.health()["reinitialised"] == 0


def test_a_restarted_track_starts_from_the_prior() -> None:
    section = ADAPTIVE
    t, _, z = walk(7, 200, 0.1, 0.04)
    estimator = run(section, t, z)
    adaptation = estimator.adaptation
    assert adaptation is not None
    assert adaptation.variance_m2()[0] == pytest.approx(0.04, rel=0.3)
    later = t[-1] + 2 * section.coast_max_ms / 1000.0  # past the coast limit: a new track
    for dt_s, xy in ((0.0, z[-1]), (0.1, z[-1] + 0.1)):
        estimator.update(Measurement.ground(later + dt_s, xy, np.eye(2) * FLOOR_M2))
    assert adaptation.variance_m2()[0] == pytest.approx(section.position_noise_m**2)
    assert adaptation.q_scale()[0] == 1.0


def test_outliers_move_neither_estimate() -> None:
    t, _, z = walk(8, 200, 0.1, 0.0025)
    estimator = run(ADAPTIVE, t, z)
    adaptation = estimator.adaptation
    assert adaptation is not None
    before = adaptation.variance_m2()[0], adaptation.q_scale()[0]
    for k in range(1, 4):  # three detections of something 5 m away
        estimator.update(Measurement.ground(t[-1] + 0.1 * k, z[-1] + 5.0, np.eye(2) * FLOOR_M2))
    assert estimator.health()["gated"] == 3
    assert (adaptation.variance_m2()[0], adaptation.q_scale()[0]) == before


def test_the_default_imm_keeps_its_configured_noise() -> None:
    """Adaptation is opt-in: the default IMM has none and uses each measurement's covariance."""
    estimator = build_estimator(EstimatorSection())
    assert isinstance(estimator, ImmEstimator) and estimator.adaptation is None
