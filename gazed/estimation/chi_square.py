"""Chi-square quantiles for the gates and consistency tests, without scipy.

The thresholds are computed once per filter (a few per construction), so plain Python is
fast enough, and the slow `import scipy.stats` stays out of process start-up.

The upper tail of χ²(k) at x is the regularised incomplete gamma Q(k/2, x/2), evaluated by
its series below a + 1 and by its continued fraction above (Numerical Recipes §6.2), in
logarithms so that tails of 1e-300 and a thousand degrees of freedom stay finite.
"""

from __future__ import annotations

import math
from statistics import NormalDist

_TINY = 1e-300
_EPSILON = 1e-16


def log_upper_tail(x: float, dof: float) -> float:
    """log P(χ²(dof) > x) for x >= 0."""
    if x <= 0.0:
        return 0.0
    a, y = 0.5 * dof, 0.5 * x
    log_prefactor = a * math.log(y) - y - math.lgamma(a)
    if y < a + 1.0:  # series of the lower tail P(a, y), then Q = 1 - P
        n, term = a, 1.0 / a
        total = term
        while term > total * _EPSILON:
            n += 1.0
            term *= y / n
            total += term
        return math.log1p(-math.exp(log_prefactor + math.log(total)))
    # continued fraction of Q(a, y) (modified Lentz)
    b = y + 1.0 - a
    c = 1.0 / _TINY
    d = 1.0 / b
    h = d
    for i in range(1, 100_000):
        an = -i * (i - a)
        b += 2.0
        d = an * d + b
        d = _TINY if abs(d) < _TINY else d
        c = b + an / c
        c = _TINY if abs(c) < _TINY else c
        d = 1.0 / d
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < _EPSILON:
            break
    return log_prefactor + math.log(h)


def chi2_quantile(probability: float, dof: int) -> float:
    """x with P(χ²(dof) <= x) = probability, for 0 < probability < 1 and dof >= 1.

    Newton's method on log Q from the Wilson-Hilferty approximation; relative accuracy 1e-12.
    """
    if not 0.0 < probability < 1.0:
        raise ValueError(f"probability must be in (0, 1), got {probability}")
    if dof < 1:
        raise ValueError(f"degrees of freedom must be >= 1, got {dof}")
    log_q = math.log1p(-probability)
    z = NormalDist().inv_cdf(probability)
    h = 2.0 / (9.0 * dof)
    x = max(dof * (1.0 - h + z * math.sqrt(h)) ** 3, 1e-3)
    a = 0.5 * dof
    for _ in range(200):
        g = log_upper_tail(x, dof) - log_q
        # d log Q / dx = -pdf(x) / Q(x), pdf = x^(a-1) e^(-x/2) / (2^a Γ(a))
        log_pdf = (a - 1.0) * math.log(x) - 0.5 * x - a * math.log(2.0) - math.lgamma(a)
        slope = -math.exp(log_pdf - log_upper_tail(x, dof))
        step = g / slope
        x_next = x - step
        x_next = 0.5 * x if x_next <= 0.0 else x_next
        if abs(x_next - x) <= 1e-13 * x:
            return x_next
        x = x_next
    return x
