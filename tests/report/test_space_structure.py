"""The report's products of both named structures: eq 8's validity map and Table 4 / Figure 9
under both structures, from the study's data (campaign.studies.space_structure)."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from campaign.model.paper import load_paper
from campaign.report.figures import validity
from campaign.report.tables import structures_table
from campaign.studies import FILES
from campaign.studies import space_structure as study


def _row(cell, ratio, err, truth_err=0.0):
    return {"structure": "space_class", "cell": cell, "ratio": ratio, "eq8": 10.0,
            "identified": 10.0 * (1 + err), "truth": 10.0 * (1 + truth_err)}


def test_holds_below_is_the_last_ratio_before_the_first_miss():
    rows = [_row("1-low", 0.01, 0.02), _row("1-high", 0.02, -0.049), _row("2-low", 0.05, 0.08),
            _row("2-high", 0.03, 0.01), _row("1-low", 0.2, 0.01)]
    # sorted by ratio: 0.01 ok, 0.02 ok, 0.03 ok, 0.05 misses -> 0.03; the later 0.2 does not count
    assert validity.holds_below(rows) == pytest.approx(0.03)
    assert validity.holds_below(rows, tolerance=0.1) == pytest.approx(0.2)
    assert validity.holds_below([_row("1-low", 0.01, 0.06)]) == 0.0
    assert validity.holds_below(rows, key="truth") == pytest.approx(0.2)


def _write_validity_csv(path, rows):
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["structure", "EI_scale", "cell", "speed_m_s", "f1_Hz", "f2_Hz", "Tc_s", "Tc_over_T1", "eq8_kg",
                    "identified_kg", "truth_kg"])
        for r in rows:
            w.writerow([r["structure"], 1, r["cell"], 1.5, 0.7, 7.0, 0.07, r["ratio"], r["eq8"], r["identified"],
                        r["truth"]])


def test_validity_figure_draws_one_series_per_cell_and_the_tolerance_band(tmp_path):
    rows = [_row("1-low", 0.01, 0.02), _row("1-low", 0.1, 0.2), _row("passive 1", 0.01, 0.01),
            _row("passive 1", 0.3, 0.1)]
    path = tmp_path / "v.csv"
    _write_validity_csv(path, rows)
    back = validity.read_rows(path)
    assert [(r["cell"], r["ratio"]) for r in back] == [(r["cell"], r["ratio"]) for r in rows]
    fig = validity.draw_validity(back, tolerance=0.05)
    ax = fig.axes[0]
    labels = [line.get_label() for line in ax.get_lines() if not line.get_label().startswith("_")]
    assert "1-low" in labels and "passive 1 (lambda = 0)" in labels
    assert ax.get_xscale() == "log"
    files = validity.make(path, tmp_path / "v.png", tmp_path / "v.pdf")
    assert all(Path(f).stat().st_size > 0 for f in files)
    empty = tmp_path / "e.csv"
    _write_validity_csv(empty, [])
    with pytest.raises(ValueError, match="no rows"):
        validity.read_rows(empty)


def test_structures_table_puts_each_structure_beside_the_paper(tmp_path):
    path = tmp_path / "s.csv"
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["structure", "cell", "f1_Hz", "Tc_over_T1", "eq8_kg", "identified_kg", "truth_kg",
                    "paper_experiment_kg", "paper_eq8_kg", "fig9_reduction", "fig9_eq8_reduction"])
        w.writerow(["space_class", "2-high", 0.7, 0.05, 40.0, 44.0, 43.0, 39.33, 38.99, 0.02, 0.035])
        w.writerow(["stiff_mast", "2-high", 4.4, 0.32, 40.0, 60.0, 61.0, 39.33, 38.99, 0.04, 0.03])
    t = structures_table(path, paper=load_paper())
    assert [r["structure"] for r in t.rows] == ["space_class", "stiff_mast"]
    assert t.rows[0]["ident_vs_eq8"] == pytest.approx(0.1)
    assert t.rows[1]["ident_vs_paper"] == pytest.approx(60.0 / 39.33 - 1)
    assert "paper experiment [kg]" in t.to_markdown()


def test_quick_study_writes_both_structures_and_the_map(tmp_path):
    """The study's reduced run (seconds): Table 4 under both structures and a validity map with
    a point per structure, Table 4 cell and passive configuration, each as the report reads it."""
    files = study.run(tmp_path, quick=True)
    assert sorted(Path(f).name for f in files) == sorted(FILES["space_structure"])
    t = structures_table(tmp_path / "table4_structures.csv", paper=load_paper())
    cells = {(r["structure"], r["cell"]) for r in t.rows}
    assert cells == {(s, c) for s in ("stiff_mast", "space_class") for c in ("1-low", "1-high", "2-low", "2-high")}
    f1 = {r["structure"]: r["f1"] for r in t.rows}
    assert 0.3 < f1["space_class"] < 1.0 < 3.0 < f1["stiff_mast"]
    assert all(0.0 < r["fig9"] < 1.0 for r in t.rows)
    rows = validity.read_rows(tmp_path / "eq8_validity.csv")
    assert {(r["structure"], r["cell"]) for r in rows} == {
        (s, c) for s in ("stiff_mast", "space_class")
        for c in ("1-low", "1-high", "2-low", "2-high", "passive 1", "passive 2")}
    # the passive arm's lambda is 0 exactly: eq 8 needs no identified lambda, and on the
    # space-class structure (T_c / T_1 ~ 0.05) it is within 10 % of the truth
    passive = [r for r in rows if r["cell"].startswith("passive") and r["structure"] == "space_class"]
    assert all(r["ratio"] < 0.1 and abs(r["truth"] / r["eq8"] - 1) < 0.1 for r in passive)


def test_base_fit_residuals_are_eq8_on_the_space_class_base_over_the_paper():
    """Part D without the fit: the space-class base's own residuals against the paper's eq 8 column."""
    (row,) = study.base_fit(fit=False)
    assert row["base"] == "space_class" and row["mass_kg"] > 0
    assert set(row) >= {f"residual_{c}" for c in ("1-low", "1-high", "2-low", "2-high")}
    assert all(abs(row[f"residual_{c}"]) < 0.3 for c in ("1-low", "1-high", "2-low", "2-high"))


def test_the_reference_archives_flexible_scene_is_todays_space_class():
    """The committed reference campaign (config/tests/reference.yaml) struck the space-class
    structure: selecting it gives that trial's scene, every rig value and the seed, so its
    trials are today's."""
    from campaign.archive import open_trial_arrays
    from campaign.scene.description import Scene, make_scene

    ref = Path(__file__).resolve().parents[2] / "archive" / "reference" / "flexible" / "config1" / "low"
    trial = sorted(ref.glob("v2.500/r00.nc"))[0]
    stored = Scene.from_json(str(open_trial_arrays(trial, group="measured").attrs["scene_json"]))
    now = make_scene(base="flexible", config=1, gain="low", speed=2.5, repeat=0, campaign_seed=1996,
                     params={"flexible.structure": "space_class"})
    assert now.param_dict == stored.param_dict
    assert now.seed == stored.seed


def test_structure_is_read_from_the_stored_scene():
    """A trial's structure is the named one whose values it holds: the reference's, one
    stored before structures were named (no ``flexible.structure`` key, the stiff mast's
    values), a named one with a changed value says so, and an unknown one is unnamed."""
    from campaign.archive import open_trial_arrays
    from campaign.pipeline.paths import index_cells
    from campaign.scene.description import (
        Scene,
        make_scene,
        structure_of,
        trial_structures,
    )

    root = Path(__file__).resolve().parents[2] / "archive" / "reference"
    trial = sorted((root / "flexible" / "config1" / "low").glob("v2.500/r00.nc"))[0]
    stored = Scene.from_json(str(open_trial_arrays(trial, group="measured").attrs["scene_json"]))
    assert structure_of(stored.param_dict) == "space_class"
    unnamed_key = {k: v for k, v in make_scene(base="flexible", params={"flexible.structure": "stiff_mast"})
                   .param_dict.items() if k != "flexible.structure"}
    assert structure_of(unnamed_key) == "stiff_mast"
    for name in ("stiff_mast", "space_class"):
        assert structure_of(make_scene(base="flexible", params={"flexible.structure": name}).param_dict) == name
    soft = make_scene(base="flexible", params={"flexible.structure": "space_class", "flexible.beam_EI": 1e8})
    assert structure_of(soft.param_dict) == "space_class with flexible.beam_EI changed"
    odd = dict(unnamed_key, **{"flexible.beam_length": 33.0})
    assert structure_of(odd) == "unnamed"
    flexible = [p for cell, paths in index_cells(root).items() if cell[0] == "flexible" for p in paths]
    assert flexible and trial_structures(flexible) == ["space_class"]
