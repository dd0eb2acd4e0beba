"""Wall and CPU seconds per stage of a job."""

from __future__ import annotations

import contextlib
import gc
import time
from collections.abc import Iterator

__all__ = ["Timer"]
# ---------------------------------------------------------------------------------------
# logging and timing
# ---------------------------------------------------------------------------------------
class Timer:
    """Wall and CPU seconds spent per stage of a job (``with timer("simulate"): ...``)."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}
        self.cpu: dict[str, float] = {}

    @contextlib.contextmanager
    def __call__(self, stage: str) -> Iterator[None]:
        t0, c0 = time.perf_counter(), time.process_time()
        try:
            yield
        finally:
            self.seconds[stage] = self.seconds.get(stage, 0.0) + time.perf_counter() - t0
            self.cpu[stage] = self.cpu.get(stage, 0.0) + time.process_time() - c0

    @contextlib.contextmanager
    def imports(self) -> Iterator[None]:
        """The stage ``imports`` (a job's heavy modules), with the cyclic garbage collector paused.

        Importing numpy, scipy, xarray, pinocchio and matplotlib creates hundreds of
        thousands of objects that all stay alive; the collector's passes over them find
        nothing to free and cost about 10 % of the import time (0.05-0.15 s a job). It is
        switched back on (if it was on) when the imports are done.
        """

        enabled = gc.isenabled()
        gc.disable()
        try:
            with self("imports"):
                yield
        finally:
            if enabled:
                gc.enable()

