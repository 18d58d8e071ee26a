"""The positive-definiteness check of measurement covariances and the chi-square quantiles
that replace scipy: against numpy's eigenvalues and scipy on seeded random cases."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from scipy.stats import chi2

from gazed.estimation.chi_square import chi2_quantile, log_upper_tail
from gazed.estimation.small_matrices import positive_definite


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
