"""Closed forms for the 2x2 and 4x4 symmetric matrices of the measurement space, batched.

Innovation covariances S and measurement covariances R are 2x2 (position) or 4x4 (position
and velocity). `np.linalg` loops over a batch one LAPACK call per matrix (about 1 µs each);
the closed forms below are a few dozen array operations on the whole stack, which wins from a
few dozen matrices on (for one track's three models, LAPACK is faster). A 4x4 matrix is split
into 2x2 blocks, S = [[A, B], [Bᵀ, D]], with the Schur complement C = D - Bᵀ A⁻¹ B:

    S⁻¹ = [[A⁻¹ + E Bᵀ A⁻¹, -E], [-Eᵀ, C⁻¹]],  E = A⁻¹ B C⁻¹,   det S = det A · det C,

and S is positive definite exactly when A and C are (no pivoting is needed for such S).
The closed forms work on the stack transposed to (m, m, L), so that every operation runs
along the L matrices (an operation over the two entries of a 2x2 row is mostly overhead).
"""

from __future__ import annotations

import numpy as np

# stacks of at most this many matrices are inverted by LAPACK (`inverse_and_log_det`)
LAPACK_MAX_MATRICES = 16

# adj([[a, b], [c, d]]) = [[d, -b], [-c, a]]: the matrix reversed on both axes, transposed,
# times this
_COFACTOR_SIGN = np.array([[1.0, -1.0], [-1.0, 1.0]])[:, :, None]


# flat indices of the entries above the diagonal and of their mirror images, per size
_UPPER = {m: np.array([i * m + j for i in range(m) for j in range(i + 1, m)]) for m in (2, 4)}
_LOWER = {m: np.array([j * m + i for i in range(m) for j in range(i + 1, m)]) for m in (2, 4)}


def _t(A: np.ndarray) -> np.ndarray:
    """Transpose of (2, 2, L) matrices."""
    return A.transpose(1, 0, 2)


def _det_2x2(A: np.ndarray) -> np.ndarray:
    return A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]


def _adjugate_2x2(A: np.ndarray) -> np.ndarray:
    return _t(A[::-1, ::-1]) * _COFACTOR_SIGN


def _matmul_2x2(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """A B for (2, 2, L) stacks, as two outer products along the stack."""
    return A[:, :1] * B[:1, :] + A[:, 1:] * B[1:, :]


def _entries_first(S: np.ndarray) -> np.ndarray:
    """(..., m, m) -> contiguous (m, m, L)."""
    m = S.shape[-1]
    return np.ascontiguousarray(S.reshape(-1, m, m).transpose(1, 2, 0))


def inverse_and_log_det(S: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """S⁻¹ (..., m, m) and log det S (...) of symmetric positive definite S, m = 2 or 4.

    Up to LAPACK_MAX_MATRICES matrices go to LAPACK (one call each for the inverse and the
    determinant beats the dozens of array operations below on a handful of matrices); larger
    stacks use the closed forms. Both are checked against each other in the tests.
    """
    if S.size <= LAPACK_MAX_MATRICES * S.shape[-1] ** 2:
        try:
            return np.linalg.inv(S), np.linalg.slogdet(S)[1]
        except np.linalg.LinAlgError:  # singular: inf / NaN from the closed forms, which no
            with np.errstate(all="ignore"):  # gate accepts
                return closed_form_inverse_and_log_det(S)
    return closed_form_inverse_and_log_det(S)


def closed_form_inverse_and_log_det(S: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`inverse_and_log_det` by the 2x2 block formulas of the module docstring."""
    St = _entries_first(S)
    if S.shape[-1] == 2:
        det = _det_2x2(St)
        S_inv = _adjugate_2x2(St) / det
    else:
        A, B, D = St[:2, :2], St[:2, 2:], St[2:, 2:]
        det_A = _det_2x2(A)
        A_inv = _adjugate_2x2(A) / det_A
        A_inv_B = _matmul_2x2(A_inv, B)
        C = D - _matmul_2x2(_t(B), A_inv_B)
        det_C = _det_2x2(C)
        C_inv = _adjugate_2x2(C) / det_C
        E = _matmul_2x2(A_inv_B, C_inv)
        S_inv = np.empty(St.shape)
        S_inv[:2, :2] = A_inv + _matmul_2x2(E, _t(A_inv_B))
        np.negative(E, out=S_inv[:2, 2:])
        np.negative(_t(E), out=S_inv[2:, :2])
        S_inv[2:, 2:] = C_inv
        det = det_A * det_C
    S_inv = np.ascontiguousarray(S_inv.transpose(2, 0, 1)).reshape(S.shape)
    return S_inv, np.log(det).reshape(S.shape[:-2])


def positive_definite(S: np.ndarray) -> np.ndarray:
    """(...) True where S (..., m, m), m = 2 or 4, is finite, symmetric (to 1e-9 relative) and
    positive definite.

    Sylvester's criterion on the blocks without a division: A ≻ 0 (a₀₀ > 0, det A > 0) and
    det A · C = det A · D - Bᵀ adj(A) B ≻ 0.
    """
    m = S.shape[-1]
    finite = np.isfinite(S).all(axis=(-1, -2))
    if not finite.all():
        S = np.where(finite[..., None, None], S, np.eye(m))
    # |S_ij - S_ji| <= 1e-9 (1 + |S_ij|) both ways, on the pairs above and below the diagonal
    flat = S.reshape(*S.shape[:-2], m * m)
    upper, lower = flat[..., _UPPER[m]], flat[..., _LOWER[m]]
    tolerance = 1e-9 * (1.0 + np.minimum(np.abs(upper), np.abs(lower)))
    symmetric = (np.abs(upper - lower) <= tolerance).all(axis=-1)
    St = _entries_first(S)
    A = St[:2, :2]
    det_A = _det_2x2(A)
    definite = (A[0, 0] > 0.0) & (det_A > 0.0)
    if S.shape[-1] == 4:
        B = St[:2, 2:]
        C_scaled = det_A * St[2:, 2:] - _matmul_2x2(_t(B), _matmul_2x2(_adjugate_2x2(A), B))
        definite &= (C_scaled[0, 0] > 0.0) & (_det_2x2(C_scaled) > 0.0)
    return finite & symmetric & definite.reshape(finite.shape)
