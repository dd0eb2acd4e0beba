# Helpers of the campaign workflow: the configuration (validated at start-up), where every
# file lives, which job manifests, trials and identification tables each product needs, and
# the targets.
#
# Only the standard library, PyYAML and the package's start-up modules (campaign.core.vocabulary,
# campaign.model.conventions, campaign.pipeline.paths, .config, .digests: standard library and
# PyYAML at import) are imported
# here: Snakemake evaluates this file every time it starts, a dry run included, so the heavy
# stages (numpy, pinocchio, xarray, matplotlib) load in the jobs only.
#
# What Snakemake plans grows with the jobs, not with the trials: a simulation job's only
# declared output is its job manifest (campaign.archive.jobs), which lists the trial files it
# wrote; the jobs downstream take the manifests as input and read their trials from them.

import os
import sys
from pathlib import Path

import yaml
from snakemake.exceptions import WorkflowError
from snakemake.utils import min_version, validate

from campaign import studies as study_registry   # names and files only: it imports nothing
from campaign.core import vocabulary
from campaign.core.errors import InputError
from campaign.core.yamlfile import config_file
from campaign.model import conventions
from campaign.pipeline import config as config_checks
from campaign.pipeline import digests, paths

min_version("9.0")

# Every job imports the campaign package of this workflow's own source tree, whatever
# environment runs it (.venv with the editable install, or a conda env of workflow/envs).
os.environ.update(PYTHONPATH=os.pathsep.join(p for p in (workflow.basedir, os.environ.get("PYTHONPATH")) if p))


configfile: "config/config.yaml"


# --config values arrive as strings unless Snakemake recognises them (simulate=false,
# speeds=[1.0,2.5]): read the command line's (not a file's) as the schema's types, then validate
SCHEMA_FILE = Path(workflow.basedir, "workflow", "schemas", "config.schema.yaml")
# (one line naming the key), then let Snakemake's validate fill in the schema's defaults
with open(SCHEMA_FILE, encoding="utf-8") as _fh:
    _schema = yaml.safe_load(_fh)
config_checks.parse_typed_strings(config, _schema, given=workflow.config_settings.config)
try:
    config_checks.check_environment()
    config_checks.check_schema(config, _schema)
    # the folders and files the configuration names, before anything reads them
    config_checks.check_paths(config)
except InputError as _exc:
    raise WorkflowError(str(_exc)) from None
validate(config, schema="../schemas/config.schema.yaml")


report: "../report/workflow.rst"


wildcard_constraints:
    gain="|".join(vocabulary.gain_sets()),
    config="[0-9]+",


# ----------------------------------------------------------------------------------------
# configuration
# ----------------------------------------------------------------------------------------
CAMPAIGN = config["campaign"]
ARCHIVE = f"{config['archive_root']}/{CAMPAIGN}"
SIMULATE = bool(config["simulate"])
JOB_UNIT = config["job_unit"]
GAIN_ORDER = vocabulary.gain_sets()
# the files every trial depends on: the rig parameters and the paper's tables (configurations, gains)
RIG_FILE = config["rig"] if config.get("rig") else str(config_file("rig.yaml"))
PAPER_FILE = str(config_file("paper.yaml"))
def code_digest(*patterns):
    """The stage digest of the package files ``patterns`` name (campaign.pipeline.digests)."""
    try:
        return digests.code_digest(*patterns)
    except InputError as exc:
        raise WorkflowError(str(exc)) from None


# the code behind each stage (see code_digest)
CODE_SIMULATE = code_digest("pipeline/sweep.py", "model/robot/*/*")
CODE_IDENTIFY = code_digest("pipeline/stages.py", "identify/table.py", "model/robot/*/*")
CODE_FIT = code_digest("pipeline/fit.py", "model/robot/*/*")
CODE_TABLES = code_digest("pipeline/tabulate.py", "model/robot/*/*")


def figure_code(name):
    """Digest of the figure's module and every package module it imports, with the robot files."""
    return code_digest(f"report/figures/{name}.py", "model/robot/*/*")


GAIN_CLASSES = {k: list(v) for k, v in vocabulary.gain_classes().items()}


def _config_error(key, message):
    """Stop at start-up with one message naming the configuration key."""
    raise WorkflowError(f"configuration key {key}: {message}")


def _sweeps():
    """{base: {configurations, gains, speeds, repeats}} with the global speeds/repeats filled in."""
    out = {}
    for base, sweep in config["bases"].items():
        if sweep is None:       # a base set to null is not swept
            continue
        out[base] = {
            "configurations": sorted(int(c) for c in sweep["configurations"]),
            "gains": [g for g in GAIN_ORDER if g in sweep["gains"]],
            "speeds": [float(s) for s in sweep.get("speeds", config["speeds"])],
            "repeats": int(sweep.get("repeats", config["repeats"])),
        }
    return out


def _reuse_cells(root):
    """{(base, configuration, gain): [trial files]} of the reused archive, from its own
    index.csv, restricted to the bases, configurations and gains the configuration lists."""
    try:
        held = paths.index_cells(root)
    except (OSError, ValueError) as exc:
        _config_error("reuse_archive", str(exc))
    wanted = _sweeps()
    out = {cell: paths for cell, paths in held.items()
           if cell[0] in wanted and cell[1] in wanted[cell[0]]["configurations"] and cell[2] in wanted[cell[0]]["gains"]}
    if not out:
        _config_error("reuse_archive", f"{root!r} holds no trial of the cells bases: lists "
                      f"(it holds {sorted({c[0] for c in held})} bases)")
    return out


def _held_sweeps(held):
    """The sweep of each base as the reused archive holds it (speeds and repeats from its files)."""
    out = {}
    for base in [b for b in vocabulary.bases() if any(c[0] == b for c in held)]:
        rows = [c for c in held if c[0] == base]
        speeds = sorted({float(Path(p).parent.name[1:]) for c in rows for p in held[c]})
        repeats = max(int(Path(p).stem[1:]) for c in rows for p in held[c]) + 1
        out[base] = {"configurations": sorted({c[1] for c in rows}),
                     "gains": [g for g in GAIN_ORDER if any(c[2] == g for c in rows)],
                     "speeds": speeds, "repeats": repeats}
    return out



def _rig_file_data():
    """The rig parameter file's content (its existence was checked at start-up)."""
    with open(RIG_FILE, encoding="utf-8") as fh:
        return yaml.safe_load(fh) or {}


def _structure():
    """The flexible sweep's named structure (bases.flexible.structure), checked against the
    rig file's ``structures:``; None keeps the rig file's default."""
    name = (config["bases"].get("flexible") or {}).get("structure")
    if name is None:
        return None
    known = sorted(_rig_file_data().get("structures") or {})
    if name not in known:
        _config_error("bases.flexible.structure", f"unknown structure {name!r}; the rig file {RIG_FILE} names {known}")
    return name


STRUCTURE = _structure()


def _robot():
    """(name, number of joints, configurations, folder) of the robot the campaign simulates:
    rig_params.robot, else the rig file's ``robot`` (campaign.model.conventions)."""
    name = config["rig_params"].get("robot")
    key = "rig_params.robot"
    if name is None:
        with open(RIG_FILE) as fh:
            leaf = yaml.safe_load(fh).get("robot")
        name, key = (leaf.get("value") if isinstance(leaf, dict) else leaf), "rig"
    try:
        return (str(name), conventions.angle_count(name), conventions.configurations(name),
                conventions.robot_dir(name).resolve())
    except (InputError, ValueError) as exc:
        _config_error(key, str(exc))


ROBOT, ROBOT_JOINTS, ROBOT_CONFIGURATIONS, _robot_folder = _robot()
with open(PAPER_FILE) as _fh:
    PAPER_ROBOT = str(yaml.safe_load(_fh)["robot"])
# the paper's products (its configurations 1-3, its published values beside ours) are made
# for the paper's robot only; another robot's campaign makes its trials, identification,
# lambda fits and the products that do not compare it with the paper's arm
PAPER_ARM = _robot_folder == conventions.robot_dir(PAPER_ROBOT).resolve()
for _base, _sweep in config["bases"].items():
    _unknown = [c for c in (_sweep or {}).get("configurations", []) if c not in ROBOT_CONFIGURATIONS]
    if _unknown:
        _config_error(f"bases.{_base}.configurations", f"robot {ROBOT} names no configuration {_unknown} (its "
                      f"configurations: {sorted(ROBOT_CONFIGURATIONS) or 'none'})")
#: products another robot's campaign makes too
ANY_ARM_PRODUCTS = ("fig7",)


def sweep_params(base):
    """Rig overrides of ``base``'s jobs: the campaign's rig_params, and for the flexible base
    its named structure (rig_params may still override single values of it)."""
    params = dict(config["rig_params"])
    if base == "flexible" and STRUCTURE is not None:
        params.setdefault("flexible.structure", STRUCTURE)
    return params

if SIMULATE:
    TRIAL_ROOT = ARCHIVE
    RESULTS = f"{config['results_root']}/{CAMPAIGN}"
    SWEEPS = _sweeps()
    REUSED = {}
else:
    if not config.get("reuse_archive"):
        _config_error("reuse_archive", "simulate is false, so reuse_archive must name an archive folder")
    TRIAL_ROOT = config["reuse_archive"].rstrip("/")
    if not Path(TRIAL_ROOT).is_dir():
        _config_error("reuse_archive", f"{TRIAL_ROOT!r} is not a folder (simulate is false: nothing is simulated)")
    # a results folder of its own, named for the archive read: a simulated campaign's results
    # (results/<campaign>) are never written over, nor mixed with another archive's
    RESULTS = paths.reuse_results(config["results_root"], TRIAL_ROOT)
    try:
        paths.check_reuse_results(RESULTS, TRIAL_ROOT)
    except InputError as _exc:
        _config_error("reuse_archive", str(_exc))
    REUSED = _reuse_cells(TRIAL_ROOT)
    SWEEPS = _held_sweeps(REUSED)

def _configured_structure():
    """The structure the flexible sweep simulates: the config's, else the rig file's default."""
    if STRUCTURE is not None:
        return STRUCTURE
    leaf = (_rig_file_data().get("flexible") or {}).get("structure")
    return leaf.get("value") if isinstance(leaf, dict) else leaf


# the structure Table 4 and Figure 9 show: a reused archive's own, read from the stored scene of
# one flexible trial per cell (an archive made before the default changed holds another one),
# else the one the flexible sweep simulates
FLEX_STRUCTURE = _configured_structure()
if not SIMULATE and any(c[0] == "flexible" for c in REUSED):
    from campaign.scene.description import trial_structures   # numpy and h5py: only when reusing an archive

    _held = ", ".join(trial_structures([ps[0] for c, ps in REUSED.items() if c[0] == "flexible"]))
    if _held != FLEX_STRUCTURE:
        print(f"reuse_archive: its flexible-base trials emulate the structure {_held} (their stored scenes), not "
              f"{FLEX_STRUCTURE} that the campaign config names; Table 4 and Figure 9 show {_held}", file=sys.stderr)
    FLEX_STRUCTURE = _held

try:
    config_checks.check_workflow_config(config, sweeps=SWEEPS if SIMULATE else {})
except InputError as exc:
    raise WorkflowError(str(exc)) from None


def cells(base, configs=None, gains=None):
    """The sweep cells (base, configuration, gain) of ``base``, optionally restricted."""
    sweep = SWEEPS.get(base)
    if sweep is None:
        return []
    return [(base, c, g) for g in sweep["gains"] for c in sweep["configurations"]
            if (configs is None or c in configs) and (gains is None or g in gains)
            and (SIMULATE or (base, c, g) in REUSED)]


# ----------------------------------------------------------------------------------------
# job units: what one simulation job covers, and its job manifest
# ----------------------------------------------------------------------------------------
def unit_of(base, config_, gain):
    """Wildcard values of the job covering a cell (``job_unit`` sweep: base x gain; cell: + configuration)."""
    return {"gain": gain} if JOB_UNIT == "sweep" else {"config": config_, "gain": gain}


def unit_name(base):
    """Path pattern of one job of ``base`` (logs, job manifests, identification tables)."""
    return f"{base}/{{gain}}" if JOB_UNIT == "sweep" else f"{base}/config{{config}}/{{gain}}"


def unit_cells(base, wildcards):
    """The cells one job covers, from its wildcards."""
    if JOB_UNIT == "sweep":
        return cells(base, gains=[wildcards.gain])
    return cells(base, configs=[int(wildcards.config)], gains=[wildcards.gain])


def units(base):
    """The job units of ``base`` in sweep order, each as its wildcard values, each once."""
    out = []
    for b, c, g in cells(base):
        unit = unit_of(b, c, g)
        if unit not in out:
            out.append(unit)
    return out


def job_manifest(base, unit):
    """The job manifest of one simulation job (campaign.archive.jobs): its only declared output."""
    return f"{ARCHIVE}/.jobs/{unit_name(base).format(**unit)}.json"


def unit_sources(base, unit):
    """What the jobs after the simulation read for one unit: its job manifest when simulating,
    the reused archive's trial files of the unit's cells (from its index.csv) when not."""
    if SIMULATE:
        return [job_manifest(base, unit)]
    return [t for b, c, g in cells(base, configs=[int(unit["config"])] if "config" in unit else None,
                                   gains=[unit["gain"]]) for t in REUSED[(b, c, g)]]


def base_sources(base):
    """:func:`unit_sources` of every unit of ``base``."""
    return [s for unit in units(base) for s in unit_sources(base, unit)]


def single_trial(wc):
    """The trial ``snakemake <archive>/<base>/config<N>/<gain>/v<speed>/r<NN>.nc`` asks for, checked
    to be one of the campaign's (its cell, speed and repeat in the sweep)."""
    trial = {"base": wc.base, "config": int(wc.config), "gain": wc.gain, "speed": float(wc.speed),
             "repeat": int(wc.repeat)}
    sweep = SWEEPS.get(wc.base)
    if sweep is None or (wc.base, trial["config"], wc.gain) not in cells(wc.base) \
            or trial["speed"] not in sweep["speeds"] or trial["repeat"] >= sweep["repeats"]:
        runs = (f"bases.{wc.base} runs configurations {sweep['configurations']}, gains {sweep['gains']}, speeds "
                f"{sweep['speeds']} m/s and repeats 0-{sweep['repeats'] - 1}") if sweep else f"it has no {wc.base} base"
        raise WorkflowError(f"{ARCHIVE}/{vocabulary.trial_relpath(**trial)} is not a trial of campaign {CAMPAIGN}: "
                            f"{runs}")
    return {**trial, "repeats": sweep["repeats"]}


def trial_source(base, config_, gain, speed, repeat, key):
    """(input, trial path) of one trial a figure shows: the input is the job manifest of the
    simulation job that writes it, or the reused trial file; ``key`` names the configuration
    entry that chose it. A trial the campaign does not hold stops the run naming the key."""
    why = config_checks.trial_pick_problem(base, config_, gain, speed, repeat, sweeps=SWEEPS, key=key,
                                           held=cells(base))
    if why:
        raise WorkflowError(why)
    path = f"{TRIAL_ROOT}/{vocabulary.trial_relpath(base, config_, gain, speed, repeat)}"
    if SIMULATE:
        return job_manifest(base, unit_of(base, config_, gain)), path
    if not Path(path).is_file():
        raise WorkflowError(f"{key}: trial {path} is not in reuse_archive {TRIAL_ROOT!r}")
    return path, path


def ident_table(base, config_, gain):
    """Identification table (CSV) holding the trials of one cell."""
    unit = unit_name(base).format(**unit_of(base, config_, gain))
    return f"{RESULTS}/identify/{unit}.csv"


def ident_tables(base, configs=None, gains=None):
    """Identification tables covering the cells of ``base`` (restricted), each once, in order."""
    out = []
    for b, c, g in cells(base, configs, gains):
        path = ident_table(b, c, g)
        if path not in out:
            out.append(path)
    return out


def fit_classes():
    """Gain classes the fixed-base sweep can fit: {class: [gains of the class in the sweep]}."""
    have = SWEEPS.get("fixed", {}).get("gains", [])
    return {k: [g for g in v if g in have] for k, v in GAIN_CLASSES.items() if any(g in have for g in v)}


#: the campaign's identification as one CSV (rule identification_csv)
IDENTIFICATION_CSV = config.get("identification_csv") or f"{RESULTS}/identification.csv"


def all_job_manifests():
    """The job manifest of every simulation job of the campaign (the archive's finalisation input)."""
    return [job_manifest(base, unit) for base in SWEEPS for unit in units(base)]


FIGURE_BASE = {"fig5": "fixed", "fig9": "flexible"}


def figure_pick(name):
    """(speed, repeat) of the trial a single-trial figure shows: configuration key
    figures.<name>, by default the base's highest speed and repeat 0."""
    pick = config.get("figures", {}).get(name, {})
    speeds = SWEEPS.get(FIGURE_BASE[name], {}).get("speeds") or config["speeds"]
    return float(pick.get("speed", max(speeds))), int(pick.get("repeat", 0))


def fig9_sources():
    """{"c<config>_<gain>": (input, trial path)} of Figure 9's four trials (also the calibration report's)."""
    return {f"c{c}_{g}": trial_source("flexible", c, g, *figure_pick("fig9"), key="figures.fig9")
            for c in (1, 2) for g in ("low", "high")}


# ----------------------------------------------------------------------------------------
# scheduling
# ----------------------------------------------------------------------------------------
#: each job's priority: the work on the longest path from it to the end of a campaign, in
#: seconds of the full campaign's CPU (rounded; docs/benchmarks.rst), so that of the jobs that
#: can run, the one that holds up the most work after it starts first. The fixed base's
#: simulations lead to identification, the lambda fits and the planner's maps (the longest
#: job after the simulations); the archive's finalisation needs nothing after it.
PRIORITY = {
    "simulate_fixed": 16, "identify_fixed": 15, "simulate_flexible": 12, "fixed_base": 11, "planner_maps": 8,
    "identify_flexible": 7, "model_figures": 2, "fig5_joint3_motion": 1, "fig9_base_motion": 1,
    "flexible_base": 1, "finalize_archive": 0, "verify_archive": 0, "identification_csv": 0,
}


# ----------------------------------------------------------------------------------------
# products and what each needs
# ----------------------------------------------------------------------------------------
FIGURES = ("fig4", "fig5", "fig6", "fig7", "fig8", "fig9", "plan_maps", "eq8_validity")
TABLES = ("table2", "table3", "table4", "table4_structures", "plan_rig_check")


def figure_files(name):
    if name == "plan_maps":     # one job draws the planner's two maps
        return figure_files("plan_workspace") + figure_files("plan_directions")
    return [f"{RESULTS}/figures/{name}.png", f"{RESULTS}/figures/{name}.pdf"]


def fit_jsons():
    """{gain class: lambda fit JSON} of the campaign, in the paper's order."""
    return {k: f"{RESULTS}/fit/lambda_{k}.json" for k in fit_classes()}


def table_files(name):
    return [f"{RESULTS}/tables/{name}.csv", f"{RESULTS}/tables/{name}.md"]


def _fixed_complete():
    """Tables 2-3 (and so Table 4's lambda) need every configuration of the fixed base under
    each gain class: eq 11 has three unknowns lambda_1..3 per class."""
    have = SWEEPS.get("fixed")
    return bool(have) and len(have["configurations"]) >= 3 and {"high"} <= set(have["gains"]) \
        and bool({"zero", "low"} & set(have["gains"]))


def fit_requirement():
    """Why this configuration cannot fit lambda, or "" if it can: every gain class needs as
    many fixed-base configurations as the robot has joints (eq 11: one lambda_j per joint)."""
    have = SWEEPS.get("fixed")
    if not have or not fit_classes():
        return "needs bases.fixed with the gains of a gain class"
    if len(have["configurations"]) < ROBOT_JOINTS:
        return (f"needs bases.fixed with at least {ROBOT_JOINTS} configurations (robot {ROBOT} has "
                f"{ROBOT_JOINTS} joints, one lambda_j each)")
    return ""


def missing_requirement(product):
    """Why ``product`` cannot be made from this configuration, or "" if it can."""
    fixed = SWEEPS.get("fixed")
    if not PAPER_ARM and product not in ANY_ARM_PRODUCTS:
        return (f"needs the paper's robot {PAPER_ROBOT} (its configurations and published values; this campaign "
                f"simulates {ROBOT})")
    if product in ("fig4", "fig8"):
        return ""
    if product in STUDY_PRODUCTS:
        study = STUDY_PRODUCTS[product]
        return "" if study in STUDIES else \
            f"needs the study {study} listed under the configuration key studies: (or `snakemake study_{study}` alone)"
    if product == "fig5":
        return "" if ("fixed", 1, "zero") in cells("fixed") else "needs bases.fixed with configuration 1 and gain zero"
    if product in ("fig6", "fig7"):
        return "" if fixed else "needs bases.fixed"
    if product == "fig9":
        need = [("flexible", c, g) for c in (1, 2) for g in ("low", "high")]
        return "" if all(n in cells("flexible") for n in need) else \
            "needs bases.flexible with configurations 1, 2 and gains low, high"
    if product == "plan_maps":
        return "" if _fixed_complete() else \
            "needs the fixed-base fit (bases.fixed with configurations 1-3, gain high and zero or low)"
    if product in ("table2", "table3"):
        return "" if _fixed_complete() else "needs bases.fixed with configurations 1-3, gain high and zero or low"
    if product == "table4":
        if not _fixed_complete():
            return "needs the fixed-base fit (bases.fixed with configurations 1-3, gain high and zero or low)"
        return "" if cells("flexible", gains=["low", "high"]) else "needs bases.flexible with gain low or high"
    raise WorkflowError(f"unknown product {product!r}")


def product_files(product):
    if product in STUDY_PRODUCTS:
        return study_report_files(product)
    return figure_files(product) if product in FIGURES else table_files(product)


def requires(product):
    """The product's files, or a clear error naming what the configuration lacks."""
    why = missing_requirement(product)
    if why:
        raise WorkflowError(f"{product} cannot be made from campaign {CAMPAIGN!r}: it {why}")
    return product_files(product)


def default_targets():
    """Every product this configuration can make, the lambda fits, plus the archive's
    manifest (simulating) or its verification (reusing). Products it cannot make are named
    on stderr."""
    out = []
    for product in FIGURES + TABLES:
        why = missing_requirement(product)
        if why:
            print(f"campaign {CAMPAIGN}: skipping {product}: it {why}", file=sys.stderr)
        else:
            out += product_files(product)
    why = fit_requirement()
    if why:
        print(f"campaign {CAMPAIGN}: skipping the lambda fits: it {why}", file=sys.stderr)
    else:
        out += [f for f in fit_jsons().values() if f not in out]
    out += [f for f in study_targets() if f not in out]
    out.append(f"{ARCHIVE}/MANIFEST.sha256" if SIMULATE else f"{RESULTS}/archive_verify.txt")
    if SIMULATE and config.get("identification_csv"):
        out.append(config["identification_csv"])
    return out


def log_file(rule_name, unit=None, *, root=None):
    """Log of one job: ``<root>/logs/<rule>[/<unit>].log``, the campaign's results folder by default."""
    return str(Path(root or RESULTS, "logs", rule_name, *([unit] if unit else [])).with_suffix(".log"))


def bench_file(rule_name, unit=None):
    """Snakemake benchmark record of one job (wall time, CPU time, memory)."""
    return str(Path(RESULTS, "benchmarks", rule_name, *([unit] if unit else [])).with_suffix(".tsv"))


# ----------------------------------------------------------------------------------------
# studies (campaign.studies, workflow/rules/studies.smk): not per campaign
# ----------------------------------------------------------------------------------------
STUDY_NAMES = study_registry.NAMES
#: the studies this campaign's `all` target and report include
STUDIES = list(config["studies"])
#: a reduced run of each study (seconds; the tests) into a folder of its own
STUDIES_QUICK = bool(config["studies_quick"])
#: the report's products a study makes
STUDY_PRODUCTS = {"table4_structures": "space_structure", "eq8_validity": "space_structure",
                  "plan_rig_check": "plan_rig_check"}


def study_dir(name):
    """Folder of one study's files: ``<results_root>/studies/<study>[/quick]``."""
    return str(Path(config["results_root"], "studies", name, *(["quick"] if STUDIES_QUICK else [])))


def study_outputs(name):
    """The files one study's job writes (campaign.studies.FILES)."""
    return [f"{study_dir(name)}/{f}" for f in study_registry.FILES[name]]


def study_report_files(product):
    """The rendered table or figure of a study that the report shows."""
    stem = f"{study_dir(STUDY_PRODUCTS[product])}/report/{product}"
    return [f"{stem}.png", f"{stem}.pdf"] if product in FIGURES else [f"{stem}.csv", f"{stem}.md", f"{stem}.html"]


def study_files(name):
    """Everything of one study: its job's files and what the report shows of them."""
    return study_outputs(name) + [f for p, s in STUDY_PRODUCTS.items() if s == name for f in study_report_files(p)]


def study_targets():
    """The files of the studies the configuration lists under ``studies:``."""
    return [f for name in STUDIES for f in study_files(name)]


def designed_study_inputs():
    """The designed campaign's identification tables (study impact_resistance)."""
    if not DESIGNED:
        raise WorkflowError(f"study impact_resistance needs the designed campaign's settings {DESIGNED_FILE}")
    return [t for role in ("designed", "heldout") for t in designed_tables(role)]


def calibration_targets():
    """The calibration report, when the campaign has what its held-out rows need."""
    if not missing_requirement("table4") and not missing_requirement("fig9"):
        return [f"{RESULTS}/calibration/calibration.md", f"{RESULTS}/calibration/calibration.html"]
    return []


# ----------------------------------------------------------------------------------------
# the jobs after the simulations: what each makes (fixed_base.smk, flexible_base.smk, figures.smk)
# ----------------------------------------------------------------------------------------
def fixed_base_products():
    """The products the fixed_base job makes for this configuration, in the order it makes
    them (the fits first: Table 3 reads them)."""
    out = [f"fit_{k}" for k in fit_classes()] if _fixed_complete() else []
    out += [p for p in ("table2", "table3") if not missing_requirement(p)]
    return out + [p for p in ("fig6", "fig7") if not missing_requirement(p)]


def fixed_base_outputs():
    """The fixed_base job's outputs, named ``<product>_<kind>`` (the fits ``fit_<class>``)."""
    out = {}
    for product in fixed_base_products():
        if product.startswith("fit_"):
            out[product] = fit_jsons()[product[len("fit_"):]]
        elif product.startswith("table"):
            n = product[len("table"):]
            out[f"{product}_csv"], out[f"{product}_md"] = table_files(product)
            out[f"{product}_html"] = report(f"{RESULTS}/tables/{product}.html", caption=f"../report/{product}.rst",
                                            category="Fixed base" if n == "2" else "Virtual rotor inertia (lambda)",
                                            subcategory="Tables", labels={"table": f"Table {n}"})
        else:
            png, pdf = figure_files(product)
            labels = {"figure": f"Figure {product[len('fig'):]}"}
            out[f"{product}_png"] = report(png, caption=f"../report/{product}.rst", category="Fixed base",
                                           subcategory="Figures", labels={**labels, "format": "PNG"})
            out[f"{product}_pdf"] = report(pdf, caption=f"../report/{product}.rst", category="Fixed base",
                                           subcategory="Figures", labels={**labels, "format": "vector PDF"})
    return out


def fixed_base_logs():
    """One log per product (the fits' under fit_lambda/<class>.log), then the job's own."""
    out = {p: log_file("fit_lambda", p[len("fit_"):]) if p.startswith("fit_") else log_file(p)
           for p in fixed_base_products()}
    return {**out, "job": log_file("fixed_base")}


def flexible_base_products():
    """The products the flexible_base job makes for this configuration (Table 4 first: the
    calibration report reads it)."""
    return (["table4"] if not missing_requirement("table4") else []) + (["calibration"] if calibration_targets() else [])


def flexible_base_outputs():
    out = {}
    if "table4" in flexible_base_products():
        out["table4_csv"], out["table4_md"] = table_files("table4")
        out["table4_html"] = report(f"{RESULTS}/tables/table4.html", caption="../report/table4.rst",
                                    category="Flexible base", subcategory="Tables", labels={"table": "Table 4"})
    if "calibration" in flexible_base_products():
        out["calibration_md"] = f"{RESULTS}/calibration/calibration.md"
        out["calibration_html"] = report(f"{RESULTS}/calibration/calibration.html",
                                         caption="../report/calibration.rst", category="Calibration",
                                         subcategory="Fitted and held-out observations",
                                         labels={"report": "The simulated rig against the paper"})
        out["calibration_csv"] = f"{RESULTS}/calibration/calibration.csv"
    return out


def flexible_base_inputs():
    out = {"paper": PAPER_FILE, "rig": RIG_FILE, "tables": ident_tables("flexible"), **fit_jsons()}
    if "table4" in flexible_base_products():
        # the shipped response model (fitted by the designed campaign) fills Table 4's model column
        out["model"] = str(Path(PAPER_FILE).parent / "response_model.json")
    if "calibration" in flexible_base_products():
        out["trials"] = sorted({source for source, _ in fig9_sources().values()})
    return out


def figure_outputs(name, category):
    """{<name>_png, <name>_pdf} of one figure, both shown in the report."""
    labels = {"figure": f"Figure {name[len('fig'):]}"}
    png, pdf = figure_files(name)
    return {f"{name}_png": report(png, caption=f"../report/{name}.rst", category=category, subcategory="Figures",
                                  labels={**labels, "format": "PNG"}),
            f"{name}_pdf": report(pdf, caption=f"../report/{name}.rst", category=category, subcategory="Figures",
                                  labels={**labels, "format": "vector PDF"})}


# ----------------------------------------------------------------------------------------
# the designed campaign (`snakemake designed`): its own settings file, checked at start-up
# ----------------------------------------------------------------------------------------
# the project's config/designed.yaml (like rig.yaml and paper.yaml, whatever the working
# directory), or the file --config designed=PATH names
DESIGNED_FILE = str(config.get("designed") or config_file("designed.yaml"))


def _designed_settings():
    """The designed campaign's settings, validated; None when the file is absent (the
    designed rules are then not defined)."""
    if not Path(DESIGNED_FILE).is_file():
        if config.get("designed"):
            _config_error("designed", f"{DESIGNED_FILE!r} does not exist")
        return None
    with open(DESIGNED_FILE, encoding="utf-8") as fh:
        settings = yaml.safe_load(fh)
    validate(settings, schema="../schemas/designed.schema.yaml")
    return settings


DESIGNED = _designed_settings()
DESIGNED_RESULTS = f"{config['results_root']}/{DESIGNED['campaign']}" if DESIGNED else None
DESIGNED_ARCHIVE = f"{config['archive_root']}/{DESIGNED['campaign']}" if DESIGNED else None
DESIGNED_ROLES = ("paper", "designed", "heldout")


# what the configuration asks of its products (the trial each single-trial figure shows, the
# planner's maps), checked at start-up with one line naming the key, not when a job's input
# is first asked for
try:
    config_checks.check_products(config, sweeps=SWEEPS, held={b: cells(b) for b in SWEEPS},
                                 wanted={name: not missing_requirement(name) for name in ("fig5", "fig9", "plan_maps")})
except InputError as _exc:
    raise WorkflowError(str(_exc)) from None
CODE_DESIGNED = code_digest("design/designed_campaign.py", "model/robot/*/*")


def designed_tables(role):
    """Identification CSVs of one role of the designed campaign, every gain set."""
    return [f"{DESIGNED_RESULTS}/identification/{role}_{g}.csv" for g in GAIN_ORDER]


# the named structures the designed campaign's held-out poses are struck under
# (designed_flexible_trials), from the rig file
with open(RIG_FILE) as _fh:
    DESIGNED_STRUCTURES = sorted((yaml.safe_load(_fh).get("structures") or {}))
CODE_DESIGNED_MODEL = code_digest("design/designed_model.py", "model/robot/*/*")


def designed_flexible_tables():
    """Identification CSVs of the held-out poses on the flexible base, every structure and gain set."""
    return [f"{DESIGNED_RESULTS}/identification/flexible/{s}_{g}.csv" for s in DESIGNED_STRUCTURES
            for g in GAIN_ORDER]


def designed_log(rule_name, unit=None):
    """Log of one job of the designed campaign."""
    return str(Path(DESIGNED_RESULTS, "logs", rule_name, *([unit] if unit else [])).with_suffix(".log"))
