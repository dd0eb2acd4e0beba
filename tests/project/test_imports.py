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


@pytest.mark.parametrize("imports, absent", [
    # a simulation job: its flexible-base stroke check predicts with the planner, which needs the
    # joints' pulse response only, not the identification or the lambda fit
    ("from campaign.pipeline import run_cells, run_trial", ("campaign.identify", "campaign.joints.lambda_fit")),
    # the planner's maps predict with lambdas: no response model file, so no identification or archive
    ("from campaign.plan import planner_lambdas; from campaign.report.figures import plan_maps",
     ("campaign.identify", "campaign.archive", "campaign.joints.modelfile", "h5py")),
])
def test_a_job_imports_only_the_stages_it_runs(imports, absent):
    code = f"import sys; {imports}; print(sorted(m for m in {absent!r} if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]", out


def test_the_workflows_start_up_imports_neither_numpy_nor_the_robot_model():
    """common.smk imports these on every start, a dry run included: each package face on the
    way (campaign.core, .model, .pipeline, .studies) exports its names on first use only."""
    code = ("import sys; import campaign.core.vocabulary, campaign.core.errors, campaign.core.yamlfile, "
            "campaign.model.conventions, campaign.pipeline.paths, campaign.pipeline.config, "
            "campaign.pipeline.digests, campaign.studies; "
            "print(sorted(m for m in ('numpy', 'pinocchio', 'scipy', 'xarray', 'h5py') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]", out


def test_a_lazy_face_imports_a_module_on_first_use_of_its_name():
    code = ("import sys, campaign.plan as plan; before = 'campaign.plan.factory' in sys.modules; "
            "f = plan.build_planner; "
            "print(before, 'campaign.plan.factory' in sys.modules, 'build_planner' in vars(plan), "
            "f is sys.modules['campaign.plan.factory'].build_planner, 'build_planner' in dir(plan))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False", "True", "True", "True", "True"]
    with pytest.raises(AttributeError, match="campaign.plan.*no_such_name"):
        _ = __import__("campaign.plan").plan.no_such_name


_IMPORT_EVERY_FACE = """
import importlib, pkgutil, campaign
packages = ["campaign"] + [m.name for m in pkgutil.walk_packages(campaign.__path__, "campaign.") if m.ispkg]
missing = []
for package in packages:
    for name in importlib.import_module(package).__all__:
        try:
            exec(f"from {package} import {name}")
        except ImportError:
            missing.append(f"{package}.{name}")
print(len(packages), missing)
"""


def test_every_name_a_package_exports_resolves():
    """Each package's ``__all__`` imported as a user does (``from campaign.model import
    load_paper``, or ``from campaign.report.figures import fig4`` for a member module): the
    layout test checks the names statically, this imports them."""
    out = subprocess.run([sys.executable, "-c", _IMPORT_EVERY_FACE], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "18 []", out
