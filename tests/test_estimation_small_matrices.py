"""Closed forms for the 2x2 / 4x4 measurement-space matrices and the chi-square quantiles
that replace scipy: against numpy's LAPACK and scipy on seeded random cases."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from scipy.stats import chi2

from gazed.estimation.chi_square import chi2_quantile, log_upper_tail
from gazed.estimation.small_matrices import (
    LAPACK_MAX_MATRICES,
    closed_form_inverse_and_log_det,
    inverse_and_log_det,
    positive_definite,
)


def random_spd(
    rng: np.random.Generator, shape: tuple[int, ...], m: int, decades: float = 3.0
) -> np.ndarray:
    """Symmetric positive definite matrices with condition numbers up to 10^decades."""
    Q, _ = np.linalg.qr(rng.normal(size=(*shape, m, m)))
    eigenvalues = 10.0 ** rng.uniform(-decades / 2, decades / 2, size=(*shape, m))
    S = (Q * eigenvalues[..., None, :]) @ Q.mT
    return 0.5 * (S + S.mT)


@pytest.mark.parametrize("m", [2, 4])
@pytest.mark.parametrize("shape", [(1,), (3, 5), (400,)])
def test_closed_form_inverse_matches_lapack(m: int, shape: tuple[int, ...]) -> None:
    S = random_spd(np.random.default_rng(m), shape, m)
    S_inv, log_det = closed_form_inverse_and_log_det(S)
    assert S_inv.shape == S.shape and log_det.shape == shape
    np.testing.assert_allclose(S_inv @ S, np.broadcast_to(np.eye(m), S.shape), atol=1e-10)
    np.testing.assert_allclose(S_inv, np.linalg.inv(S), rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(log_det, np.linalg.slogdet(S)[1], rtol=1e-12, atol=1e-12)


def test_closed_form_inverse_of_ill_conditioned_matrices() -> None:
    """Condition numbers up to 1e6: every entry within 1e-6 of the largest of LAPACK's
    inverse (the block elimination has no pivoting and loses up to about three more digits
    than LAPACK there: 1.2e-7 measured on these; the filters' S are far better conditioned)."""
    S = random_spd(np.random.default_rng(5), (2000,), 4, decades=6.0)
    assert np.linalg.cond(S).max() > 1e5
    S_inv, log_det = closed_form_inverse_and_log_det(S)
    reference = np.linalg.inv(S)
    scale = np.abs(reference).max(axis=(-1, -2), keepdims=True)
    assert (np.abs(S_inv - reference) / scale).max() < 1e-6
    np.testing.assert_allclose(log_det, np.linalg.slogdet(S)[1], atol=1e-6)


@pytest.mark.parametrize("m", [2, 4])
def test_both_inverse_paths_agree(m: int) -> None:
    """A stack small enough for LAPACK and one that takes the closed forms give the same
    matrices (the single-track and the batch path of every filter)."""
    S = random_spd(np.random.default_rng(7), (LAPACK_MAX_MATRICES + 1,), m)
    small_inv, small_log_det = inverse_and_log_det(S[:3])
    large_inv, large_log_det = inverse_and_log_det(S)
    np.testing.assert_allclose(large_inv[:3], small_inv, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(large_log_det[:3], small_log_det, rtol=1e-10, atol=1e-10)


def test_singular_matrix_gives_non_finite_values_not_an_exception() -> None:
    S = np.zeros((2, 4, 4))
    S[1] = np.eye(4)
    S_inv, log_det = inverse_and_log_det(S)
    assert not np.isfinite(log_det[0]) and log_det[1] == 0.0
    np.testing.assert_allclose(S_inv[1], np.eye(4))


@pytest.mark.parametrize("m", [2, 4])
def test_positive_definite_agrees_with_eigenvalues(m: int) -> None:
    rng = np.random.default_rng(11)
    S = rng.normal(size=(500, m, m))
    S = 0.5 * (S + S.mT) + rng.uniform(-1.0, 3.0, size=(500, 1, 1)) * np.eye(m)
    expected = np.linalg.eigvalsh(S)[:, 0] > 0
    assert 0.2 < expected.mean() < 0.8  # both outcomes are exercised
    np.testing.assert_array_equal(positive_definite(S), expected)


def test_positive_definite_rejects_asymmetric_and_non_finite() -> None:
    R = np.tile(np.diag([0.01, 0.02, 0.3, 0.4]), (6, 1, 1))
    R[1, 0, 3] += 1e-6  # asymmetric beyond 1e-9 relative
    R[2, 0, 3] = R[2, 3, 0] = 1e-3  # symmetric, still definite
    R[3, 2, 2] = math.nan
    R[4, 1, 1] = math.inf
    R[5, 0, 2] += 1e-12  # asymmetric below the tolerance
    np.testing.assert_array_equal(positive_definite(R), [True, False, True, False, False, True])


@pytest.mark.parametrize("probability", [0.5, 0.9, 0.99, 0.999, 0.99999999])
def test_chi_square_quantile_matches_scipy(probability: float) -> None:
    for dof in [*range(1, 41), 100, 399, 4000]:
        assert chi2_quantile(probability, dof) == pytest.approx(
            chi2.ppf(probability, dof), rel=1e-11
        )


def test_chi_square_upper_tail_matches_scipy_far_out() -> None:
    for dof, x in [(2, 50.0), (4, 700.0), (40, 10.0), (1000, 1100.0)]:
        assert log_upper_tail(x, dof) == pytest.approx(chi2.logsf(x, dof), rel=1e-10)
    with pytest.raises(ValueError, match="probability"):
        chi2_quantile(1.0, 2)
    with pytest.raises(ValueError, match="degrees"):
        chi2_quantile(0.5, 0)


def test_estimation_does_not_import_scipy() -> None:
    """scipy.stats takes about a second to import: process start-up stays without it."""
    code = "import sys, gazed.estimation; print('scipy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
