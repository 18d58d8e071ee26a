"""`all` and `any` of a boolean mask, for the per-step checks of the filters.

`ndarray.all()` and `.any()` dispatch through Python-level wrappers (`numpy._core._methods`),
whose overhead dominates on a single track's few elements; `np.count_nonzero` is one C call,
and a step makes several such checks.
"""

from __future__ import annotations

import numpy as np


def every(mask: np.ndarray) -> bool:
    """True when every element of mask is true (True for an empty mask)."""
    return np.count_nonzero(mask) == mask.size


def some(mask: np.ndarray) -> bool:
    """True when any element of mask is true."""
    return np.count_nonzero(mask) > 0
