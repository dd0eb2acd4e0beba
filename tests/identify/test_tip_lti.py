"""The LTI fit's responses evaluated at the grid samples it reads equal the full convolutions read by numpy.interp."""

from __future__ import annotations

import numpy as np
import pytest

from campaign.identify.contact import ContactInput, ContactWindow
from campaign.identify.tip_lti import _GridPoints, _lti_kernels, _lti_responses


def _contact_input():
    t = np.arange(0.0, 0.5, 1e-4)
    force = np.where((t > 0.1) & (t < 0.16), 50.0 * np.sin(np.pi * (t - 0.1) / 0.06), 0.0)
    window = ContactWindow(0.1, 0.16, 50.0, 1.9, 0.0, 0.01, 0.05, 1, ((0.1, 0.16),), False, True)
    return ContactInput(t, force, window, 0.16 + 0.1 + 1e-3)


@pytest.mark.parametrize("a1, a0", [(0.0, 0.0), (1.0, 0.0), (30.0, 300.0), (5.0, 2000.0)])
def test_responses_at_the_read_samples_equal_the_full_convolutions(a1, a0):
    cin = _contact_input()
    assert 0 < cin.support < cin.grid.size and not np.any(cin.g[cin.support:])
    # joint samples at 50 Hz over the window, the contact's end, and times off the grid's ends
    x = np.concatenate([np.arange(0.1, 0.27, 0.02), [0.16, cin.grid[0] - 1e-3, cin.grid[-1], cin.grid[-1] + 1.0]])
    points = _GridPoints(cin.grid, x)
    full = _lti_responses(cin, a1, a0, True, True)
    sparse = _lti_responses(cin, a1, a0, True, True, points=points)
    for (pos, vel), (pos_at, vel_at) in zip(full, sparse, strict=True):
        for whole, at in ((pos, pos_at), (vel, vel_at)):
            expected = np.interp(x, cin.grid, whole)
            scale = np.abs(whole).max()
            np.testing.assert_allclose(points.interp(at), expected, rtol=0, atol=1e-12 * scale)


@pytest.mark.parametrize("a1, a0", [(1.0, 0.0), (30.0, 300.0), (5.0, 2000.0), (40.0, 400.0)])
def test_real_kernels_solve_the_resistance_law(a1, a0):
    """h'' + a1 h' + a0 h = 0 with h(0) = 0, h'(0) = 1, and hd = h' (finite differences)."""
    x = np.linspace(0.0, 0.2, 20001)
    h, hd = _lti_kernels(a1, a0, x)
    dx = x[1] - x[0]
    assert h[0] == 0.0 and hd[0] == pytest.approx(1.0)
    np.testing.assert_allclose(np.gradient(h, dx)[1:-1], hd[1:-1], rtol=0, atol=1e-6 * np.abs(hd).max())
    hdd = np.gradient(hd, dx)
    np.testing.assert_allclose((hdd + a1 * hd + a0 * h)[2:-2], 0.0, atol=1e-5 * (np.abs(hdd).max() + 1))
