"""The campaign's plan (campaign.pipeline.campaign_plan) asked directly, without Snakemake:
sweeps, cells and job units, reused archives, trials, every product's requirement and
refusal, the default targets, the jobs' outputs, the studies' and the designed campaign's files."""

from __future__ import annotations

import copy
import csv
import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from campaign import studies as study_registry
from campaign.core import vocabulary
from campaign.core.errors import InputError
from campaign.core.yamlfile import config_file
from campaign.pipeline.campaign_plan import ARCHIVE_FILES, CampaignPlan
from campaign.pipeline.plan_parts import FIGURES, PRIORITY, STUDY_PRODUCTS, TABLES, DesignedPlan, Output, StudiesPlan

REPO = Path(__file__).resolve().parents[2]
SCHEMA = yaml.safe_load((REPO / "workflow" / "schemas" / "config.schema.yaml").read_text())
CI = yaml.safe_load((REPO / "config" / "tests" / "ci.yaml").read_text())
PUMA = "configuration key bases.fixed.configurations"
FIT_TEXT = "bases.fixed with configurations 1-3, gain high and zero or low"
OTHER_ARM = "needs the paper's robot puma560 (its configurations and published values; this campaign simulates planar2)"


def config(tmp_path: Path, **changes) -> dict:
    """config/tests/ci.yaml into tmp_path's folders, the schema's top-level defaults filled in, the figures'
    default trials (the highest speed), ``changes`` applied."""
    cfg = {k: copy.deepcopy(v["default"]) for k, v in SCHEMA["properties"].items() if "default" in v}
    cfg.update(copy.deepcopy(CI), archive_root=str(tmp_path / "archive"), results_root=str(tmp_path / "results"),
               figures={})
    for key, value in changes.items():
        cfg[key] = value
    return cfg


def plan(tmp_path: Path, **changes) -> CampaignPlan:
    return CampaignPlan.from_config(config(tmp_path, **changes))


def bases(fixed=None, flexible=None) -> dict:
    return {"fixed": fixed, "flexible": flexible}


FULL_FIXED = {"configurations": [1, 2, 3], "gains": ["zero", "low", "high"]}
CI_FLEXIBLE = {"configurations": [1, 2], "gains": ["low", "high"], "structure": "space_class"}


# ------------------------------------------------------------------------------------------
# start-up cost, sweeps, cells, job units
# ------------------------------------------------------------------------------------------
def test_importing_the_plan_loads_no_numerical_library():
    code = ("import sys, campaign.pipeline.campaign_plan; "
            "print(sorted(m for m in ('numpy', 'pinocchio', 'h5py', 'xarray', 'matplotlib', 'scipy') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_sweeps_fill_in_the_global_speeds_and_repeats_and_skip_a_null_base(tmp_path):
    p = plan(tmp_path, speeds=[2.5, 1.5], repeats=2,
             bases=bases({"configurations": [3, 1], "gains": ["high", "zero"], "speeds": [2.0], "repeats": 1}))
    assert p.sweeps == {"fixed": {"configurations": [1, 3], "gains": ["zero", "high"], "speeds": [2.0], "repeats": 1}}
    assert p.cells("flexible") == [] and p.units("flexible") == []
    p = plan(tmp_path, speeds=[2.5, 1.5], repeats=2)
    assert p.sweeps["fixed"]["speeds"] == [2.5, 1.5] and p.sweeps["fixed"]["repeats"] == 2


def test_cells_are_gain_major_and_restrictable(tmp_path):
    p = plan(tmp_path)
    assert p.cells("flexible") == [("flexible", 1, "low"), ("flexible", 2, "low"), ("flexible", 1, "high"),
                                   ("flexible", 2, "high")]
    assert p.cells("fixed", configs=[2], gains=["zero", "high"]) == [("fixed", 2, "zero"), ("fixed", 2, "high")]


def test_a_sweep_job_covers_a_base_and_gain_set(tmp_path):
    p = plan(tmp_path)
    archive, results = tmp_path / "archive" / "ci", tmp_path / "results" / "ci"
    assert p.units("fixed") == [{"gain": "zero"}, {"gain": "low"}, {"gain": "high"}]
    assert p.unit_name("fixed") == "fixed/{gain}"
    assert p.job_manifest_pattern("fixed") == f"{archive}/.jobs/fixed/{{gain}}.json"
    assert p.unit_cells("fixed", {"gain": "low"}) == [("fixed", c, "low") for c in (1, 2, 3)]
    assert p.unit_sources("fixed", {"gain": "low"}) == [f"{archive}/.jobs/fixed/low.json"]
    assert p.ident_tables("fixed") == [f"{results}/identify/fixed/{g}.csv" for g in ("zero", "low", "high")]
    assert p.ident_tables("fixed", configs=[2], gains=["high"]) == [f"{results}/identify/fixed/high.csv"]
    assert p.all_job_manifests() == [f"{archive}/.jobs/{b}/{g}.json" for b, gs in
                                     (("fixed", ("zero", "low", "high")), ("flexible", ("low", "high"))) for g in gs]
    assert p.identify_units("flexible")[0] == {
        "name": "flexible/low", "sources": [f"{archive}/.jobs/flexible/low.json"],
        "csv": f"{results}/identify/flexible/low.csv", "log": f"{results}/logs/identify_flexible/flexible/low.log"}
    assert p.identify_logs("flexible") == [f"{results}/logs/identify_flexible.log",
                                           f"{results}/logs/identify_flexible/flexible/low.log",
                                           f"{results}/logs/identify_flexible/flexible/high.log"]


def test_a_cell_job_covers_one_cell(tmp_path):
    p = plan(tmp_path, job_unit="cell")
    archive, results = tmp_path / "archive" / "ci", tmp_path / "results" / "ci"
    assert p.units("flexible") == [{"config": 1, "gain": "low"}, {"config": 2, "gain": "low"},
                                   {"config": 1, "gain": "high"}, {"config": 2, "gain": "high"}]
    assert p.unit_name("fixed") == "fixed/config{config}/{gain}"
    assert p.job_manifest_pattern("fixed") == f"{archive}/.jobs/fixed/config{{config}}/{{gain}}.json"
    assert p.unit_cells("fixed", {"config": "2", "gain": "low"}) == [("fixed", 2, "low")]
    assert p.ident_tables("fixed", configs=[2], gains=["high"]) == [f"{results}/identify/fixed/config2/high.csv"]
    assert len(p.all_job_manifests()) == 9 + 4 == len(set(p.all_job_manifests()))
    assert p.log_file("simulate_fixed", p.unit_name("fixed")) == \
        f"{results}/logs/simulate_fixed/fixed/config{{config}}/{{gain}}.log"
    assert p.bench_file("identify_fixed") == f"{results}/benchmarks/identify_fixed.tsv"


def test_the_flexible_sweep_names_its_structure_and_an_unknown_one_is_refused(tmp_path):
    p = plan(tmp_path, rig_params={"contact.stiffness": 2e6})
    assert p.sweep_params("flexible") == {"contact.stiffness": 2e6, "flexible.structure": "space_class"}
    assert p.sweep_params("fixed") == {"contact.stiffness": 2e6}
    assert p.shown_structure == "space_class"
    with pytest.raises(InputError, match=r"^configuration key bases.flexible.structure: unknown structure 'kite'; "
                                         r"the rig file .*rig.yaml names \["):
        plan(tmp_path, bases=bases(FULL_FIXED, {**CI_FLEXIBLE, "structure": "kite"}))


def test_a_configuration_the_robot_does_not_name_is_refused(tmp_path):
    with pytest.raises(InputError, match=re.escape(f"{PUMA}: robot puma560 names no configuration [4] "
                                                   "(its configurations: [1, 2, 3])")):
        plan(tmp_path, bases=bases({"configurations": [1, 4], "gains": ["zero"]}))


# ------------------------------------------------------------------------------------------
# re-analysing an archive
# ------------------------------------------------------------------------------------------
def fake_archive(root: Path, cells, speeds=(1.0, 2.5), repeats=2) -> Path:
    """An archive folder with an index.csv listing ``cells`` (no trial files)."""
    root.mkdir(parents=True)
    with open(root / "index.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["path", "base", "config", "gain", "speed", "repeat"])
        for b, c, g in cells:
            for v in speeds:
                for r in range(repeats):
                    w.writerow([vocabulary.trial_relpath(b, c, g, v, r), b, c, g, v, r])
    return root


def test_reuse_takes_the_sweeps_from_the_archive_and_the_cells_the_configuration_lists(tmp_path):
    held = [("fixed", c, g) for c in (1, 2, 3) for g in ("zero", "low", "high")]
    root = fake_archive(tmp_path / "old" / "held", held)
    p = plan(tmp_path, simulate=False, reuse_archive=f"{root}/",
             bases=bases({"configurations": [1, 2, 3], "gains": ["zero", "high"]}, CI_FLEXIBLE))
    assert p.trial_root == str(root) and p.results == f"{tmp_path}/results/reuse-held"
    assert p.sweeps == {"fixed": {"configurations": [1, 2, 3], "gains": ["zero", "high"], "speeds": [1.0, 2.5],
                                  "repeats": 2}}
    assert sorted(p.reused) == sorted(c for c in held if c[2] != "low")
    assert p.unit_sources("fixed", {"gain": "high"}) == [
        f"{root}/{vocabulary.trial_relpath('fixed', c, 'high', v, r)}" for c in (1, 2, 3) for v in (1.0, 2.5)
        for r in (0, 1)]
    assert p.default_targets()[-1] == f"{tmp_path}/results/reuse-held/archive_verify.txt" == p.verify_file
    assert p.missing_requirement("fig9") == "needs bases.flexible with configurations 1, 2 and gains low, high"
    # a figure's trial is the reused file itself, once it is there
    with pytest.raises(InputError, match=r"^figures.fig5: trial .*fixed/config1/zero/v2.500/r00.nc is not in "
                                         r"reuse_archive"):
        p.figure_sources("fig5")
    trial = root / vocabulary.trial_relpath("fixed", 1, "zero", 2.5, 0)
    trial.parent.mkdir(parents=True)
    trial.touch()
    assert p.figure_sources("fig5") == {"1-zero": (str(trial), str(trial))}


@pytest.mark.parametrize("case, message", [
    ("unset", "configuration key reuse_archive: simulate is false, so reuse_archive must name an archive folder"),
    ("missing", "configuration key reuse_archive: '{root}' is not a folder (simulate is false: nothing is simulated)"),
    ("no index", "configuration key reuse_archive: {root}: no index.csv (finalize it first"),
    ("other cells", "configuration key reuse_archive: '{root}' holds no trial of the cells bases: lists (it holds "
                    "['fixed'] bases)"),
])
def test_reuse_refusals(tmp_path, case, message):
    root = tmp_path / "old"
    if case == "no index":
        root.mkdir()
    elif case == "other cells":
        fake_archive(root, [("fixed", 3, "low")])
    changes = {"simulate": False, "reuse_archive": None if case == "unset" else str(root)}
    with pytest.raises(InputError) as info:
        plan(tmp_path, bases=bases({"configurations": [1], "gains": ["zero", "high"]}), **changes)
    assert str(info.value).startswith(message.format(root=root))


def test_reuse_of_the_reference_archive_shows_its_own_structure(tmp_path):
    p = plan(tmp_path, simulate=False, reuse_archive=str(REPO / "archive" / "reference"), bases=bases(
        FULL_FIXED, {"configurations": [1, 2, 3], "gains": ["zero", "low", "high"], "structure": "space_class"}))
    index = list(csv.DictReader(open(REPO / "archive" / "reference" / "index.csv")))
    assert {b: (s["speeds"], s["repeats"]) for b, s in p.sweeps.items()} == {
        b: (sorted({float(r["speed"]) for r in index if r["base"] == b}),
            max(int(r["repeat"]) for r in index if r["base"] == b) + 1) for b in ("fixed", "flexible")}
    assert sum(len(v) for v in p.reused.values()) == len(index)
    assert p.shown_structure and not p.missing_requirement("table4")


# ------------------------------------------------------------------------------------------
# trials
# ------------------------------------------------------------------------------------------
def test_one_trial_of_the_campaign_and_one_it_does_not_run(tmp_path):
    p = plan(tmp_path)
    assert p.single_trial(base="fixed", config="2", gain="low", speed="1.500", repeat="00") == {
        "base": "fixed", "config": 2, "gain": "low", "speed": 1.5, "repeat": 0, "repeats": 1}
    values = {"base": "fixed", "config": "2", "gain": "low", "speed": "1.500", "repeat": "00"}
    assert p.trial_pattern().format(**values) == f"{tmp_path}/archive/ci/fixed/config2/low/v1.500/r00.nc"
    assert all(re.fullmatch(rx, values[k]) for k, rx in vocabulary.trial_wildcards().items())
    assert p.trial_log_pattern() == f"{tmp_path}/results/ci/logs/simulate_trial/{{base}}/config{{config}}/{{gain}}/" \
                                    "v{speed}/r{repeat}.log"
    with pytest.raises(InputError, match=re.escape(
            "fixed/config2/low/v9.000/r00.nc is not a trial of campaign ci: bases.fixed runs configurations "
            "[1, 2, 3], gains ['zero', 'low', 'high'], speeds [1.5, 2.5] m/s and repeats 0-0")):
        p.single_trial(base="fixed", config="2", gain="low", speed="9.000", repeat="00")
    with pytest.raises(InputError, match="is not a trial of campaign ci: it has no flexible base"):
        plan(tmp_path, bases=bases(FULL_FIXED)).single_trial(base="flexible", config=1, gain="low", speed=1.5,
                                                             repeat=0)


def test_the_single_trial_figures_show_their_cells_at_the_picked_speed(tmp_path):
    p = plan(tmp_path, figures={"fig9": {"speed": 1.5, "repeat": 0}})
    archive = f"{tmp_path}/archive/ci"
    assert p.figure_pick("fig5") == (2.5, 0) and p.figure_pick("fig9") == (1.5, 0)
    assert p.figure_trials("fig9") == {f"{c}-{g}": f"{archive}/flexible/config{c}/{g}/v1.500/r00.nc"
                                       for c in (1, 2) for g in ("low", "high")}
    assert p.figure_inputs("fig9") == [f"{archive}/.jobs/flexible/high.json", f"{archive}/.jobs/flexible/low.json"]
    assert p.figure_inputs("fig5") == [f"{archive}/.jobs/fixed/zero.json"]


@pytest.mark.parametrize("figures, message", [
    ({"fig5": {"speed": 2.0}}, "configuration key figures.fig5.speed: 2 m/s is not one of the fixed-base speeds "
                               "[1.5, 2.5]"),
    ({"fig9": {"repeat": 3}}, "configuration key figures.fig9.repeat: 3 but the flexible base runs 1 repeat(s)"),
])
def test_a_trial_pick_the_campaign_does_not_hold_is_refused_at_start_up(tmp_path, figures, message):
    with pytest.raises(InputError, match=re.escape(message)):
        plan(tmp_path, figures=figures)


def test_a_trial_source_outside_the_sweep_names_the_key(tmp_path):
    p = plan(tmp_path, bases=bases({"configurations": [1, 2], "gains": ["low"]}))
    with pytest.raises(InputError, match=re.escape("configuration key figures.fig5 needs cell fixed/config1/zero, "
                                                   "which bases.fixed does not list")):
        p.trial_source("fixed", 1, "zero", 2.5, 0, key="figures.fig5")


# ------------------------------------------------------------------------------------------
# every product: what it requires, and the refusal naming what is missing
# ------------------------------------------------------------------------------------------
STUDY_MISSING = "needs the study {s} listed under the configuration key studies: (or `snakemake study_{s}` alone)"
REQUIREMENTS = {
    # case: (bases, extra configuration keys, {product: requirement} of the products that cannot be made)
    "ci": (bases(FULL_FIXED, CI_FLEXIBLE), {}, {}),
    "two fixed configurations": (bases({"configurations": [1, 2], "gains": ["zero", "low", "high"]}, CI_FLEXIBLE), {}, {
        "plan_maps": f"needs the fixed-base fit ({FIT_TEXT})", "table2": f"needs {FIT_TEXT}",
        "table3": f"needs {FIT_TEXT}", "table4": f"needs the fixed-base fit ({FIT_TEXT})"}),
    "no high gains": (bases({"configurations": [1, 2, 3], "gains": ["zero", "low"]}, CI_FLEXIBLE), {}, {
        "plan_maps": f"needs the fixed-base fit ({FIT_TEXT})", "table2": f"needs {FIT_TEXT}",
        "table3": f"needs {FIT_TEXT}", "table4": f"needs the fixed-base fit ({FIT_TEXT})"}),
    "no zero gains": (bases({"configurations": [1, 2, 3], "gains": ["low", "high"]}, CI_FLEXIBLE), {}, {
        "fig5": "needs bases.fixed with configuration 1 and gain zero"}),
    "no fixed base": (bases(None, CI_FLEXIBLE), {}, {
        "fig5": "needs bases.fixed with configuration 1 and gain zero", "fig6": "needs bases.fixed",
        "fig7": "needs bases.fixed", "plan_maps": f"needs the fixed-base fit ({FIT_TEXT})",
        "table2": f"needs {FIT_TEXT}", "table3": f"needs {FIT_TEXT}",
        "table4": f"needs the fixed-base fit ({FIT_TEXT})"}),
    "no flexible base": (bases(FULL_FIXED), {}, {
        "fig9": "needs bases.flexible with configurations 1, 2 and gains low, high",
        "table4": "needs bases.flexible with gain low or high"}),
    "zero-gain flexible base": (bases(FULL_FIXED, {"configurations": [1, 2], "gains": ["zero"]}), {}, {
        "fig9": "needs bases.flexible with configurations 1, 2 and gains low, high",
        "table4": "needs bases.flexible with gain low or high"}),
    "one flexible configuration": (bases(FULL_FIXED, {"configurations": [1], "gains": ["low", "high"]}), {}, {
        "fig9": "needs bases.flexible with configurations 1, 2 and gains low, high"}),
    "studies": (bases(FULL_FIXED, CI_FLEXIBLE), {"studies": ["space_structure", "plan_rig_check"]}, None),
    "another robot": (bases(FULL_FIXED), {"rig_params": {"robot": "planar2"}},
                      {p: OTHER_ARM for p in FIGURES + TABLES if p != "fig7"}),
}


@pytest.mark.parametrize("case", REQUIREMENTS)
def test_every_product_says_what_it_requires(tmp_path, case):
    bases_, extra, missing = REQUIREMENTS[case]
    p = plan(tmp_path, bases=bases_, **extra)
    if missing is None:         # the studies listed: every product can be made
        missing = {}
    elif case != "another robot":
        missing = {**{prod: STUDY_MISSING.format(s=s) for prod, s in STUDY_PRODUCTS.items()}, **missing}
    assert {prod: p.missing_requirement(prod) for prod in FIGURES + TABLES if p.missing_requirement(prod)} == missing
    for product in FIGURES + TABLES:
        if product in missing:
            with pytest.raises(InputError) as info:
                p.requires(product)
            assert str(info.value) == f"{product} cannot be made from campaign 'ci': it {missing[product]}"
        else:
            files = p.requires(product)
            assert files == p.product_files(product) and files and all(f.startswith(str(tmp_path)) for f in files)
    assert [line.split(": skipping ")[1] for line in p.skipped() if "lambda fits" not in line] == \
        [f"{prod}: it {missing[prod]}" for prod in FIGURES + TABLES if prod in missing]


def test_an_unknown_product_is_refused(tmp_path):
    with pytest.raises(InputError, match="unknown product 'fig10'"):
        plan(tmp_path).requires("fig10")


@pytest.mark.parametrize("fixed, robot, why", [
    (FULL_FIXED, None, ""),
    ({"configurations": [1, 2], "gains": ["high"]}, None,
     "needs bases.fixed with at least 3 configurations (robot puma560 has 3 joints, one lambda_j each)"),
    (None, None, "needs bases.fixed with the gains of a gain class"),
    ({"configurations": [1, 2], "gains": ["zero"]}, "planar2", ""),
    ({"configurations": [1], "gains": ["zero", "high"]}, "planar2",
     "needs bases.fixed with at least 2 configurations (robot planar2 has 2 joints, one lambda_j each)"),
])
def test_the_lambda_fits_need_a_configuration_per_joint_and_the_fixed_base_job_makes_what_is_asked(
        tmp_path, fixed, robot, why):
    p = plan(tmp_path, bases=bases(fixed), rig_params={"robot": robot} if robot else {})
    assert p.fit_requirement() == why
    made = {o.path for o in p.fixed_base_outputs().values()}
    fits = set(p.fit_jsons().values())
    assert (fits <= made and fits <= set(p.default_targets())) if not why else not fits & made
    if why:
        assert f"campaign ci: skipping the lambda fits: it {why}" in p.skipped()


# ------------------------------------------------------------------------------------------
# the default target and the jobs after the simulations
# ------------------------------------------------------------------------------------------
def test_the_default_target_of_the_reduced_campaign(tmp_path):
    p = plan(tmp_path)
    res = f"{tmp_path}/results/ci"
    targets = p.default_targets()
    assert targets[:2] == [f"{res}/figures/fig4.png", f"{res}/figures/fig4.pdf"]
    assert targets[-1] == f"{tmp_path}/archive/ci/MANIFEST.sha256" == p.archive_files()["manifest"]
    assert {f"{res}/fit/lambda_zero_low.json", f"{res}/fit/lambda_high.json", f"{res}/tables/table4.md",
            f"{res}/figures/plan_workspace.png", f"{res}/figures/plan_directions.pdf"} <= set(targets)
    assert len(targets) == len(set(targets)) and not any("/studies/" in t for t in targets)
    assert p.calibration_targets() == [f"{res}/calibration/calibration.md", f"{res}/calibration/calibration.html"]
    export = str(tmp_path / "id.csv")
    assert plan(tmp_path, identification_csv=export).default_targets()[-1] == export
    studies = plan(tmp_path, studies=["emulation_error"]).default_targets()
    assert [t for t in studies if t not in targets] == [f"{tmp_path}/results/studies/emulation_error/{f}" for f in
                                                        ("emulation_error.csv", "traces.csv", "emulation_error.png")]
    assert plan(tmp_path, bases=bases(FULL_FIXED)).calibration_targets() == []


def test_the_fixed_and_flexible_base_jobs_outputs(tmp_path):
    p = plan(tmp_path)
    res = f"{tmp_path}/results/ci"
    assert p.fixed_base_products() == ["fit_zero_low", "fit_high", "table2", "table3", "fig6", "fig7"]
    out = p.fixed_base_outputs()
    assert out["fit_high"] == Output(f"{res}/fit/lambda_high.json")
    assert out["table3_html"] == Output(f"{res}/tables/table3.html", {
        "caption": "table3", "category": "Virtual rotor inertia (lambda)", "subcategory": "Tables",
        "labels": {"table": "Table 3"}})
    assert out["fig6_pdf"].report == {"caption": "fig6", "category": "Fixed base", "subcategory": "Figures",
                                      "labels": {"figure": "Figure 6", "format": "vector PDF"}}
    assert [k for k, o in out.items() if o.report] == ["table2_html", "table3_html", "fig6_png", "fig6_pdf",
                                                       "fig7_png", "fig7_pdf"]
    assert p.fixed_base_logs()["fit_zero_low"] == f"{res}/logs/fit_lambda/zero_low.log"
    assert list(p.fixed_base_logs())[-1] == "job"
    assert p.flexible_base_products() == ["table4", "calibration"]
    assert list(p.flexible_base_outputs()) == ["table4_csv", "table4_md", "table4_html", "calibration_md",
                                               "calibration_html", "calibration_csv"]
    inputs = p.flexible_base_inputs()
    assert inputs["trials"] == p.figure_inputs("fig9") and inputs["model"] == str(config_file("response_model.json"))
    assert inputs["tables"] == p.ident_tables("flexible") and inputs["high"] == f"{res}/fit/lambda_high.json"
    assert p.flexible_base_logs() == {"table4": f"{res}/logs/table4.log",
                                      "calibration": f"{res}/logs/calibration_report.log",
                                      "job": f"{res}/logs/flexible_base.log"}
    maps = p.planner_map_outputs()
    assert [o.path for o in maps.values()] == p.figure_files("plan_maps")
    assert maps["directions_pdf"].report["labels"] == {"map": "directions", "format": "vector PDF"}
    # a fixed sweep only: Figures 6-7 and no flexible-base job
    only = plan(tmp_path, bases=bases({"configurations": [1], "gains": ["zero"]}))
    assert only.fixed_base_products() == ["fig6", "fig7"] and only.flexible_base_products() == []


def test_the_rules_priorities_are_named(tmp_path):
    text = "\n".join(f.read_text() for f in (REPO / "workflow" / "rules").glob("*.smk"))
    named = set(re.findall(r'PRIORITY\["(\w+)"\]', text))
    named |= {f"{stage}_{b}" for stage in ("simulate", "identify") for b in vocabulary.bases()}
    assert named == set(PRIORITY)


def test_no_rule_file_spells_a_path_and_the_wiring_stays_small():
    """The plan owns the layout: a rule file's only path strings are Snakemake's own, relative to it."""
    rules = REPO / "workflow" / "rules"
    literals = {(f.name, s) for f in rules.glob("*.smk") for s in re.findall(r'"([^"\n]*)"', f.read_text())}
    assert {(f, s) for f, s in literals if "/" in s and not s.startswith("../")} == \
        {("common.smk", "config/config.yaml")}
    files = {f for names in study_registry.FILES.values() for f in names}
    assert {s for _, s in literals if re.search(r"\.(nc|csv|json|md|png|pdf|html|tsv|log)$", s)} <= files
    assert len((rules / "common.smk").read_text().splitlines()) <= 150


def test_the_archive_files_agree_with_the_archive_format(tmp_path):
    from campaign.archive import fileformat

    assert ARCHIVE_FILES == {"index": fileformat.INDEX, "readme": fileformat.README, "manifest": fileformat.MANIFEST}
    assert plan(tmp_path).job_manifest("fixed", {"gain": "zero"}) == \
        f"{tmp_path}/archive/ci/{fileformat.JOBS}/fixed/zero.json"


# ------------------------------------------------------------------------------------------
# the studies and the designed campaign
# ------------------------------------------------------------------------------------------
def test_the_studies_files(tmp_path):
    s = StudiesPlan(results_root=str(tmp_path), selected=["space_structure"], quick=True)
    folder = f"{tmp_path}/studies/space_structure/quick"
    assert s.dir("space_structure") == folder and s.output("space_structure", "lambda.csv") == f"{folder}/lambda.csv"
    with pytest.raises(InputError, match="study space_structure writes no 'lambda.json'"):
        s.output("space_structure", "lambda.json")
    assert s.log("space_structure", "eq8_validity") == f"{folder}/logs/eq8_validity.log"
    assert s.report_files("eq8_validity") == [f"{folder}/report/eq8_validity.png", f"{folder}/report/eq8_validity.pdf"]
    shown = s.report_outputs("table4_structures", caption="t", category="c", subcategory="s", labels={"table": "T"})
    assert {k: bool(o.report) for k, o in shown.items()} == {"csv": False, "md": False, "html": True}
    assert shown["html"].report == {"caption": "t", "category": "c", "subcategory": "s", "labels": {"table": "T"}}
    assert s.targets() == s.files("space_structure") and s.files("space_structure")[-1].endswith("eq8_validity.pdf")
    assert set(s.all_files()) >= set(s.targets()) and set(s.names) == set(yaml.safe_load(
        (REPO / "workflow" / "schemas" / "config.schema.yaml").read_text())["properties"]["studies"]["items"]["enum"])


def test_the_designed_campaign_files(tmp_path):
    p = plan(tmp_path)
    d = p.designed
    settings = yaml.safe_load(config_file("designed.yaml").read_text())
    res = f"{tmp_path}/results/{settings['campaign']}"
    assert d.settings == settings and d.results == res and d.path("model_md") == f"{res}/model/response_model.md"
    assert d.tables("heldout") == [f"{res}/identification/heldout_{g}.csv" for g in vocabulary.gain_sets()]
    assert d.structures == sorted(yaml.safe_load(config_file("rig.yaml").read_text())["structures"])
    assert len(d.flexible_tables()) == len(d.structures) * len(vocabulary.gain_sets())
    assert d.study_inputs() == d.tables("designed") + d.tables("heldout")
    assert d.structure_archive("mast") == f"{tmp_path}/archive/{settings['campaign']}/structures/mast"
    assert d.log("designed_trials", "paper_zero") == f"{res}/logs/designed_trials/paper_zero.log"
    with pytest.raises(InputError, match="configuration key designed: '.*nothing.yaml' does not exist"):
        plan(tmp_path, designed=str(tmp_path / "nothing.yaml"))
    absent = DesignedPlan(settings_file=str(tmp_path / "none.yaml"), named=False, results_root="r", archive_root="a",
                          structures=[])
    assert absent.settings is None
    with pytest.raises(InputError, match="study impact_resistance needs the designed campaign's settings"):
        absent.study_inputs()


# ------------------------------------------------------------------------------------------
# the vocabulary's trial layout and the paper's conventions the plan reads
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("cell", [("fixed", 1, "zero", 2.5, 0), ("flexible", 3, "high", 1.125, 17)])
def test_a_trial_path_reads_back_as_its_cell(cell):
    base, config, gain, speed, repeat = cell
    rel = vocabulary.trial_relpath(*cell)
    assert vocabulary.parse_trial_relpath(f"archive/x/{rel}") == {
        "base": base, "pose": f"config{config}", "config": config, "gain": gain, "speed": speed, "repeat": repeat}
    assert vocabulary.trial_pattern().format(base=base, config=config, gain=gain, speed=rel.split("/")[3][1:],
                                             repeat=rel.split("/")[4][1:3]) == rel


@pytest.mark.parametrize("path", ["fixed/config1/zero/v2.5/r00.nc", "fixed/config1/zero/v2.500/r0.nc",
                                  "fixed/config1/medium/v2.500/r00.nc", "config1/zero/v2.500/r00.nc",
                                  "fixed/config1/zero/v-1.000/r00.nc", "fixed/config1/zero/v2.500/r00.h5"])
def test_a_path_outside_the_trial_layout_is_refused_naming_it(path):
    with pytest.raises(InputError, match=re.escape(f"{path}: not a trial path")):
        vocabulary.parse_trial_relpath(path)


def test_table2_columns_and_figure_cells_come_from_the_paper_file():
    paper = yaml.safe_load(config_file("paper.yaml").read_text())
    assert vocabulary.table2_columns() == paper["table2_columns"] == {"m2": "zero_low", "m3": "high"}
    assert [vocabulary.table2_column(g) for g in vocabulary.gain_sets()] == ["m2", "m2", "m3"]
    assert vocabulary.figure_cells("fig9") == (("flexible", 1, "low"), ("flexible", 1, "high"),
                                               ("flexible", 2, "low"), ("flexible", 2, "high"))
    assert vocabulary.figure_cells("fig5") == (("fixed", 1, "zero"),)
    with pytest.raises(InputError, match="unknown single-trial figure 'fig6'"):
        vocabulary.figure_cells("fig6")
    with pytest.raises(InputError, match="gain set 'medium' is in no column of Table 2"):
        vocabulary.table2_column("medium")
