"""Batched Kalman filter algebra: every function takes a leading batch shape `(...)`.

The equations are the ones of seed 000 §4.1 and seed 003 eqs. (4)-(10); the update uses the
Joseph form so that P stays symmetric positive (semi-)definite whatever the gain.
Shapes: x (..., n), P (..., n, n), z and y (..., m), H (..., m, n), R (..., m, m), m = 2 or 4.
H P is computed once and shared by S and the gain.
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np

from gazed.estimation.small_matrices import inverse_and_log_det

LOG_2PI = math.log(2.0 * math.pi)


@cache
def identity(n: int) -> np.ndarray:
    """I (n, n), shared (read-only)."""
    eye = np.eye(n)
    eye.flags.writeable = False
    return eye


def symmetrize(P: np.ndarray) -> np.ndarray:
    """(P + Pᵀ) / 2 over the last two axes."""
    P_sym = P + P.mT
    P_sym *= 0.5
    return P_sym


def predict_covariance(P: np.ndarray, F: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """P(k+1|k) = F P(k|k) Fᵀ + Q   (seed 000 §4.1, seed 003 eq. 7)."""
    P_new = F @ P @ F.mT
    P_new += Q
    return symmetrize(P_new)


def innovation_covariance(
    P: np.ndarray, H: np.ndarray, R: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """H P (..., m, n) and S = H P Hᵀ + R   (seed 000 §4.1, seed 003 eq. 9)."""
    HP = H @ P
    S = HP @ H.mT
    S += R
    return HP, symmetrize(S)


def gaussian_terms(y: np.ndarray, S: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """S⁻¹, NIS = yᵀ S⁻¹ y and log N(y; 0, S) (the likelihood of seed 000 §5 step 3).

    Returns (S_inv (..., m, m), nis (...), log_likelihood (...)).
    """
    S_inv, log_det = inverse_and_log_det(S)
    nis = (y[..., None, :] @ S_inv @ y[..., :, None])[..., 0, 0]
    log_likelihood = nis + log_det
    log_likelihood += y.shape[-1] * LOG_2PI
    log_likelihood *= -0.5
    return S_inv, nis, log_likelihood


def joseph_update(
    x: np.ndarray,
    P: np.ndarray,
    y: np.ndarray,
    H: np.ndarray,
    R: np.ndarray,
    HP: np.ndarray,
    S_inv: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The measurement update for innovation y (H P and S⁻¹ given).

    K = P Hᵀ S⁻¹                                   (seed 003 eq. 10; the gain W of seed 000 §4.1)
    x(k+1|k+1) = x(k+1|k) + K y                    (eq. 4)
    P(k+1|k+1) = (I - K H) P (I - K H)ᵀ + K R Kᵀ   (Joseph form of eq. 8)
    computed with Kᵀ = S⁻¹ H P and (I - K H)ᵀ = I - Hᵀ Kᵀ, so that every batched product has
    its transposed operand on the left (see `ground_models.GroundModelBank`).
    """
    Kt = S_inv @ HP
    x_new = x + (y[..., None, :] @ Kt)[..., 0, :]
    I_KH_t = H.mT @ Kt
    np.subtract(identity(P.shape[-1]), I_KH_t, out=I_KH_t)
    P_new = I_KH_t.mT @ P @ I_KH_t
    P_new += Kt.mT @ R @ Kt
    return x_new, symmetrize(P_new)
