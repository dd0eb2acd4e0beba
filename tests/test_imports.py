"""Import costs the workflow's jobs rely on: each job is a fresh interpreter, so modules that
only check files or draw the model must not drag in xarray/pandas (~0.6 s) on import."""

import subprocess
import sys

import pytest

from campaign.core.lazy import LazyModule


@pytest.mark.parametrize("module", ["campaign.archive", "campaign.rig", "campaign.rig.beam", "campaign.pipeline.sweep"])
def test_module_does_not_import_xarray_or_pandas(module):
    code = f"import sys, {module}; print(sorted(m for m in ('xarray', 'pandas') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]", f"importing {module} imported {out.strip()}"


def test_the_calibration_report_module_does_not_import_the_fitting_libraries():
    """The campaign's calibration_report job only reads; the calibration fit imports scipy.optimize itself."""
    code = ("import sys, campaign.pipeline.calibration_report; "
            "print(sorted(m for m in ('xarray', 'pandas', 'scipy.optimize') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]", out


def test_lazy_module_imports_on_first_attribute_access():
    code = ("import sys; from campaign.core.lazy import LazyModule; m = LazyModule('json'); "
            "sys.modules.pop('json', None); before = 'json' in sys.modules; "
            "out = m.dumps([1]); print(before, 'json' in sys.modules, out)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False", "True", "[1]"]


def test_lazy_module_raises_for_a_missing_attribute_and_module():
    with pytest.raises(AttributeError):
        _ = LazyModule("json").no_such_function
    with pytest.raises(ModuleNotFoundError):
        _ = LazyModule("no_such_module_here").anything


def test_a_simulation_job_never_imports_xarray(tmp_path):
    """run_cells (the simulate rules) records and writes plain arrays: xarray and
    pandas cost ~0.7 s per job, more than the job's fixed-base trials take to simulate."""
    code = ("import sys; from campaign.pipeline.sweep import run_cells; "
            f"out = run_cells([('fixed', 1, 'zero')], archive_dir={str(tmp_path)!r}, speeds=[1.5], "
            "repeats=1, campaign_seed=1); "
            "print(len(out), sorted(m for m in ('xarray', 'pandas') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip().splitlines()[-1] == "1 []", out
    assert len(list(tmp_path.rglob("*.nc"))) == 1


def test_an_identification_job_never_imports_xarray(tmp_path):
    """identify_trials (the identify rules) reads trials as plain arrays."""
    from campaign.pipeline.sweep import run_cells

    [trial] = run_cells([("fixed", 1, "low")], archive_dir=tmp_path, speeds=[1.5], repeats=1,
                               campaign_seed=1)
    code = ("import sys; from campaign.identify.table import identify_trials; "
            f"rows = identify_trials([{str(trial)!r}], {str(tmp_path / 'id.csv')!r}); "
            "print(len(rows), rows[0]['m_eff'] != '', sorted(m for m in ('xarray', 'pandas') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip().splitlines()[-1] == "1 True []", out
