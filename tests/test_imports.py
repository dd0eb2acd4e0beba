"""Import costs the workflow's jobs rely on: each job is a fresh interpreter, so modules that
only check files or draw the model must not drag in xarray/pandas (~0.6 s) on import."""

import subprocess
import sys

import pytest

from campaign._lazy import LazyModule


@pytest.mark.parametrize("module", ["campaign.archive", "campaign.rig", "campaign.rig.beam", "campaign.runner"])
def test_module_does_not_import_xarray_or_pandas(module):
    code = f"import sys, {module}; print(sorted(m for m in ('xarray', 'pandas') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]", f"importing {module} imported {out.strip()}"


def test_lazy_module_imports_on_first_attribute_access():
    code = ("import sys; from campaign._lazy import LazyModule; m = LazyModule('json'); "
            "sys.modules.pop('json', None); before = 'json' in sys.modules; "
            "out = m.dumps([1]); print(before, 'json' in sys.modules, out)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False", "True", "[1]"]


def test_lazy_module_raises_for_a_missing_attribute_and_module():
    with pytest.raises(AttributeError):
        LazyModule("json").no_such_function
    with pytest.raises(ModuleNotFoundError):
        LazyModule("no_such_module_here").anything
