"""A simulation job's trials: every scene built and checked, then each trial integrated and
recorded in turn by the lean one-trial loop (:mod:`.trial_run`).

Each trial is integrated on its own: with the loop on plain floats a trial step costs less
than the NumPy calls a lock-step batch over the job's trials spends per step (measured:
``benchmarks/bench_trial_loop.py``, user guide, *Benchmarks*), so a job gains nothing from
advancing its trials together. A failing trial
(:class:`~campaign.core.errors.SimulationError`) is reported with its error and the others
go on.
"""

from __future__ import annotations

from ..core.errors import SimulationError
from .integrate import integrate_trial
from .trial import build, integration_args, record_arrays

__all__ = ["simulate_batch"]


def simulate_batch(scenes, *, integration: dict | None = None, on_done=None) -> list:
    """Simulate a job's trials; per scene what :func:`.trial.simulate_arrays` returns (the
    same arrays), or the :class:`~campaign.core.errors.SimulationError` that ended that trial.

    Every scene is built and checked first (:func:`.trial.build`), so a bad input raises
    its :class:`~campaign.core.errors.InputError` before any trial is integrated.

    Parameters
    ----------
    scenes : sequence of Scene
    integration : dict, optional
        Integrator overrides for every trial (:func:`.trial.build`).
    on_done : callable, optional
        Called as ``on_done(i, result)`` as trial ``i`` is recorded or fails.
    """
    rigs = [build(scene, integration=integration) for scene in scenes]
    out: list = []
    for i, rig in enumerate(rigs):
        try:
            traj = integrate_trial(rig.plant, rig.pid, **integration_args(rig))
            trial = record_arrays(rig, traj)
            trial.attrs["integration_steps"] = int(traj.n_steps)
            trial.attrs["integration_rhs_evaluations"] = int(traj.n_rhs)
        except SimulationError as err:
            trial = err
        out.append(trial)
        if on_done is not None:
            on_done(i, trial)
    return out
