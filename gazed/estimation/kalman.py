"""Batched Kalman filter algebra: every function takes a leading batch shape `(...)`.

The equations are the ones of seed 000 §4.1 and seed 003 eqs. (4)-(10); the update uses the
Joseph form so that P stays symmetric positive (semi-)definite whatever the gain.
Shapes: x (..., n), P (..., n, n), z and y (..., m), H (..., m, n), R (..., m, m).
"""

from __future__ import annotations

import math

import numpy as np

LOG_2PI = math.log(2.0 * math.pi)


def symmetrize(P: np.ndarray) -> np.ndarray:
    """(P + Pᵀ) / 2 over the last two axes."""
    return 0.5 * (P + P.mT)


def predict_covariance(P: np.ndarray, F: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """P(k+1|k) = F P(k|k) Fᵀ + Q   (seed 000 §4.1, seed 003 eq. 7)."""
    return symmetrize(F @ P @ F.mT + Q)


def innovation_covariance(P: np.ndarray, H: np.ndarray, R: np.ndarray) -> np.ndarray:
    """S = H P Hᵀ + R   (seed 000 §4.1, seed 003 eq. 9)."""
    return symmetrize(H @ P @ H.mT + R)


def gaussian_terms(y: np.ndarray, S: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """S⁻¹, NIS = yᵀ S⁻¹ y and log N(y; 0, S) (the likelihood of seed 000 §5 step 3).

    Returns (S_inv (..., m, m), nis (...), log_likelihood (...)).
    """
    S_inv = np.linalg.inv(S)
    log_det = np.linalg.slogdet(S)[1]
    nis = (y[..., None, :] @ S_inv @ y[..., :, None])[..., 0, 0]
    return S_inv, nis, -0.5 * (nis + log_det + y.shape[-1] * LOG_2PI)


def joseph_update(
    x: np.ndarray,
    P: np.ndarray,
    y: np.ndarray,
    H: np.ndarray,
    R: np.ndarray,
    S_inv: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The measurement update for innovation y (S⁻¹ given).

    K = P Hᵀ S⁻¹                                   (seed 003 eq. 10; the gain W of seed 000 §4.1)
    x(k+1|k+1) = x(k+1|k) + K y                    (eq. 4)
    P(k+1|k+1) = (I - K H) P (I - K H)ᵀ + K R Kᵀ   (Joseph form of eq. 8)
    """
    K = P @ H.mT @ S_inv
    x_new = x + (K @ y[..., None])[..., 0]
    I_KH = np.eye(P.shape[-1]) - K @ H
    return x_new, symmetrize(I_KH @ P @ I_KH.mT + K @ R @ K.mT)
