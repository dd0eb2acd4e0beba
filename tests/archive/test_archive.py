"""The data archive: trial file format, safe I/O, campaign folders, verify, reuse.

Trials here are synthetic (tests/synthetic.py): random channels of the schema's shapes, so
these tests pin the archive without waiting for the rig.
"""

from __future__ import annotations

import csv
import faulthandler
import json
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import zlib
from pathlib import Path

import h5py
import numpy as np
import pytest
import xarray as xr

import campaign.archive.read
from campaign import archive
from campaign.archive import (
    finalize_campaign,
    list_trials,
    open_campaign,
    open_trial,
    open_trial_tree,
    prepare_trial,
    to_cell_dataset,
    trial_path,
    verify,
    write_trial,
)
from campaign.archive import fileformat
from campaign.archive.decode import plain_value
from campaign.archive.read import inspect_isolated_many
from campaign.cli.main import main as cli_main
from campaign.core.errors import InputError, TrialFileError
from campaign.scene.schema import CLOCKS, MEASURED, SCHEMA_VERSION, TRUTH, variables

from synthetic import synthetic_trial

DURATION = 0.3  # s: short recordings keep every write/read in the tens of ms
ENCODING_KEYS = ("dtype", "zlib", "complevel", "shuffle", "fletcher32", "chunksizes")
CELLS = [  # a small campaign: both bases, two configurations, two gains, two speeds
    dict(base="fixed", config=1, gain="zero", speed=1.5),
    dict(base="fixed", config=2, gain="zero", speed=1.5),
    dict(base="fixed", config=1, gain="high", speed=2.0),
    dict(base="flexible", config=1, gain="low", speed=1.5),
]


@pytest.fixture(autouse=True)
def _fixed_clock(monkeypatch):
    """date_created is the one attribute that changes run to run; freeze it for comparisons."""
    monkeypatch.setattr(archive.fileformat, "_now", lambda: "2026-01-01T00:00:00Z")


@pytest.fixture(scope="module")
def trees():
    return {(c["base"], c["config"], c["gain"], c["speed"]): synthetic_trial(duration=DURATION, **c) for c in CELLS}


@pytest.fixture(scope="module")
def campaign_master(tmp_path_factory, trees):
    """A finalized campaign folder, built once; tests that damage it work on a copy."""
    folder = tmp_path_factory.mktemp("archive") / "small"
    for tree in trees.values():
        write_trial(tree, folder / f"{_scene(tree).cell}.nc")
    finalize_campaign(folder)
    return folder


@pytest.fixture
def campaign(campaign_master, tmp_path):
    folder = tmp_path / "small"
    shutil.copytree(campaign_master, folder)
    return folder


def _scene(tree):
    from campaign.scene.description import Scene
    return Scene.from_json(tree.attrs["scene_json"])


def _first_trial(folder: Path) -> Path:
    return folder / "fixed/config1/zero/v1.500/r00.nc"


# ---------------------------------------------------------------------------------------
# file format
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("base", ["fixed", "flexible"])
def test_roundtrip_identical_values_dtypes_attributes_encodings(tmp_path, base):
    tree = synthetic_trial(base=base, duration=DURATION)
    expected = prepare_trial(tree)
    path = write_trial(tree, tmp_path / "trial.nc")
    actual = open_trial_tree(path)
    xr.testing.assert_identical(actual, expected)
    for group in archive.GROUPS:
        for name, var in expected[group].variables.items():
            got = actual[group].variables[name]
            assert got.dtype == var.dtype, (group, name)
            for key in ENCODING_KEYS:
                if key in var.encoding:
                    assert got.encoding[key] == var.encoding[key], (group, name, key)
    # the rig's numbers go through untouched; time series are chunked along time and deflated
    # where deflate pays (a uniform clock always), stored contiguous where it does not
    xr.testing.assert_equal(actual["measured"].to_dataset(), tree["measured"].to_dataset())
    assert actual["measured"]["t_force"].encoding["zlib"] and actual["measured"]["t_force"].encoding["shuffle"]
    for group in archive.GROUPS:
        for name, var in actual[group].data_vars.items():
            if var.dims and var.dims[0] in CLOCKS:
                data = np.ascontiguousarray(var.values)
                shuffled = data.view(np.uint8).reshape(data.size, data.dtype.itemsize).T.tobytes()
                ratio = len(zlib.compress(shuffled, fileformat.DEFLATE_LEVEL)) / len(shuffled)
                if var.encoding["zlib"]:   # small channels are deflated untested
                    assert var.encoding["shuffle"], (group, name)
                    assert data.nbytes < fileformat._PROBE_MIN_BYTES or ratio <= fileformat.DEFLATE_PAYS + 0.15, \
                        (group, name, ratio)
                else:
                    assert var.encoding["chunksizes"] is None and ratio >= fileformat.DEFLATE_PAYS - 0.15, \
                        (group, name, ratio)


def test_files_decode_like_files_xarray_writes_itself(tmp_path):
    """Our h5py writer and xarray's h5netcdf engine give files xarray decodes identically."""
    prepared = prepare_trial(synthetic_trial(base="flexible", duration=DURATION))
    ours = write_trial(prepared, tmp_path / "ours.nc")
    reference = tmp_path / "xarray.nc"
    prepared.to_netcdf(reference, engine="h5netcdf")
    for group in archive.GROUPS:
        with xr.open_dataset(ours, engine="h5netcdf", group=group) as a, \
                xr.open_dataset(reference, engine="h5netcdf", group=group) as b:
            a.load()
            b.load()
        xr.testing.assert_identical(a, b)
        for name in a.variables:
            ea = {k: v for k, v in a[name].encoding.items() if k != "source"}
            eb = {k: v for k, v in b[name].encoding.items() if k != "source"}
            assert ea == eb, (group, name)
    # and the reference file passes our own checks: the digests describe content, not bytes
    open_trial(reference)


@pytest.fixture(scope="module")
def decoded_alike_files(tmp_path_factory):
    """Real rig trials of both bases (a flexible simulation takes about 1 s) and a trial file
    xarray writes itself."""
    from campaign.rig import simulate
    from campaign.scene.description import make_scene

    folder = tmp_path_factory.mktemp("decoded")
    files = {base: write_trial(simulate(scene), folder / f"{base}.nc") for base, scene in (
        ("fixed", make_scene(config=1, speed=1.5)),
        ("flexible", make_scene(base="flexible", config=2, gain="high", speed=2.0)))}
    files["written by xarray"] = folder / "xarray.nc"
    prepare_trial(synthetic_trial(base="flexible", duration=DURATION)).to_netcdf(files["written by xarray"],
                                                                               engine="h5netcdf")
    return files


def _assert_decoded_alike(actual: xr.Dataset, expected: xr.Dataset, where) -> None:
    """Identical, and alike in what assert_identical leaves out: order, dtypes, attribute types, encodings."""
    xr.testing.assert_identical(actual, expected)
    assert list(actual.variables) == list(expected.variables), where
    assert list(actual.xindexes) == list(expected.xindexes), where
    assert list(actual.attrs) == list(expected.attrs), where
    assert all(type(actual.attrs[k]) is type(v) for k, v in expected.attrs.items()), where
    assert actual.encoding == expected.encoding, where
    for name, var in expected.variables.items():
        got = actual.variables[name]
        assert got.dtype == var.dtype, (where, name)
        assert got.encoding == var.encoding, (where, name, got.encoding, var.encoding)
        assert list(got.attrs) == list(var.attrs), (where, name)
        assert all(type(got.attrs[k]) is type(v) for k, v in var.attrs.items()), (where, name)


@pytest.mark.parametrize("kind", ["fixed", "flexible", "written by xarray"])
def test_fast_reader_decodes_exactly_like_xarray(decoded_alike_files, kind):
    """open_trial/open_trial_tree build their Datasets from the arrays the content check read;
    the result is what xarray's h5netcdf engine returns for the same file."""
    path = decoded_alike_files[kind]
    with xr.open_dataset(path, engine="h5netcdf") as root:
        global_attrs = {k: plain_value(v) for k, v in root.attrs.items() if k != "content_sha256"}
    for group in archive.GROUPS:
        with xr.open_dataset(path, engine="h5netcdf", group=group) as expected:
            expected.load()
        expected.attrs = {**global_attrs, **expected.attrs}  # open_trial's merged global attributes
        _assert_decoded_alike(open_trial(path, group=group), expected, (kind, group))
    with xr.open_datatree(path, engine="h5netcdf") as expected_tree:
        expected_tree.load()
    actual_tree = open_trial_tree(path)
    xr.testing.assert_identical(actual_tree, expected_tree)
    assert list(actual_tree.children) == list(expected_tree.children)
    for node in ("/", *(f"/{g}" for g in archive.GROUPS)):
        assert actual_tree[node].encoding == expected_tree[node].encoding, (kind, node)
        _assert_decoded_alike(actual_tree[node].to_dataset(inherit=False),
                              expected_tree[node].to_dataset(inherit=False), (kind, node))


@pytest.mark.parametrize("kind", ["fixed", "flexible", "written by xarray"])
def test_plain_array_reader_gives_what_open_trial_gives(decoded_alike_files, kind):
    """open_trial_arrays (identification's reader in the campaign's jobs, no xarray) holds
    the values, dtypes, dims and attributes of open_trial's Dataset, and identification
    gives the same result from either."""
    import dataclasses
    import math

    from campaign.identify import identify_trial

    path = decoded_alike_files[kind]
    for group in archive.GROUPS:
        expected = open_trial(path, group=group)
        got = archive.open_trial_arrays(path, group=group)
        assert list(got.data_vars) == list(expected.data_vars), (kind, group)
        assert sorted(got.coords) == sorted(expected.coords), (kind, group)
        assert got.sizes == dict(expected.sizes) and got.attrs == expected.attrs, (kind, group)
        for name, var in expected.variables.items():
            plain = got[name]
            assert plain.dims == var.dims and plain.values.dtype == var.dtype, (kind, group, name)
            assert np.array_equal(plain.values, var.values), (kind, group, name)
            assert plain.attrs == var.attrs, (kind, group, name)
    if kind == "written by xarray":
        return   # synthetic channels: nothing to identify
    a = identify_trial(archive.open_trial_arrays(path), meta=open_trial(path).attrs)
    b = identify_trial(open_trial(path), meta=open_trial(path).attrs)
    for field in dataclasses.fields(a):
        x, y = getattr(a, field.name), getattr(b, field.name)
        assert x == y or (isinstance(x, float) and math.isnan(x) and math.isnan(y)), field.name
    with pytest.raises(InputError, match="unknown trial group"):
        archive.open_trial_arrays(path, group="raw")


def test_plain_array_reader_refuses_a_damaged_file(tmp_path):
    path = write_trial(synthetic_trial(duration=DURATION), tmp_path / "t.nc")
    with h5py.File(path, "r+") as f:
        f["measured/f_piezo"][3] += 1.0
    with pytest.raises(TrialFileError, match="content_sha256"):
        archive.open_trial_arrays(path)


def test_plain_xarray_shows_units_and_long_names_without_campaign(tmp_path):
    path = write_trial(synthetic_trial(base="flexible", duration=DURATION), tmp_path / "t.nc")
    script = textwrap.dedent("""
        import json, sys
        import xarray as xr
        out = {}
        with xr.open_dataset(sys.argv[1], engine="h5netcdf") as root:
            out["root"] = {k: str(v) for k, v in root.attrs.items()}
        for group in ("measured", "truth"):
            with xr.open_dataset(sys.argv[1], engine="h5netcdf", group=group) as ds:
                ds.load()
                out[group] = {n: {k: str(v) for k, v in ds[n].attrs.items()} for n in ds.variables}
        out["imported_campaign"] = any(m == "campaign" or m.startswith("campaign.") for m in sys.modules)
        print(json.dumps(out))
    """)
    result = subprocess.run([sys.executable, "-c", script, str(path)], capture_output=True, text=True,
                            check=True, cwd=tmp_path)
    seen = json.loads(result.stdout)
    assert not seen["imported_campaign"]
    for group, table in (("measured", MEASURED), ("truth", TRUTH)):
        for var in table:
            attrs = seen[group][var.name]
            assert attrs["units"] == var.units and attrs["long_name"] == var.long_name, (group, var.name)
        for dim in seen[group]:
            if dim in CLOCKS:
                attrs = seen[group][dim]
                assert attrs["units"] == "s" and "standard_name" not in attrs and attrs["long_name"]
            assert "long_name" in seen[group][dim], (group, dim)
    root = seen["root"]
    for key in ("title", "summary", "keywords", "Conventions", "id", "date_created", "creator_name", "project",
                "references", "license", "processing_level", "schema_version", "scene_json", "scene_sha256",
                "seed", "campaign_version", "git_commit", "numpy_version", "scipy_version", "pinocchio_version",
                "xarray_version", "h5py_version", "h5netcdf_version"):
        assert root.get(key), key
    assert root["Conventions"] == "CF-1.11, ACDD-1.3"
    assert root["schema_version"] == SCHEMA_VERSION
    assert "Impact Dynamics of Space Long Reach Manipulators" in root["references"]


def test_fixed_trials_carry_no_flexible_base_channels(tmp_path):
    path = write_trial(synthetic_trial(base="fixed", duration=DURATION), tmp_path / "t.nc")
    ds = open_trial(path)
    assert "base_position" not in ds and "t_base" not in ds.dims
    assert set(ds.data_vars) == {v.name for v in variables("measured", "fixed")}


def test_open_trial_returns_measured_by_default_with_the_file_attributes(tmp_path):
    tree = synthetic_trial(duration=DURATION)
    path = write_trial(tree, tmp_path / "t.nc")
    measured = open_trial(path)
    assert set(measured.data_vars) == {v.name for v in variables("measured", "fixed")}
    assert measured.attrs["scene_json"] == tree.attrs["scene_json"]
    assert measured.attrs["seed"] == tree.attrs["seed"]
    truth = open_trial(path, group="truth")
    assert "f_contact" in truth and "f_contact" not in measured
    with pytest.raises(InputError, match="unknown trial group 'raw'"):
        open_trial(path, group="raw")


def test_determinism_same_scene_same_channels(tmp_path, monkeypatch):
    a = write_trial(synthetic_trial(seed=11, duration=DURATION), tmp_path / "a.nc")
    monkeypatch.setattr(archive.fileformat, "_now", lambda: "2030-06-01T12:00:00Z")  # written at another time
    b = write_trial(synthetic_trial(seed=11, duration=DURATION), tmp_path / "b.nc")
    ta, tb = open_trial_tree(a), open_trial_tree(b)
    for group in archive.GROUPS:
        xr.testing.assert_identical(ta[group].to_dataset(), tb[group].to_dataset())
    assert ta.attrs["date_created"] != tb.attrs["date_created"]
    # the groups' digests do not depend on when the file was written: a fingerprint of the channels
    assert ta["measured"].attrs["content_sha256"] == tb["measured"].attrs["content_sha256"]
    c = write_trial(synthetic_trial(seed=12, duration=DURATION), tmp_path / "c.nc")
    with h5py.File(c, "r") as f:
        assert f["measured"].attrs["content_sha256"] != ta["measured"].attrs["content_sha256"]


def test_provenance_is_plain_strings_and_names_the_commit():
    prov = archive.provenance()
    assert all(isinstance(v, str) and v for v in prov.values())
    commit = prov["git_commit"]
    assert commit == "unknown" or len(commit.split("-")[0]) == 40


@pytest.mark.parametrize("damage, message", [
    (lambda t: t["measured"].to_dataset().drop_vars("f_piezo"), "missing f_piezo"),
    (lambda t: t["measured"].to_dataset().assign(extra=xr.DataArray(1.0)), "not in schema"),
    (lambda t: t["measured"].to_dataset().assign_attrs(meta={"a": 1}), "'meta'.*dict"),
    (lambda t: t["measured"].to_dataset().assign_attrs(flag=True), "'flag'.*bool"),
    (lambda t: t["measured"].to_dataset().assign_attrs(missing=None), "'missing'.*NoneType"),
    (lambda t: _with_attrs(t["measured"].to_dataset(), "f_piezo", units="kN"), "units 'kN'"),
    (lambda t: t["measured"].to_dataset().assign(f_piezo=lambda d: d.f_piezo.rename(t_force="t_x")),
     "f_piezo has dims"),
])
def test_write_refuses_trials_that_break_the_schema(tmp_path, damage, message):
    tree = synthetic_trial(duration=DURATION)
    bad = xr.DataTree.from_dict({"/": xr.Dataset(attrs=tree.attrs), "/measured": damage(tree),
                                 "/truth": tree["truth"].to_dataset()})
    target = tmp_path / "t.nc"
    with pytest.raises(InputError, match=message):
        write_trial(bad, target)
    assert not target.exists() and not list(tmp_path.iterdir())


def _with_attrs(ds, name, **attrs):
    ds = ds.copy()
    ds[name].attrs.update(attrs)
    return ds


@pytest.mark.parametrize("base", ["fixed", "flexible"])
def test_plain_arrays_are_stored_as_the_same_file_as_their_tree(tmp_path, base):
    """The campaign's simulation jobs write the rig's plain arrays (no xarray); the file must
    be the one the DataTree of the same trial gives, byte for byte."""
    from campaign.rig import simulate_arrays
    from campaign.rig.trial import to_tree
    from campaign.scene.description import make_scene

    trial = simulate_arrays(make_scene(base=base, config=1, gain="low", speed=1.5))
    from_arrays = write_trial(trial, tmp_path / "arrays.nc")
    from_tree = write_trial(to_tree(trial), tmp_path / "tree.nc")
    assert from_arrays.read_bytes() == from_tree.read_bytes()
    # and the schema is enforced on the plain form as well, before anything is written
    trial.groups["measured"].data_vars.pop("f_piezo")
    bad = archive.TrialArrays(trial.attrs, {g: archive.GroupArrays(v.data_vars, v.coords, v.attrs)
                                            for g, v in trial.groups.items()})
    with pytest.raises(InputError, match="missing f_piezo"):
        write_trial(bad, tmp_path / "bad.nc")
    assert not (tmp_path / "bad.nc").exists()


def test_write_refuses_a_scene_that_disagrees_with_its_hash(tmp_path):
    tree = synthetic_trial(duration=DURATION)
    bad = tree.copy()
    bad.attrs = {**tree.attrs, "scene_sha256": "0" * 64}
    with pytest.raises(InputError, match="scene_sha256"):
        write_trial(bad, tmp_path / "t.nc")


# ---------------------------------------------------------------------------------------
# safe I/O
# ---------------------------------------------------------------------------------------
_KILL_SCRIPT = """
import sys, time
sys.path.insert(0, {tests!r})
from campaign import archive
from synthetic import synthetic_trial
tree = synthetic_trial(duration={duration})
real = archive.write._create_dataset
count = [0]
def slow(*args, **kwargs):
    count[0] += 1
    if count[0] == 20:          # well inside the write: groups, scales and channels half done
        print("writing", flush=True)
        time.sleep(60)
    return real(*args, **kwargs)
archive.write._create_dataset = slow
archive.write_trial(tree, sys.argv[1])
"""


def test_writer_killed_mid_write_leaves_no_file_and_a_rerun_completes(tmp_path):
    final = tmp_path / "fixed/config1/zero/v1.500/r00.nc"
    script = _KILL_SCRIPT.format(tests=str(Path(__file__).parents[1]), duration=DURATION)
    proc = subprocess.Popen([sys.executable, "-c", script, str(final)], stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "writing"
        proc.send_signal(signal.SIGKILL)
    finally:
        proc.wait(timeout=30)
    assert proc.returncode == -signal.SIGKILL
    assert not final.exists()
    leftovers = list(final.parent.glob(".*.tmp"))
    assert len(leftovers) == 1 and leftovers[0].stat().st_size > 0  # the half-written temp file
    # a rerun completes, and clears the abandoned temp file
    write_trial(synthetic_trial(duration=DURATION), final)
    assert open_trial(final)["f_piezo"].size > 0
    assert sorted(p.name for p in final.parent.iterdir()) == ["r00.nc"]


def test_failed_write_removes_its_temp_file_and_keeps_the_old_file(tmp_path, monkeypatch):
    final = write_trial(synthetic_trial(duration=DURATION), tmp_path / "t.nc")
    before = final.read_bytes()

    def broken(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(archive.write, "_create_dataset", broken)
    with pytest.raises(OSError, match="disk full"):
        write_trial(synthetic_trial(seed=5, duration=DURATION), final)
    assert final.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["t.nc"]


def test_reads_leave_no_open_handles(tmp_path):
    path = write_trial(synthetic_trial(duration=DURATION), tmp_path / "t.nc")
    open_trial(path)
    open_trial_tree(path)
    # HDF5 refuses to open a file for writing while any handle to it is open in this process
    with h5py.File(path, "r+"):
        pass
    os.replace(path, tmp_path / "moved.nc")


# ---------------------------------------------------------------------------------------
# campaign folder
# ---------------------------------------------------------------------------------------
def test_campaign_layout_manifest_index_readme(campaign, trees):
    for tree in trees.values():
        assert trial_path(campaign, _scene(tree)).is_file()
    names = sorted(p.name for p in campaign.iterdir())
    assert names == sorted(["MANIFEST.sha256", "README.md", "index.csv", "fixed", "flexible"])
    # sha256sum itself accepts the manifest
    sha = shutil.which("sha256sum")
    if sha:
        out = subprocess.run([sha, "-c", "MANIFEST.sha256"], cwd=campaign, capture_output=True, text=True)
        assert out.returncode == 0, out.stdout + out.stderr
    listed = [line.split("  ", 1)[1] for line in (campaign / "MANIFEST.sha256").read_text().splitlines()]
    assert "index.csv" in listed and "README.md" in listed and len(listed) == len(CELLS) + 2
    with open(campaign / "index.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["path"] for r in rows] == sorted(r["path"] for r in rows)
    assert {(r["base"], int(r["config"]), r["gain"], float(r["speed"])) for r in rows} == set(trees)
    for r in rows:
        assert set(r) == set(archive.INDEX_COLUMNS) and r["scene"] == "default" and len(r["scene_sha256"]) == 64
    readme = (campaign / "README.md").read_text()
    for var in MEASURED + TRUTH:
        assert f"`{var.name}`" in readme and f"`{var.units}`" in readme and var.long_name in readme
    for dim, clock in CLOCKS.items():
        assert f"`{dim}`" in readme and f"`{clock.rate_key}`" in readme
    assert "| `t_force` | piezo force sample time | `sensors.piezo_rate` | 10000 |" in readme


def test_verify_accepts_an_intact_campaign(campaign):
    assert verify(campaign) == []
    assert cli_main(["archive", "verify", str(campaign)]) == 0


def test_list_trials_and_filters(campaign):
    assert len(list_trials(campaign)) == len(CELLS)
    assert [r.path for r in list_trials(campaign, base="flexible")] == ["flexible/config1/low/v1.500/r00.nc"]
    assert len(list_trials(campaign, config="1,2", gain="zero")) == 2
    assert len(list_trials(campaign, config=[2], speed=1.5)) == 1
    assert len(list_trials(campaign, speed="2.0")) == 1
    assert list_trials(campaign, gain="low", base="fixed") == []
    rec = list_trials(campaign, base="flexible")[0]
    assert rec.file.is_file() and rec.seed == _scene(synthetic_trial(base="flexible", gain="low")).seed


def test_open_campaign_collects_scalar_variables_over_the_cells(campaign):
    ds = open_campaign(campaign, variables=["hammer_mass_eff", "truth/impulse", "base_mass"])
    assert ds["impulse"].dims == archive.CELL_KEYS
    assert list(ds.base.values) == ["fixed", "flexible"] and list(ds.gain.values) == ["zero", "low", "high"]
    assert ds["impulse"].attrs == {"units": "N s", "long_name": TRUTH[[v.name for v in TRUTH].index("impulse")].long_name}
    cell = dict(base="fixed", config=1, gain="zero", speed=1.5, repeat=0)
    value = open_trial(campaign / ds["path"].sel(cell).item(), group="truth")["impulse"].item()
    assert ds["impulse"].sel(cell).item() == value
    # a fixed base has no base mass; cells without a trial are NaN
    assert np.isnan(ds["base_mass"].sel(cell).item())
    assert np.isfinite(ds["base_mass"].sel(base="flexible", config=1, gain="low", speed=1.5, repeat=0).item())
    assert np.isnan(ds["impulse"].sel(base="flexible", config=2, gain="zero", speed=1.5, repeat=0).item())
    assert ds["path"].sel(base="flexible", config=2, gain="zero", speed=1.5, repeat=0).item() == ""


def test_open_campaign_runs_a_function_per_trial_on_measured_data(campaign):
    def identify(ds):
        assert "f_contact" not in ds  # measured only
        peak = ds["f_piezo"].max()
        return {"peak_force": xr.DataArray(float(peak), attrs={"units": "N"}), "n_force": int(ds.sizes["t_force"])}

    ds = open_campaign(campaign, func=identify, gain="zero")
    assert ds.sizes == {"base": 1, "config": 2, "gain": 1, "speed": 1, "repeat": 1}
    assert ds["peak_force"].attrs == {"units": "N"}
    assert ds["n_force"].dtype == np.int64
    with pytest.raises(InputError, match="scalar per-trial"):
        open_campaign(campaign, variables=["f_piezo"])
    with pytest.raises(InputError, match="not in schema"):
        open_campaign(campaign, variables=["m_eff"])


def test_to_cell_dataset_from_records_frames_and_csv(tmp_path):
    records = [
        {"base": "fixed", "config": 1, "gain": "low", "speed": 1.5, "repeat": 0, "m_eff": 12.9, "e": 0.55},
        {"base": "fixed", "config": 1, "gain": "low", "speed": 1.5, "repeat": 1, "m_eff": 13.1, "e": 0.56},
        {"base": "fixed", "config": 3, "gain": "high", "speed": 2.0, "repeat": 0, "m_eff": 19.0, "e": 0.5},
    ]
    ds = to_cell_dataset(records, attrs={"m_eff": {"units": "kg", "long_name": "effective mass"}})
    assert ds["m_eff"].dims == archive.CELL_KEYS and ds["m_eff"].attrs["units"] == "kg"
    assert ds["m_eff"].sel(base="fixed", config=1, gain="low", speed=1.5, repeat=1).item() == 13.1
    assert np.isnan(ds["m_eff"].sel(base="fixed", config=3, gain="low", speed=1.5, repeat=0).item())
    assert ds["speed"].attrs["units"] == "m s-1"
    # the same table as a pandas DataFrame or a CSV file (what identification may write) gives the same Dataset
    import pandas as pd
    xr.testing.assert_equal(to_cell_dataset(pd.DataFrame(records)), ds)
    path = tmp_path / "results.csv"
    pd.DataFrame(records).to_csv(path, index=False)
    xr.testing.assert_equal(to_cell_dataset(path), ds)
    with pytest.raises(InputError, match="same cell"):
        to_cell_dataset(records + records[:1])
    with pytest.raises(InputError, match="no gain"):
        to_cell_dataset([{"base": "fixed", "config": 1, "speed": 1.5, "repeat": 0}])


# ---------------------------------------------------------------------------------------
# faults: each reported by verify and by the loader, naming the file
# ---------------------------------------------------------------------------------------
def _flip_bytes_in_data(path: Path) -> None:
    with h5py.File(path, "r") as f:   # a deflated channel's chunk, or a plain one's bytes
        dsid = f["measured/f_piezo"].id
        offset, size = ((dsid.get_chunk_info(0).byte_offset, dsid.get_chunk_info(0).size)
                        if f["measured/f_piezo"].chunks else (dsid.get_offset(), dsid.get_storage_size()))
    with open(path, "r+b") as fh:
        fh.seek(offset + size // 2)
        chunk = bytearray(fh.read(4))
        fh.seek(offset + size // 2)
        fh.write(bytes(b ^ 0x5A for b in chunk))


def _truncate(path: Path) -> None:
    with open(path, "r+b") as fh:
        fh.truncate(path.stat().st_size // 2)


def _newer_major(path: Path) -> None:
    with h5py.File(path, "r+") as f:
        f.attrs["schema_version"] = f"{int(SCHEMA_VERSION.split('.')[0]) + 1}.0"


def _drop_channel(path: Path) -> None:
    with h5py.File(path, "r+") as f:
        del f["measured/f_piezo"]


def _alter_attribute(path: Path) -> None:
    with h5py.File(path, "r+") as f:
        f["measured/q_enc"].attrs["units"] = "deg"


FAULTS = {
    "flipped bytes": (_flip_bytes_in_data, ["sha256 differs", "content_sha256"], "content_sha256|corrupt"),
    "truncated": (_truncate, ["sha256 differs", "truncated or corrupt"], "truncated or corrupt"),
    "missing file": (lambda p: p.unlink(), ["listed in MANIFEST.sha256 but missing"], "does not exist"),
    "newer schema major": (_newer_major, ["schema version 2.0 is newer"], "schema version 2.0 is newer"),
    "missing channel": (_drop_channel, ["channel measured/f_piezo is missing"], "measured/f_piezo is missing"),
    "altered attribute": (_alter_attribute, ["sha256 differs", "content_sha256"], "content_sha256"),
}


@pytest.mark.parametrize("fault", list(FAULTS))
def test_faults_are_reported_by_verify_and_by_the_loader(campaign, fault, capsys):
    damage, verify_says, loader_says = FAULTS[fault]
    target = _first_trial(campaign)
    rel = target.relative_to(campaign).as_posix()
    damage(target)
    problems = verify(campaign)
    assert problems and all(p.file for p in problems)
    for text in verify_says:
        assert any(p.file == rel and text in p.message for p in problems), (text, [str(p) for p in problems])
    # the other trials are still fine and nothing else is blamed
    assert {p.file for p in problems} <= {rel, "index.csv"}
    with pytest.raises(TrialFileError, match=loader_says) as err:
        open_trial(target)
    assert str(target) in str(err.value)
    # the CLI prints each problem with its file and exits non-zero
    assert cli_main(["archive", "verify", str(campaign)]) == 1
    out = capsys.readouterr().out
    assert rel in out


def test_verify_reports_unlisted_and_leftover_temp_files(campaign):
    (campaign / "notes.txt").write_text("not part of the campaign")
    (campaign / "fixed/config1/zero/v1.500/.r01.nc.123-abcd.tmp").write_bytes(b"\x89HDF")
    found = {(p.file, p.message.split(" (")[0]) for p in verify(campaign)}
    assert ("notes.txt", "not in MANIFEST.sha256") in found
    assert ("fixed/config1/zero/v1.500/.r01.nc.123-abcd.tmp", "temporary file of an interrupted write") in found
    with pytest.raises(InputError, match="interrupted write"):
        finalize_campaign(campaign)


def test_verify_survives_a_file_that_crashes_the_hdf5_library(campaign, monkeypatch):
    """Some corruptions make HDF5 segfault instead of raising: verify checks each file in a child."""
    target = _first_trial(campaign)
    real = archive.read.inspect_trial

    def crashing(path, **kwargs):
        if Path(path) == target:
            faulthandler.disable()  # a real crash prints no Python traceback either
            os.kill(os.getpid(), signal.SIGSEGV)
        return real(path, **kwargs)

    monkeypatch.setattr(archive.read, "inspect_trial", crashing)
    problems = verify(campaign)
    assert [str(p) for p in problems] == [
        "fixed/config1/zero/v1.500/r00.nc: reading it crashed the HDF5 library (signal 11): the file is corrupt"]
    with pytest.raises(TrialFileError, match="crashed the HDF5 library"):
        finalize_campaign(campaign)


def test_isolated_check_names_the_crashing_file_and_checks_the_ones_after_it(campaign, monkeypatch, tmp_path):
    """All files are checked in one child; a crash costs that file only: the files after it
    are checked in a new child (a broken one among them is still reported)."""
    files = sorted(campaign.rglob("*.nc"))
    assert len(files) >= 3
    crash, broken = files[0], files[-1]
    _drop_channel(broken)
    real = archive.read.inspect_trial
    checkers = tmp_path / "checker-pids"

    def crashing(path, **kwargs):
        with open(checkers, "a") as fh:   # the children's memory is not ours: note the pid on disk
            fh.write(f"{os.getpid()}\n")
        if Path(path) == crash:
            faulthandler.disable()
            os.kill(os.getpid(), signal.SIGSEGV)
        return real(path, **kwargs)

    monkeypatch.setattr(archive.read, "inspect_trial", crashing)
    found = inspect_isolated_many(files)
    assert len(found) == len(files)
    assert "crashed the HDF5 library (signal 11)" in found[0][0]
    assert any("f_piezo" in p for p in found[-1])
    assert all(f == [] for f in found[1:-1])
    pids = checkers.read_text().split()
    assert len(pids) == len(files) and str(os.getpid()) not in pids   # every check ran in a child:
    assert len(set(pids)) == 2           # one for the crash, one for the files after it ...
    monkeypatch.setattr(archive.read, "inspect_trial", real)
    calls = []
    monkeypatch.setattr(os, "fork", lambda real_fork=os.fork: calls.append(1) or real_fork())
    inspect_isolated_many(files[1:-1])
    assert calls == [1]                  # ... and intact files cost one child in all


def test_finalize_refuses_a_broken_trial(campaign):
    _drop_channel(_first_trial(campaign))
    with pytest.raises(TrialFileError, match="f_piezo is missing"):
        finalize_campaign(campaign)


def test_random_byte_flips_never_load_silently_wrong_data(tmp_path):
    """Flip one byte anywhere: the loader raises naming the file, or returns the very same trial."""
    path = write_trial(synthetic_trial(duration=0.1), tmp_path / "t.nc")
    original = open_trial(path)
    raw = path.read_bytes()
    rng = np.random.default_rng(3)
    outcomes = {"raised": 0, "unchanged": 0}
    for pos in rng.integers(0, len(raw), 8):
        damaged = tmp_path / f"flip{pos}.nc"
        data = bytearray(raw)
        data[pos] ^= 0xFF
        damaged.write_bytes(bytes(data))
        try:
            loaded = open_trial(damaged)
        except TrialFileError as exc:
            assert str(damaged) in str(exc)
            outcomes["raised"] += 1
        else:
            xr.testing.assert_identical(loaded.drop_attrs(), original.drop_attrs())
            assert {k: v for k, v in loaded.attrs.items()} == original.attrs
            outcomes["unchanged"] += 1
    assert outcomes["raised"] > 0


# ---------------------------------------------------------------------------------------
# bad input: clear errors, exit status 2
# ---------------------------------------------------------------------------------------
def test_not_a_campaign_folder(tmp_path, capsys):
    empty = tmp_path / "empty"
    empty.mkdir()
    for call in (lambda: verify(empty), lambda: list_trials(empty), lambda: finalize_campaign(empty),
                 lambda: open_campaign(empty), lambda: verify(tmp_path / "nope")):
        with pytest.raises(InputError, match="is not a campaign folder"):
            call()
    for action in ("verify", "finalize", "ls"):
        assert cli_main(["archive", action, str(empty)]) == 2
        assert "is not a campaign folder" in capsys.readouterr().err


def test_unknown_filter_key(campaign, capsys):
    with pytest.raises(InputError, match="unknown filter key.*'colour'.*known keys: base"):
        list_trials(campaign, colour="red")
    with pytest.raises(InputError, match="filter config='one': expected int"):
        list_trials(campaign, config="one")
    assert cli_main(["archive", "ls", str(campaign), "--filter", "colour=red"]) == 2
    assert "unknown filter key" in capsys.readouterr().err
    assert cli_main(["archive", "ls", str(campaign), "--filter", "gain"]) == 2
    assert "key=value" in capsys.readouterr().err


def test_cli_ls_and_finalize(campaign, capsys):
    assert cli_main(["archive", "ls", str(campaign), "--filter", "base=fixed", "--filter", "config=1"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split()[:4] == ["path", "base", "config", "gain"] and len(out) == 3
    assert cli_main(["archive", "ls", str(campaign), "--format", "csv"]) == 0
    rows = list(csv.DictReader(capsys.readouterr().out.splitlines()))
    assert len(rows) == len(CELLS)
    (campaign / "MANIFEST.sha256").unlink()
    assert [p.file for p in verify(campaign)] == ["MANIFEST.sha256"]
    assert cli_main(["archive", "finalize", str(campaign)]) == 0
    assert verify(campaign) == []


def test_time_series_are_deflated_where_deflate_pays():
    """A uniform clock and a quantised channel compress and are deflated; white noise in
    float64 does not, and is stored contiguous; a small channel is deflated untested."""
    rng = np.random.default_rng(7)
    n = 20_000
    clock = np.arange(n) * 1e-4
    quantised = np.round(np.cumsum(rng.normal(size=n)) * 10) / 10
    noise = rng.normal(size=(n, 3))
    for data, deflated in ((clock, True), (quantised, True), (noise, False), (noise[:100], True)):
        enc = fileformat._encoding(("t_force",) + (("axis",) if data.ndim == 2 else ()), data)
        assert enc["zlib"] is deflated, data.shape
        assert enc["chunksizes"] is None if not deflated else enc["chunksizes"][0] == data.shape[0]
