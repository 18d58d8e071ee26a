"""What every mode does with bad input: non-finite or non-positive-definite measurements,
out-of-order times, outliers (chi-square gate, re-initialisation), long coasts; covariances
stay symmetric positive definite; the common interface works the same for all modes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gazed.config import EstimatorSection
from gazed.estimation import FILTER_MODES, Measurement, Outcome, build_estimator

R = np.eye(2) * 0.05**2


def walk(estimator, steps=30, dt=0.1, speed=(1.0, 0.5), t0=0.0, noise_m=0.05) -> float:
    """A straight walk measured with position noise; returns the last time."""
    rng = np.random.default_rng(11)
    for k in range(steps):
        t = t0 + k * dt
        z = np.array(speed) * t + rng.normal(0, noise_m, 2)
        estimator.update(Measurement.ground(t, z, R))
    return t0 + (steps - 1) * dt


@pytest.mark.parametrize("mode", FILTER_MODES)
def test_common_interface(mode: str) -> None:
    estimator = build_estimator(EstimatorSection(), mode=mode)
    assert estimator.predict(0.0) is None and not estimator.tracking
    assert estimator.update(Measurement.ground(0.0, [0, 0], R)) == Outcome.PENDING
    held = estimator.predict(0.5)
    assert held is not None and np.allclose(held.position, 0) and np.allclose(held.velocity, 0)
    assert estimator.update(Measurement.ground(0.1, [0.1, 0.05], R)) == Outcome.INITIALISED
    t = walk(estimator, t0=0.2, noise_m=0.005)
    p = estimator.predict(t + 0.5)
    assert p is not None and p.covariance.shape == (4, 4)
    assert np.allclose(p.position, np.array([1.0, 0.5]) * (t + 0.5), atol=0.3)
    assert np.allclose(p.velocity, [1.0, 0.5], atol=0.4)
    probabilities = estimator.model_probabilities()
    assert set(probabilities) == set(estimator.model_names)
    assert sum(probabilities.values()) == pytest.approx(1.0)
    assert estimator.most_likely() in estimator.model_names
    assert estimator.coast(t + 0.1) == Outcome.COASTED
    assert estimator.health()["accepted"] == 30 and estimator.health()["coasted"] == 1
    assert isinstance(estimator.drain_events(), list)


@pytest.mark.parametrize("mode", FILTER_MODES)
@pytest.mark.parametrize(
    "bad",
    [
        Measurement.ground(4.0, [math.nan, 0.0], R),
        Measurement.ground(4.0, [0.0, math.inf], R),
        Measurement.ground(4.0, [0.0, 0.0], [[1.0, 0.0], [0.0, -1.0]]),  # not positive definite
        Measurement.ground(4.0, [0.0, 0.0], [[1.0, 2.0], [0.0, 1.0]]),  # not symmetric
        Measurement.ground(4.0, [0, 0], R, [math.nan, 0.0], R),
    ],
    ids=["nan", "inf", "indefinite", "asymmetric", "nan-velocity"],
)
def test_bad_measurements_are_rejected_and_counted(mode: str, bad: Measurement) -> None:
    estimator = build_estimator(EstimatorSection(), mode=mode)
    walk(estimator)
    before = estimator.predict(4.5)
    assert estimator.update(Measurement.ground(math.nan, [0, 0], R)) == Outcome.NONFINITE
    assert estimator.update(bad) == Outcome.NONFINITE
    assert estimator.health()["nonfinite"] == 2
    after = estimator.predict(4.5)  # the track coasted to t = 4: nothing absorbed
    assert after is not None and np.all(np.isfinite(after.position))
    np.testing.assert_allclose(after.position, before.position, atol=0.05)


@pytest.mark.parametrize("mode", FILTER_MODES)
def test_out_of_order_measurements_are_dropped(mode: str) -> None:
    estimator = build_estimator(EstimatorSection(), mode=mode)
    t = walk(estimator)
    before = estimator.predict(t + 0.2)
    assert estimator.update(Measurement.ground(t - 0.05, [50.0, 50.0], R)) == Outcome.OUT_OF_ORDER
    assert estimator.update(Measurement.ground(t, [50.0, 50.0], R)) == Outcome.OUT_OF_ORDER
    assert estimator.health()["out_of_order"] == 2
    np.testing.assert_array_equal(estimator.predict(t + 0.2).position, before.position)
    with pytest.raises(ValueError, match="before"):
        estimator.predict(t - 1.0)


@pytest.mark.parametrize("mode", FILTER_MODES)
def test_outlier_is_gated_then_a_real_jump_reinitialises(mode: str) -> None:
    settings = EstimatorSection(reinit_after_misses=3)
    estimator = build_estimator(settings, mode=mode)
    t = walk(estimator)
    expected = estimator.predict(t + 0.1).position
    assert estimator.update(Measurement.ground(t + 0.1, expected + 20.0, R)) == Outcome.GATED
    # the outlier was not absorbed: the track only coasted (mixing moves an IMM a hair)
    np.testing.assert_allclose(estimator.predict(t + 0.1).position, expected, atol=0.01)
    # the target really is elsewhere now: after 3 misses in a row the track restarts there
    outcomes = [
        estimator.update(Measurement.ground(t + 0.1 * k, [100.0, 100.0], R)) for k in (2, 3)
    ]
    assert outcomes == [Outcome.GATED, Outcome.REINITIALISED]
    assert estimator.update(Measurement.ground(t + 0.4, [100.0, 100.0], R)) == Outcome.INITIALISED
    p = estimator.predict(t + 0.5)
    np.testing.assert_allclose(p.position, [100.0, 100.0], atol=0.2)
    health = estimator.health()
    assert health["gated"] == 3 and health["reinitialised"] == 1


@pytest.mark.parametrize("mode", FILTER_MODES)
def test_long_coast_drops_the_track(mode: str) -> None:
    estimator = build_estimator(EstimatorSection(coast_max_ms=500.0), mode=mode)
    t = walk(estimator, steps=5)
    assert estimator.coast(t + 0.3) == Outcome.COASTED
    assert estimator.coast(t + 0.6) == Outcome.DROPPED
    assert not estimator.tracking and estimator.predict(t + 1.0) is None
    # a measurement after a long gap starts a new track instead of bridging the gap
    estimator2 = build_estimator(EstimatorSection(coast_max_ms=500.0), mode=mode)
    t = walk(estimator2, steps=5)
    assert estimator2.update(Measurement.ground(t + 5.0, [0, 0], R)) == Outcome.PENDING
    assert estimator2.health()["dropped"] == 1


@pytest.mark.parametrize("mode", ["imm", "innovation", "cv", "ca", "image-cv"])
def test_covariances_stay_symmetric_positive_definite(mode: str) -> None:
    """Long runs with velocity, tiny measurement noise and long coasts (the cases where the
    standard covariance update loses symmetry and definiteness)."""
    estimator = build_estimator(EstimatorSection(gate_probability=0.99999999), mode=mode)
    rng = np.random.default_rng(2)
    tiny = np.eye(2) * 1e-6
    for k in range(400):
        t = k * 0.04
        if k % 50 in (10, 11, 12, 13):
            estimator.coast(t)
            continue
        z = np.array([math.cos(t), math.sin(t)]) * 3 + rng.normal(0, 1e-3, 2)
        v = np.array([-math.sin(t), math.cos(t)]) * 3
        estimator.update(Measurement.ground(t, z, tiny, v, tiny))
        P = estimator.imm.P if mode == "imm" else estimator.P
        assert np.all(P.swapaxes(-1, -2) == P)
        eig = np.linalg.eigvalsh(P)
        assert eig.min() > -1e-9 * eig.max(), f"step {k}: {eig.min()}"
    assert estimator.health()["accepted"] >= 250


def test_batch_step_equals_independent_tracks() -> None:
    """One vectorised call for N tracks gives what N single-track estimators give."""
    rng = np.random.default_rng(4)
    n, steps = 5, 40
    section = EstimatorSection()
    batch = build_estimator(section, n_tracks=n, mode="imm")
    singles = [build_estimator(section, mode="imm") for _ in range(n)]
    for k in range(steps):
        t = np.full(n, k * 0.1)
        z = np.stack([np.array([1.0, 0.2 * i]) * k * 0.1 for i in range(n)]) + rng.normal(
            0, 0.05, (n, 2)
        )
        present = rng.random(n) > 0.2  # some tracks miss this frame
        batch.step(t, z, np.broadcast_to(R, (n, 2, 2)), present)
        for i, single in enumerate(singles):
            if present[i]:
                single.update(Measurement.ground(t[i], z[i], R))
            else:
                single.coast(t[i])
    f = batch.forecast(np.full(n, steps * 0.1))
    for i, single in enumerate(singles):
        p = single.predict(steps * 0.1)
        np.testing.assert_allclose(f.position[i], p.position, atol=1e-12)
        np.testing.assert_allclose(f.covariance[i], p.covariance, atol=1e-12)
        np.testing.assert_allclose(batch.probabilities[i], single.probabilities[0], atol=1e-12)


def test_a_still_target_starts_with_a_positive_semidefinite_covariance() -> None:
    """Two nearly coincident positions give a speed of ~0 and no direction: the heading's
    variance is capped at π² with its row and column scaled together (capping the variance
    alone made P indefinite and, on slow pedestrians, S singular a few steps later)."""
    estimator = build_estimator(EstimatorSection(), mode="imm")
    estimator.update(Measurement.ground(0.0, [1.0, 2.0], R))
    estimator.update(Measurement.ground(0.4, [1.01, 2.0], R))
    P = estimator.imm.P[0, 0]
    assert P[3, 3] == pytest.approx(math.pi**2)
    eigenvalues = np.linalg.eigvalsh(P)
    assert eigenvalues.min() >= -1e-12 * eigenvalues.max()
    assert P[1, 3] > 0.1  # the heading's correlation with the position is kept, scaled


def test_a_slow_wandering_target_keeps_the_filter_finite() -> None:
    """Position-only, 0.4 s steps, a walker creeping at a few cm/s (the case of the hotel
    file that produced NaN): covariances stay positive semi-definite and every state finite,
    in a single track and in a batch."""
    rng = np.random.default_rng(8)
    n = 8
    single = build_estimator(EstimatorSection(), mode="imm")
    batch = build_estimator(EstimatorSection(), n_tracks=n, mode="imm")
    position = np.zeros((n, 2))
    for k in range(120):
        position += rng.normal(0, 0.02, (n, 2))
        z = position + rng.normal(0, 0.05, (n, 2))
        single.update(Measurement.ground(0.4 * k, z[0], R))
        batch.step(np.full(n, 0.4 * k), z, np.broadcast_to(R, (n, 2, 2)))
    for estimator in (single, batch):
        assert np.isfinite(estimator.imm.x).all() and np.isfinite(estimator.imm.mu).all()
        eigenvalues = np.linalg.eigvalsh(estimator.imm.P)
        assert (eigenvalues.min(axis=-1) >= -1e-9 * eigenvalues.max(axis=-1)).all()
    assert single.health()["accepted"] >= 110


def test_a_batch_gives_the_single_track_results() -> None:
    """A batch steps every track as a single-track estimator does (one vectorised call over
    the tracks against the single track's own path)."""
    rng = np.random.default_rng(9)
    n, steps = 10, 30
    section = EstimatorSection()
    batch = build_estimator(section, n_tracks=n, mode="imm")
    singles = [build_estimator(section, mode="imm") for _ in range(n)]
    heading = rng.uniform(-math.pi, math.pi, n)
    for k in range(steps):
        t = k * 0.04
        direction = np.stack([np.cos(heading + 0.3 * t), np.sin(heading + 0.3 * t)], axis=-1)
        p = direction * t + rng.normal(0, 0.02, (n, 2))
        v = direction + rng.normal(0, 0.1, (n, 2))
        Rv = np.diag([0.02**2, 0.02**2, 0.1**2, 0.1**2])
        batch.step(np.full(n, t), np.concatenate([p, v], axis=-1), np.broadcast_to(Rv, (n, 4, 4)))
        for i, single in enumerate(singles):
            single.update(Measurement.ground(t, p[i], Rv[:2, :2], v[i], Rv[2:, 2:]))
    f = batch.forecast(np.full(n, steps * 0.04))
    for i, single in enumerate(singles):
        p = single.predict(steps * 0.04)
        np.testing.assert_allclose(f.position[i], p.position, rtol=1e-8, atol=1e-10)
        np.testing.assert_allclose(f.covariance[i], p.covariance, rtol=1e-6, atol=1e-12)
        np.testing.assert_allclose(batch.probabilities[i], single.probabilities[0], atol=1e-8)


@pytest.mark.parametrize(
    "bad",
    [
        Measurement.ground(1.0, [math.nan, 0.0], R),
        Measurement.ground(math.inf, [0.0, 0.0], R),
        Measurement.ground(1.0, [0.0, 0.0], [[1.0, 2.0], [0.0, 1.0]]),
        Measurement.ground(1.0, [0.0, 0.0], [[1.0, 0.0], [0.0, -1.0]]),
        Measurement.ground(1.0, [0.0, 0.0], R, [0.0, 0.0], [[1.0, 1.0], [1.0, 1.0]]),
        Measurement.ground(1.0, [0.0, 0.0], R, [0.0, math.inf], R),
        Measurement.ground(1.0, [0.0, 0.0], R, [0.0, 0.0], [[1.0, 1e-12], [0.0, 1.0]]),
        Measurement.ground(1.0, [0.0, 0.0], R, [0.3, 0.0], R),
    ],
)
def test_single_track_validation_agrees_with_the_batch_one(bad: Measurement) -> None:
    """`update` checks a measurement on its 2x2 blocks in plain Python; `step` checks the
    stacked arrays: both accept and reject the same measurements."""
    single = build_estimator(EstimatorSection(), mode="cv")
    batch = build_estimator(EstimatorSection(), mode="cv")
    outcome = single.update(bad)
    batch_outcome = batch.step(np.array([bad.t_s]), bad.z[None], bad.R[None])[0]
    assert outcome == batch_outcome
    assert (outcome == Outcome.NONFINITE) == (not bad.usable)
