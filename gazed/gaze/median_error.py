"""A median and its standard error, robust to a minority of wild values (the zoom's sizes)."""

from __future__ import annotations

import math

import numpy as np


def median_and_error(values: np.ndarray) -> tuple[float, float]:
    """The median of `values` and its standard error: their median absolute deviation times
    1.4826 for a standard deviation (that of a normal sample), times a median's 1.2533 /
    sqrt(n)."""
    at = float(np.median(values))
    sigma = 1.4826 * float(np.median(np.abs(values - at)))
    return at, 1.2533 * sigma / math.sqrt(len(values))
