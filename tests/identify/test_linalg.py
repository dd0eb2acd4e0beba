"""identification's direct LAPACK solves give numpy's solutions, and numpy's answer where LAPACK's routine cannot."""

from __future__ import annotations

import numpy as np
import pytest

from campaign.core.tolerance import CROSS_PATH_RTOL
from campaign.identify.linalg import lstsq, solve


def test_solve_and_lstsq_agree_with_numpy_to_roundoff():
    rng = np.random.default_rng(3)
    for m, n in ((3, 3), (6, 3), (40, 4)):
        A = rng.normal(size=(m, n))
        b = rng.normal(size=m)
        np.testing.assert_allclose(lstsq(A, b), np.linalg.lstsq(A, b, rcond=None)[0], rtol=1e-12, atol=1e-14)
    H = rng.normal(size=(3, 3)) + 3 * np.eye(3)
    t = rng.normal(size=3)
    # the same routine (dgesv) from SciPy's and NumPy's own BLAS builds: equal to roundoff, not bit for bit
    np.testing.assert_allclose(solve(H, t), np.linalg.solve(H, t), rtol=CROSS_PATH_RTOL, atol=0)


def test_rank_deficient_and_wide_systems_take_numpys_minimum_norm_solution():
    rng = np.random.default_rng(4)
    A = rng.normal(size=(8, 3))
    A[:, 2] = 0.0                       # a column the data never excite
    b = rng.normal(size=8)
    # both fall back to numpy's own call: the same arithmetic, bit for bit
    np.testing.assert_array_equal(lstsq(A, b), np.linalg.lstsq(A, b, rcond=None)[0])
    wide = rng.normal(size=(2, 4))
    np.testing.assert_array_equal(lstsq(wide, b[:2]), np.linalg.lstsq(wide, b[:2], rcond=None)[0])


def test_a_singular_matrix_raises_numpys_error():
    with pytest.raises(np.linalg.LinAlgError):
        solve(np.zeros((3, 3)), np.ones(3))
