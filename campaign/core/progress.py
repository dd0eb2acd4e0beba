"""Progress bars for long commands: on a terminal only, never in logs or pipes.

A command that loops over many trials (verifying or finalizing an archive, identifying,
fitting, writing the tables, calibrating) wraps its loop in :func:`progress`. The bar is
drawn on stderr when stderr is a terminal, so ``campaign identify ... > out.txt`` still
shows it while the results go to the file, and a Snakemake job (stderr sent to its log)
or a pipe gets nothing extra. ``CAMPAIGN_PROGRESS=0`` switches it off, ``=1`` forces it.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterable, Iterator
from typing import TypeVar

__all__ = ["enabled", "progress"]

T = TypeVar("T")


def enabled() -> bool:
    """Whether bars are drawn: ``$CAMPAIGN_PROGRESS`` if set (0/1), else stderr is a terminal."""
    forced = os.environ.get("CAMPAIGN_PROGRESS", "").strip()
    if forced in ("0", "1"):
        return forced == "1"
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):  # stderr replaced or closed
        return False


def progress(items: Iterable[T], *, desc: str, total: int | None = None, unit: str = "trial") -> Iterator[T]:
    """``items``, with a tqdm bar on stderr while it is consumed when :func:`enabled`.

    Parameters
    ----------
    items : iterable
    desc : str
        What the loop does (``"verify"``, ``"identify"``).
    total : int, optional
        Number of items, if ``items`` has no ``len``.
    unit : str
        What one item is.
    """
    if not enabled():
        yield from items
        return
    from tqdm import tqdm

    if total is None and hasattr(items, "__len__"):
        total = len(items)  # type: ignore[arg-type]
    with tqdm(items, desc=desc, total=total, unit=unit, leave=False, file=sys.stderr, dynamic_ncols=True) as bar:
        yield from bar
