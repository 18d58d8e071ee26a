"""Which measurement covariances a filter can take: finite, symmetric, positive definite.

Covariances R are 2x2 (position) or 4x4 (position and velocity), checked for a whole batch in
closed forms along the stack (a dozen array operations, where `np.linalg` would make one LAPACK
call per matrix). A 4x4 matrix is split into 2x2 blocks, S = [[A, B], [Bᵀ, D]]; it is positive
definite exactly when A and the Schur complement C = D - Bᵀ A⁻¹ B are. The stack is transposed
to (m, m, L), so that every operation runs along the L matrices.
"""

from __future__ import annotations

import numpy as np

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
