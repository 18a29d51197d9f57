"""Whiteness of residual and innovation sequences.

The sample autocorrelation of a white sequence of ``n`` samples lies inside
``+-1.96 / sqrt(n)`` at 95 % of its non-zero lags; the fraction of lags inside that band is
the whiteness figure of filter innovations and of model residuals.
"""

from __future__ import annotations

import math

__all__ = ["WHITENESS_Z", "whiteness_band"]

#: The normal quantile of the two-sided 95 % band.
WHITENESS_Z = 1.96


def whiteness_band(n: int) -> float:
    """Half-width of the 95 % band of a white sequence's autocorrelation.

    Parameters
    ----------
    n : int
        Number of samples of the sequence (values below 1 count as 1).

    Returns
    -------
    float
        ``1.96 / sqrt(n)``.
    """
    return WHITENESS_Z / math.sqrt(max(int(n), 1))
