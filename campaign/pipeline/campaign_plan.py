"""The campaign's plan: what a workflow configuration asks for, and where each of its files lives.

A :class:`CampaignPlan` is made once from the validated configuration, the rig file and the
paper file. It answers what the workflow's rules ask: the sweeps and their cells (or, when an
archive is re-analysed, the cells it holds), the simulation jobs (units) and their job
manifests, where every trial, identification table, fit, table, figure, log and study file
lives, which products the configuration can make and why one cannot, the trials the
single-trial figures show, and the designed campaign's files. ``workflow/rules/common.smk``
only wires it into Snakemake; trial paths are built and read through
:mod:`campaign.core.vocabulary` only.

Only the standard library, PyYAML and the start-up modules are imported (the vocabulary, the
robots' conventions, the configuration checks, :mod:`.paths`, :mod:`.digests` and
:mod:`.plan_parts`): Snakemake makes the plan every time it starts, a dry run included; a
check that needs the scene imports it when it runs. A configuration the plan cannot
run raises :class:`~campaign.core.errors.InputError`, one line naming the key.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from ..core import vocabulary
from ..core.errors import InputError
from ..core.yamlfile import config_file, read_yaml
from ..model import conventions
from . import config as config_checks
from . import paths
from .plan_parts import (
    ANY_ARM_PRODUCTS,
    FIGURES,
    STUDY_PRODUCTS,
    TABLES,
    DesignedPlan,
    JobOutputs,
    StudiesPlan,
    log_path,
)

__all__ = ["CampaignPlan", "ARCHIVE_FILES", "CALIBRATION_FILES"]

#: the archive's own files, named here too since campaign.archive.fileformat (INDEX, README,
#: MANIFEST, JOBS) loads h5py; the plan's tests check that both agree
ARCHIVE_FILES = {"index": "index.csv", "readme": "README.md", "manifest": "MANIFEST.sha256"}
_JOBS = ".jobs"
#: the calibration's files in the results folder, by role
CALIBRATION_FILES = {"fit": "fit.md", "md": "calibration.md", "html": "calibration.html", "csv": "calibration.csv"}


def _read_yaml(path: str) -> dict:
    return read_yaml(path) or {}


def _config_error(key: str, message: str) -> InputError:
    return InputError(f"configuration key {key}: {message}")


def _leaf(value):
    """A rig file's value: plain, or the ``value`` of a documented leaf."""
    return value.get("value") if isinstance(value, dict) else value


class CampaignPlan(JobOutputs):
    """The campaign a validated workflow configuration describes (see the module docstring).

    Parameters
    ----------
    config : mapping
        The workflow configuration, validated against ``workflow/schemas/config.schema.yaml``
        with its defaults filled in.
    rig_file, paper_file : str
        The rig parameter file and the paper's conventions (``config/paper.yaml``).
    check_reuse : bool
        Check a re-analysed archive's files against its manifest
        (:func:`campaign.pipeline.paths.check_manifest`); the workflow does so in its main
        process, not again in every job.

    Attributes
    ----------
    campaign, archive, results : str
        The campaign's name, its archive folder and its results folder (a re-analysed
        archive's: ``<results_root>/reuse-<archive>``).
    simulate : bool
        Whether the trials are simulated; else they are read from ``trial_root``, the reused
        archive, whose trial files by cell are ``reused``.
    sweeps : dict
        ``{base: {configurations, gains, speeds, repeats}}`` as the campaign runs (or holds) them.
    robot, robot_joints, paper_robot, paper_arm
        The simulated robot, its joints, the paper's robot and whether they are the same arm.
    structure, shown_structure
        The flexible sweep's named structure (None: the rig file's default), and the one
        Table 4 and Figure 9 show (a reused archive's own).
    studies, designed : StudiesPlan, DesignedPlan
        The studies' files and the designed campaign's.
    notes : list of str
        What the user should know at start-up (not errors).

    Raises
    ------
    InputError
        What the configuration asks that the plan cannot run: an unknown structure, a
        configuration the robot does not name, a reused archive without the cells it lists,
        a trial a figure picks that the campaign does not hold, ... (one line naming the key).
    """

    def __init__(self, *, config: Mapping[str, Any], rig_file: str, paper_file: str, check_reuse: bool = True):
        self.config = config
        self._check_reuse = check_reuse
        self.rig_file, self.paper_file = str(rig_file), str(paper_file)
        # the paper's two bases, in its order: the arm on the ground, then on the emulated structure
        self.fixed_base, self.flexible_base = vocabulary.bases()
        self.campaign = str(config["campaign"])
        self.archive = f"{config['archive_root']}/{self.campaign}"
        self.simulate = bool(config["simulate"])
        self.job_unit = config["job_unit"]
        # start-up notes for the user (stderr), not errors
        self.notes: list[str] = []
        self._rig = _read_yaml(self.rig_file)
        self._paper = _read_yaml(self.paper_file)
        self.structure = self._named_structure()
        self.robot, self.robot_joints, self.robot_configurations, folder = self._robot()
        self.paper_robot = str(self._paper["robot"])
        # the paper's products (its configurations 1-3, its published values beside ours) are made
        # for the paper's robot only; another robot's campaign makes its trials, identification,
        # lambda fits and the products that do not compare it with the paper's arm
        self.paper_arm = folder == conventions.robot_dir(self.paper_robot).resolve()
        self._check_configurations()
        if self.simulate:
            self.trial_root = self.archive
            self.results = f"{config['results_root']}/{self.campaign}"
            self.reused: dict[tuple[str, int, str], list[str]] = {}
            self.sweeps = self._configured_sweeps()
        else:
            self.trial_root, self.results, self.reused = self._reuse()
            self.sweeps = self._held_sweeps(self.reused)
        self.shown_structure = self._shown_structure()
        config_checks.check_workflow_config(config, sweeps=self.sweeps if self.simulate else {})
        # the studies' files; the designed campaign's settings and files
        self.studies = StudiesPlan(results_root=config["results_root"], selected=config["studies"],
                                   quick=config["studies_quick"])
        self.designed = DesignedPlan(settings_file=str(config.get("designed") or config_file("designed.yaml")),
                                     named=bool(config.get("designed")), results_root=config["results_root"],
                                     archive_root=config["archive_root"], structures=self._rig.get("structures") or {})
        self.identification_csv = config.get("identification_csv") or f"{self.results}/identification.csv"
        # the products' configuration (the trial each single-trial figure shows, the planner's
        # maps), checked now rather than when a job's input is first asked for
        config_checks.check_products(config, sweeps=self.sweeps, held={b: self.cells(b) for b in self.sweeps},
                                     wanted={p: not self.missing_requirement(p) for p in ("fig5", "fig9", "plan_maps")})

    @classmethod
    def from_config(cls, config: Mapping[str, Any], *, check_reuse: bool = True) -> CampaignPlan:
        """The plan of ``config`` with its rig file (``rig``, else the project's
        ``config/rig.yaml``) and the project's ``config/paper.yaml``."""
        rig = config["rig"] if config.get("rig") else str(config_file("rig.yaml"))
        return cls(config=config, rig_file=rig, paper_file=str(config_file("paper.yaml")), check_reuse=check_reuse)

    # ------------------------------------------------------------------------------------
    # what is swept: the robot, the structure, the sweeps (configured or held by an archive)
    # ------------------------------------------------------------------------------------
    def _named_structure(self) -> str | None:
        """The flexible sweep's named structure, checked against the rig file's ``structures:``."""
        name = (self.config["bases"].get(self.flexible_base) or {}).get("structure")
        if name is None:
            return None
        known = sorted(self._rig.get("structures") or {})
        if name not in known:
            raise _config_error(f"bases.{self.flexible_base}.structure",
                                f"unknown structure {name!r}; the rig file {self.rig_file} names {known}")
        return name

    def _robot(self) -> tuple[str, int, dict, Path]:
        """(name, joints, configurations, folder) of the robot: rig_params.robot, else the rig file's."""
        name, key = self.config["rig_params"].get("robot"), "rig_params.robot"
        if name is None:
            name, key = _leaf(self._rig.get("robot")), "rig"
        try:
            return (str(name), conventions.angle_count(name), conventions.configurations(name),
                    conventions.robot_dir(name).resolve())
        except (InputError, ValueError) as exc:
            raise _config_error(key, str(exc)) from None

    def _check_configurations(self) -> None:
        for base, sweep in self.config["bases"].items():
            unknown = [c for c in (sweep or {}).get("configurations", []) if c not in self.robot_configurations]
            if unknown:
                raise _config_error(f"bases.{base}.configurations", f"robot {self.robot} names no configuration "
                                    f"{unknown} (its configurations: {sorted(self.robot_configurations) or 'none'})")

    def _configured_sweeps(self) -> dict[str, dict[str, Any]]:
        """{base: {configurations, gains, speeds, repeats}} with the global speeds and repeats filled in."""
        out = {}
        for base, sweep in self.config["bases"].items():
            if sweep is None:       # a base set to null is not swept
                continue
            out[base] = {"configurations": sorted(int(c) for c in sweep["configurations"]),
                         "gains": [g for g in vocabulary.gain_sets() if g in sweep["gains"]],
                         "speeds": [float(s) for s in sweep.get("speeds", self.config["speeds"])],
                         "repeats": int(sweep.get("repeats", self.config["repeats"]))}
        return out

    def _reuse(self) -> tuple[str, str, dict[tuple[str, int, str], list[str]]]:
        """(archive, results folder, {cell: trial files}) of a re-analysed archive: its cells from
        its own index.csv, restricted to the bases, configurations and gains the configuration lists."""
        if not self.config.get("reuse_archive"):
            raise _config_error("reuse_archive", "simulate is false, so reuse_archive must name an archive folder")
        root = self.config["reuse_archive"].rstrip("/")
        if not Path(root).is_dir():
            raise _config_error("reuse_archive", f"{root!r} is not a folder (simulate is false: nothing is simulated)")
        # a results folder of its own, named for the archive read: a simulated campaign's results
        # (results/<campaign>) are never written over, nor mixed with another archive's
        results = paths.reuse_results(self.config["results_root"], root)
        try:
            paths.check_reuse_results(results, root)
            held = paths.index_cells(root)
            if self._check_reuse:   # the files its manifest lists (the index too), and the trials it indexes
                paths.check_manifest(root, [t for files in held.values() for t in files])
        except (OSError, ValueError) as exc:
            raise _config_error("reuse_archive", str(exc)) from None
        wanted = self._configured_sweeps()
        out = {cell: files for cell, files in held.items() if cell[0] in wanted
               and cell[1] in wanted[cell[0]]["configurations"] and cell[2] in wanted[cell[0]]["gains"]}
        if not out:
            raise _config_error("reuse_archive", f"{root!r} holds no trial of the cells bases: lists "
                                f"(it holds {sorted({c[0] for c in held})} bases)")
        return root, results, out

    @staticmethod
    def _held_sweeps(held: Mapping[tuple[str, int, str], Sequence[str]]) -> dict[str, dict[str, Any]]:
        """The sweep of each base as a reused archive holds it (speeds and repeats from its trial paths)."""
        out = {}
        for base in [b for b in vocabulary.bases() if any(c[0] == b for c in held)]:
            rows = [c for c in held if c[0] == base]
            trials = [vocabulary.parse_trial_relpath(p) for c in rows for p in held[c]]
            out[base] = {"configurations": sorted({c[1] for c in rows}),
                         "gains": [g for g in vocabulary.gain_sets() if any(c[2] == g for c in rows)],
                         "speeds": sorted({t["speed"] for t in trials}),
                         "repeats": max(t["repeat"] for t in trials) + 1}
        return out

    def _shown_structure(self) -> str | None:
        """The structure Table 4 and Figure 9 show: a reused archive's own, read from the stored
        scene of one flexible trial per cell, else the one the flexible sweep simulates."""
        configured = self.structure if self.structure is not None else \
            _leaf((self._rig.get(self.flexible_base) or {}).get("structure"))
        firsts = [files[0] for cell, files in self.reused.items() if cell[0] == self.flexible_base]
        if not firsts:
            return configured
        from ..scene.description import trial_structures  # numpy and h5py: only when reusing an archive

        held = ", ".join(trial_structures(firsts))
        if held != configured:
            self.notes.append(f"reuse_archive: its flexible-base trials emulate the structure {held} (their stored "
                              f"scenes), not {configured} that the campaign config names; Table 4 and Figure 9 "
                              f"show {held}")
        return held

    def sweep_params(self, base: str) -> dict[str, Any]:
        """Rig overrides of ``base``'s jobs: the campaign's rig_params, and for the flexible base
        its named structure (rig_params may still override single values of it)."""
        params = dict(self.config["rig_params"])
        if base == self.flexible_base and self.structure is not None:
            params.setdefault("flexible.structure", self.structure)
        return params

    def cells(self, base: str, configs: Sequence[int] | None = None,
              gains: Sequence[str] | None = None) -> list[tuple[str, int, str]]:
        """The sweep cells (base, configuration, gain) of ``base``, gain-major, optionally restricted."""
        sweep = self.sweeps.get(base)
        if sweep is None:
            return []
        return [(base, c, g) for g in sweep["gains"] for c in sweep["configurations"]
                if (configs is None or c in configs) and (gains is None or g in gains)
                and (self.simulate or (base, c, g) in self.reused)]

    # ------------------------------------------------------------------------------------
    # job units: what one simulation job covers, its job manifest, what the jobs after it read
    # ------------------------------------------------------------------------------------
    def unit_of(self, base: str, config: int, gain: str) -> dict[str, Any]:
        """Wildcard values of the job covering a cell (job_unit sweep: base x gain; cell: + configuration)."""
        return {"gain": gain} if self.job_unit == "sweep" else {"config": config, "gain": gain}

    def unit_name(self, base: str) -> str:
        """Path pattern of one job of ``base`` (its log, job manifest and identification table)."""
        return f"{base}/{{gain}}" if self.job_unit == "sweep" else f"{base}/{vocabulary.config_folder('{config}')}/{{gain}}"

    def unit_cells(self, base: str, unit: Mapping[str, Any]) -> list[tuple[str, int, str]]:
        """The cells one job covers, from its wildcard values."""
        configs = [int(unit["config"])] if self.job_unit != "sweep" else None
        return self.cells(base, configs=configs, gains=[unit["gain"]])

    def units(self, base: str) -> list[dict[str, Any]]:
        """The job units of ``base`` in sweep order, each as its wildcard values, each once."""
        out: list[dict[str, Any]] = []
        for b, c, g in self.cells(base):
            if (unit := self.unit_of(b, c, g)) not in out:
                out.append(unit)
        return out

    def job_manifest(self, base: str, unit: Mapping[str, Any]) -> str:
        """The job manifest of one simulation job (campaign.archive.jobs): its only declared output."""
        return f"{self.archive}/{_JOBS}/{self.unit_name(base).format(**unit)}.json"

    def job_manifest_pattern(self, base: str) -> str:
        """:meth:`job_manifest` with the unit's wildcards: the simulation rule's output."""
        return self.job_manifest(base, {"gain": "{gain}", "config": "{config}"})

    def all_job_manifests(self) -> list[str]:
        """The job manifest of every simulation job (the archive's finalisation input)."""
        return [self.job_manifest(base, unit) for base in self.sweeps for unit in self.units(base)]

    def unit_sources(self, base: str, unit: Mapping[str, Any]) -> list[str]:
        """What the jobs after the simulation read for one unit: its job manifest when simulating,
        the reused archive's trial files of the unit's cells when not."""
        if self.simulate:
            return [self.job_manifest(base, unit)]
        return [t for cell in self.unit_cells(base, unit) for t in self.reused[cell]]

    def base_sources(self, base: str) -> list[str]:
        """:meth:`unit_sources` of every unit of ``base``."""
        return [s for unit in self.units(base) for s in self.unit_sources(base, unit)]

    def identify_units(self, base: str) -> list[dict[str, Any]]:
        """One entry per identification table of ``base``: its unit name, sources, CSV and log."""
        out = []
        for unit in self.units(base):
            name = self.unit_name(base).format(**unit)
            out.append({"name": name, "sources": self.unit_sources(base, unit), "csv": self._identify_csv(name),
                        "log": self.log_file(f"identify_{base}", name)})
        return out

    def identify_logs(self, base: str) -> list[str]:
        """The identification job's own log (start-up, imports), then one per table."""
        return [self.log_file(f"identify_{base}")] + [u["log"] for u in self.identify_units(base)]

    def _identify_csv(self, unit_name: str) -> str:
        return f"{self.results}/identify/{unit_name}.csv"

    def ident_tables(self, base: str, configs: Sequence[int] | None = None,
                     gains: Sequence[str] | None = None) -> list[str]:
        """Identification tables (CSV) covering the cells of ``base`` (restricted), each once, in order."""
        out: list[str] = []
        for b, c, g in self.cells(base, configs, gains):
            if (path := self._identify_csv(self.unit_name(b).format(**self.unit_of(b, c, g)))) not in out:
                out.append(path)
        return out

    def all_ident_tables(self) -> list[str]:
        """The identification tables of every base."""
        return [t for base in self.sweeps for t in self.ident_tables(base)]

    # ------------------------------------------------------------------------------------
    # trials
    # ------------------------------------------------------------------------------------
    def trial_pattern(self) -> str:
        """The output pattern of one trial of the campaign's archive (its wildcards:
        :func:`campaign.core.vocabulary.trial_wildcards`)."""
        return f"{self.archive}/{vocabulary.trial_pattern()}"

    def trial_log_pattern(self) -> str:
        """The log of the job that simulates one trial alone."""
        return self.log_file("simulate_trial", vocabulary.trial_pattern().removesuffix(vocabulary.TRIAL_SUFFIX))

    def single_trial(self, *, base: str, config, gain: str, speed, repeat) -> dict[str, Any]:
        """The trial ``snakemake <archive>/<trial path>`` asks for (wildcard values), checked to be
        one of the campaign's (its cell, speed and repeat in the sweep), with its sweep's repeats."""
        trial = {"base": base, "config": int(config), "gain": gain, "speed": float(speed), "repeat": int(repeat)}
        sweep = self.sweeps.get(base)
        if sweep is None or (base, trial["config"], gain) not in self.cells(base) \
                or trial["speed"] not in sweep["speeds"] or trial["repeat"] >= sweep["repeats"]:
            runs = (f"bases.{base} runs configurations {sweep['configurations']}, gains {sweep['gains']}, speeds "
                    f"{sweep['speeds']} m/s and repeats 0-{sweep['repeats'] - 1}") if sweep else f"it has no {base} base"
            raise InputError(f"{self.archive}/{vocabulary.trial_relpath(**trial)} is not a trial of campaign "
                             f"{self.campaign}: {runs}")
        return {**trial, "repeats": sweep["repeats"]}

    def trial_source(self, base: str, config: int, gain: str, speed: float, repeat: int, *,
                     key: str) -> tuple[str, str]:
        """(input, trial path) of one trial a figure shows: the input is the job manifest of the
        simulation job that writes it, or the reused trial file; ``key`` names the configuration
        entry that chose it. A trial the campaign does not hold raises InputError naming the key."""
        why = config_checks.trial_pick_problem(base, config, gain, speed, repeat, sweeps=self.sweeps, key=key,
                                               held=self.cells(base))
        if why:
            raise InputError(why)
        path = f"{self.trial_root}/{vocabulary.trial_relpath(base, config, gain, speed, repeat)}"
        if self.simulate:
            return self.job_manifest(base, self.unit_of(base, config, gain)), path
        if not Path(path).is_file():
            raise InputError(f"{key}: trial {path} is not in reuse_archive {self.trial_root!r}")
        return path, path

    def figure_pick(self, name: str) -> tuple[float, int]:
        """(speed, repeat) of the trials a single-trial figure shows: configuration key
        figures.<name>, by default the base's highest speed and repeat 0."""
        pick = self.config.get("figures", {}).get(name, {})
        base = vocabulary.figure_cells(name)[0][0]
        speeds = self.sweeps.get(base, {}).get("speeds") or self.config["speeds"]
        return float(pick.get("speed", max(speeds))), int(pick.get("repeat", 0))

    def figure_sources(self, name: str) -> dict[str, tuple[str, str]]:
        """{"<configuration>-<gain>": (input, trial path)} of the trials a single-trial figure
        shows (``fig5``, ``fig9``; Figure 9's are also the calibration report's)."""
        return {f"{c}-{g}": self.trial_source(b, c, g, *self.figure_pick(name), key=f"figures.{name}")
                for b, c, g in vocabulary.figure_cells(name)}

    def figure_inputs(self, name: str) -> list[str]:
        """The inputs of :meth:`figure_sources`, sorted, each once."""
        return sorted({source for source, _ in self.figure_sources(name).values()})

    def figure_trials(self, name: str) -> dict[str, str]:
        """The trial paths of :meth:`figure_sources`."""
        return {key: path for key, (_, path) in self.figure_sources(name).items()}

    # ------------------------------------------------------------------------------------
    # products and what each needs
    # ------------------------------------------------------------------------------------
    def fit_classes(self) -> dict[str, list[str]]:
        """Gain classes the fixed-base sweep can fit: {class: [gains of the class in the sweep]}."""
        have = self.sweeps.get(self.fixed_base, {}).get("gains", [])
        return {k: [g for g in v if g in have] for k, v in vocabulary.gain_classes().items()
                if any(g in have for g in v)}

    def fit_jsons(self) -> dict[str, str]:
        """{gain class: lambda fit JSON} of the campaign, in the paper's order."""
        return {k: f"{self.results}/fit/lambda_{k}.json" for k in self.fit_classes()}

    def complete_fixed_sweep(self) -> bool:
        """Tables 2-3 (and so Table 4's lambda) need every paper configuration on the fixed base
        under each gain class: eq 11 has three unknowns lambda_1..3 per class."""
        have = self.sweeps.get(self.fixed_base)
        return bool(have) and len(have["configurations"]) >= len(self._paper["configurations"]) \
            and set(self.fit_classes()) == set(vocabulary.gain_classes())

    def _fixed_fit_text(self) -> str:
        """bases.fixed with configurations 1-3, gain high and zero or low: what the fixed-base fit needs."""
        numbers = sorted(int(c) for c in self._paper["configurations"])
        classes = " and ".join(" or ".join(g) for g in sorted(vocabulary.gain_classes().values(), key=len))
        return f"bases.{self.fixed_base} with configurations {numbers[0]}-{numbers[-1]}, gain {classes}"

    def fit_requirement(self) -> str:
        """Why this configuration cannot fit lambda, or "" if it can: every gain class needs as
        many fixed-base configurations as the robot has joints (eq 11: one lambda_j per joint)."""
        have = self.sweeps.get(self.fixed_base)
        if not have or not self.fit_classes():
            return f"needs bases.{self.fixed_base} with the gains of a gain class"
        if len(have["configurations"]) < self.robot_joints:
            return (f"needs bases.{self.fixed_base} with at least {self.robot_joints} configurations (robot "
                    f"{self.robot} has {self.robot_joints} joints, one lambda_j each)")
        return ""

    def _figure_requirement(self, name: str) -> str:
        cells = vocabulary.figure_cells(name)
        base, configs, gains = cells[0][0], sorted({c for _, c, _ in cells}), list(dict.fromkeys(g for *_, g in cells))
        if all(cell in self.cells(base) for cell in cells):
            return ""
        return (f"needs bases.{base} with configuration{'s' * (len(configs) > 1)} {', '.join(map(str, configs))} "
                f"and gain{'s' * (len(gains) > 1)} {', '.join(gains)}")

    def missing_requirement(self, product: str) -> str:
        """Why ``product`` cannot be made from this configuration, or "" if it can."""
        if product not in FIGURES + TABLES:
            raise InputError(f"unknown product {product!r}")
        if not self.paper_arm and product not in ANY_ARM_PRODUCTS:
            return (f"needs the paper's robot {self.paper_robot} (its configurations and published values; this "
                    f"campaign simulates {self.robot})")
        fixed_fit = "" if self.complete_fixed_sweep() else f"needs the fixed-base fit ({self._fixed_fit_text()})"
        if product in STUDY_PRODUCTS:
            study = STUDY_PRODUCTS[product]
            return "" if study in self.studies.selected else (f"needs the study {study} listed under the configuration key "
                                                     f"studies: (or `snakemake study_{study}` alone)")
        if product in ("fig5", "fig9"):
            return self._figure_requirement(product)
        if product in ("fig6", "fig7"):
            return "" if self.sweeps.get(self.fixed_base) else f"needs bases.{self.fixed_base}"
        if product == "plan_maps":
            return fixed_fit
        if product in ("table2", "table3"):
            return fixed_fit and f"needs {self._fixed_fit_text()}"
        if product == "table4":
            gains = list(dict.fromkeys(str(key).split("-")[1] for key in self._paper["table4"]))
            return fixed_fit or ("" if self.cells(self.flexible_base, gains=gains) else
                                 f"needs bases.{self.flexible_base} with gain {' or '.join(gains)}")
        return ""      # Figures 4 and 8: the robot model and the rig only

    def requires(self, product: str) -> list[str]:
        """The product's files, or InputError naming what the configuration lacks."""
        why = self.missing_requirement(product)
        if why:
            raise InputError(f"{product} cannot be made from campaign {self.campaign!r}: it {why}")
        return self.product_files(product)

    def figure_files(self, name: str) -> list[str]:
        """PNG and PDF of a figure (the planner's maps: both maps' files)."""
        if name == "plan_maps":     # one job draws the planner's two maps
            return self.figure_files("plan_workspace") + self.figure_files("plan_directions")
        return [f"{self.results}/figures/{name}.png", f"{self.results}/figures/{name}.pdf"]

    def table_files(self, name: str) -> list[str]:
        """CSV and Markdown of a table (its HTML is the report's)."""
        return [f"{self.results}/tables/{name}.csv", f"{self.results}/tables/{name}.md"]

    def product_files(self, product: str) -> list[str]:
        """The files a named target ``snakemake <product>`` makes."""
        if product in STUDY_PRODUCTS:
            return self.studies.report_files(product)
        return self.figure_files(product) if product in FIGURES else self.table_files(product)

    def skipped(self) -> list[str]:
        """One line per product (and the lambda fits) the default target leaves out, with why."""
        out = [f"campaign {self.campaign}: skipping {product}: it {why}" for product in FIGURES + TABLES
               if (why := self.missing_requirement(product))]
        if why := self.fit_requirement():
            out.append(f"campaign {self.campaign}: skipping the lambda fits: it {why}")
        return out

    def default_targets(self) -> list[str]:
        """Every product this configuration can make, the lambda fits, the listed studies' files,
        the archive's manifest (simulating) or its verification (reusing), and the identification
        CSV when identification_csv is set (:meth:`skipped` says what is left out)."""
        out = [f for product in FIGURES + TABLES if not self.missing_requirement(product)
               for f in self.product_files(product)]
        if not self.fit_requirement():
            out += [f for f in self.fit_jsons().values() if f not in out]
        out += [f for f in self.studies.targets() if f not in out]
        out.append(self.archive_files()["manifest"] if self.simulate else self.verify_file)
        if self.simulate and self.config.get("identification_csv"):
            out.append(self.config["identification_csv"])
        return out

    def calibration_file(self, role: str) -> str:
        """A file of the calibration's folder: ``fit`` (what ``snakemake calibrate`` did), the
        report's ``md``, ``html`` and ``csv``."""
        return f"{self.results}/calibration/{CALIBRATION_FILES[role]}"

    def calibration_targets(self) -> list[str]:
        """The calibration report, when the campaign has what its held-out rows need."""
        if not self.missing_requirement("table4") and not self.missing_requirement("fig9"):
            return [self.calibration_file("md"), self.calibration_file("html")]
        return []

    def log_file(self, rule: str, unit: str | None = None, *, root: str | None = None) -> str:
        """Log of one job: ``<root>/logs/<rule>[/<unit>].log``, the campaign's results folder by default."""
        return log_path(root or self.results, rule, unit)

    def bench_file(self, rule: str, unit: str | None = None) -> str:
        """Snakemake benchmark record of one job (wall time, CPU time, memory)."""
        return str(Path(self.results, "benchmarks", rule, *([unit] if unit else [])).with_suffix(".tsv"))

    # ------------------------------------------------------------------------------------
    # the archive, the code behind each stage, the rig's and paper's files
    # ------------------------------------------------------------------------------------
    def archive_files(self) -> dict[str, str]:
        """The finalized archive's index.csv, README.md and MANIFEST.sha256."""
        return {k: f"{self.archive}/{name}" for k, name in ARCHIVE_FILES.items()}

    @property
    def verify_file(self) -> str:
        """A re-analysed archive's verification, in its results folder."""
        return f"{self.results}/{paths.VERIFY_FILE}"

    @property
    def response_model(self) -> str:
        """The shipped response model (fitted by the designed campaign), beside the paper file."""
        return str(Path(self.paper_file).parent / "response_model.json")

    @property
    def calibration_settings(self) -> str:
        """The calibration's observations and bounds (``config/calibration.yaml``)."""
        return str(config_file("calibration.yaml"))
