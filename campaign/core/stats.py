"""Statistical constants shared by the fits and the experiment design."""

from __future__ import annotations

__all__ = ["Z95"]

#: the standard normal's 97.5 % quantile: half-width of a 95 % interval in standard deviations
Z95 = 1.959963984540054
