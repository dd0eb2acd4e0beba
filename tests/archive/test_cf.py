"""Trial files against a real CF/ACDD checker, and byte-identical with SOURCE_DATE_EPOCH.

The checker is the IOOS ``compliance-checker`` (pinned in constraints.txt). It checks the
root group of a netCDF file only, so each of a trial's two groups is copied, exactly
(dimensions, variables, every attribute, no fill value added), into a flat file whose
global attributes are the trial's root attributes plus the group's own, and checked
there. CF-1.11 must pass every check (its "must" and "should" both); ACDD-1.3's only
shortfall allowed is ``standard_name`` on variables, since CF's standard-name table has
no name for joint angles, hammer forces or the like.
"""

from __future__ import annotations

import json
from pathlib import Path

import netCDF4
import numpy as np
import pytest
from compliance_checker import runner

from campaign.archive import write_trial
from campaign.core.errors import InputError
from campaign.rig import simulate
from campaign.scene.description import make_scene

EPOCH = "1700000000"


def _flat(trial: Path, group: str, out: Path) -> Path:
    """One group of a trial as a flat netCDF-4 file, attributes and data copied exactly."""
    with netCDF4.Dataset(trial) as root, netCDF4.Dataset(out, "w", format="NETCDF4") as flat:
        g = root.groups[group]
        flat.setncatts({**{k: root.getncattr(k) for k in root.ncattrs()}, **{k: g.getncattr(k) for k in g.ncattrs()}})
        for name, dim in g.dimensions.items():
            flat.createDimension(name, len(dim))
        for name, var in g.variables.items():
            attrs = {k: var.getncattr(k) for k in var.ncattrs()}
            fill = attrs.pop("_FillValue", None)
            copy = flat.createVariable(name, var.datatype, var.dimensions,
                                       fill_value=fill if fill is not None else False)
            copy.setncatts(attrs)
            copy[...] = var[...]
    return out


def _check(path: Path, tmp: Path) -> dict:
    """The checker's JSON report of ``path`` for CF-1.11 and ACDD-1.3."""
    runner.CheckSuite.load_all_available_checkers()
    report = tmp / f"{path.stem}.json"
    runner.ComplianceChecker.run_checker(str(path), ["cf:1.11", "acdd:1.3"], 0, "normal",
                                         output_filename=str(report), output_format="json")
    return json.loads(report.read_text())


def _failures(result: dict, priority: str) -> list[tuple[str, list[str]]]:
    return [(item["name"], item["msgs"]) for item in result.get(f"{priority}_priorities", [])
            if item["value"][0] < item["value"][1]]


@pytest.fixture(scope="module")
def trials(tmp_path_factory):
    """A fixed- and a flexible-base trial, each simulated and written twice with SOURCE_DATE_EPOCH."""
    out = tmp_path_factory.mktemp("cf")
    mp = pytest.MonkeyPatch()
    mp.setenv("SOURCE_DATE_EPOCH", EPOCH)
    paths = {}
    try:
        for base, config, gain in (("fixed", 1, "zero"), ("flexible", 2, "high")):
            for run in (1, 2):
                scene = make_scene(base=base, config=config, gain=gain, speed=2.0)
                paths[base, run] = write_trial(simulate(scene), out / f"{base}{run}.nc")
    finally:
        mp.undo()
    return paths


@pytest.mark.parametrize("base", ["fixed", "flexible"])
def test_two_runs_give_byte_identical_files(trials, base):
    assert trials[base, 1].read_bytes() == trials[base, 2].read_bytes()
    with netCDF4.Dataset(trials[base, 1]) as ds:
        assert ds.getncattr("date_created") == "2023-11-14T22:13:20Z"


@pytest.mark.parametrize("base", ["fixed", "flexible"])
@pytest.mark.parametrize("group", ["measured", "truth"])
def test_each_group_passes_the_cf_and_acdd_checker(trials, tmp_path, base, group):
    flat = _flat(trials[base, 1], group, tmp_path / f"{base}_{group}.nc")
    report = _check(flat, tmp_path)
    cf, acdd = report["cf:1.11"], report["acdd:1.3"]
    assert not _failures(cf, "high") and not _failures(cf, "medium"), (_failures(cf, "high"), _failures(cf, "medium"))
    assert cf["scored_points"] == cf["possible_points"]
    for name, msgs in _failures(acdd, "high"):
        assert name.startswith("variable ") and msgs == ["standard_name"], (name, msgs)
    # the checker's monotonicity test stops at the label coordinates (strings), so the
    # clocks are checked here: every time coordinate strictly increasing, in seconds
    with netCDF4.Dataset(flat) as ds:
        clocks = [v for v in ds.variables.values() if v.dimensions == (v.name,) and v.name.startswith("t_")]
        assert clocks
        for clock in clocks:
            assert clock.units == "s" and "standard_name" not in clock.ncattrs()
            assert np.all(np.diff(clock[:]) > 0), clock.name


def test_a_bad_source_date_epoch_is_named(tmp_path, monkeypatch):
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "yesterday")
    tree = simulate(make_scene(speed=1.5))
    with pytest.raises(InputError, match="SOURCE_DATE_EPOCH = 'yesterday'"):
        write_trial(tree, tmp_path / "t.nc")
    assert not list(tmp_path.iterdir())
