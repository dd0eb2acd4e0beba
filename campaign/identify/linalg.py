"""Small dense solves of identification's inner loops through LAPACK without numpy's wrappers.

``numpy.linalg.solve`` and ``numpy.linalg.lstsq`` spend 15-25 us of Python per call on
argument handling, several times the LAPACK work on the 3 x 3 to 100 x 4 systems of the
F/T momentum balance and the tip-space fits, which call them once per sample or per
residual. The same LAPACK routines called directly (SciPy's wrappers) give the same
solutions to roundoff.
"""

from __future__ import annotations

import functools

import numpy as np


@functools.cache
def _lapack():
    """SciPy's LAPACK wrappers, imported on first use (scipy.linalg costs start-up time to
    jobs that never fit; identification has imported it with scipy.optimize by then)."""
    from scipy.linalg import lapack

    return lapack


def solve(H: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``numpy.linalg.solve(H, b)`` by the routine it calls (LU, dgesv); numpy's call (and
    its error) where dgesv reports a singular matrix."""
    _, _, x, info = _lapack().dgesv(H, b)
    return x if info == 0 else np.linalg.solve(H, b)


def lstsq(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The least-squares solution of ``A x = b`` (``A`` m x n, m >= n, full rank) by QR
    (dgels; ``numpy.linalg.lstsq``, an SVD, costs five times as much and agrees to
    roundoff); ``numpy.linalg.lstsq(A, b, rcond=None)`` where ``A`` has fewer rows than
    columns or dgels finds it rank deficient."""
    if A.shape[0] >= A.shape[1]:
        _, x, info = _lapack().dgels(A, b)
        if info == 0:
            return x[:A.shape[1]]
    return np.linalg.lstsq(A, b, rcond=None)[0]
