"""Parts of the campaign's plan: the report's products, the jobs (their code digests,
priorities, outputs, inputs and logs), the studies' files and the designed campaign's.

The studies do not depend on a campaign's trials: their files go to
``<results_root>/studies/<study>/`` whatever the campaign. The designed campaign
(``config/designed.yaml``, ``snakemake designed``) has a results and archive folder of its
own. :class:`campaign.pipeline.campaign_plan.CampaignPlan` holds one of each. Standard
library and PyYAML only: the workflow makes them every time it starts.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

from .. import studies as study_registry
from ..core import vocabulary
from ..core.errors import InputError
from ..core.yamlfile import read_yaml
from . import digests

__all__ = ["Output", "log_path", "JobOutputs", "StudiesPlan", "DesignedPlan", "PRIORITY", "STAGE_CODE", "FIGURES",
           "TABLES", "STUDY_PRODUCTS", "ANY_ARM_PRODUCTS", "DESIGNED_ROLES", "DESIGNED_FILES"]

#: the report's figures and tables (named targets), in the order the default target lists them
FIGURES = ("fig4", "fig5", "fig6", "fig7", "fig8", "fig9", "plan_maps", "eq8_validity")
TABLES = ("table2", "table3", "table4", "table4_structures", "plan_rig_check")
#: products another robot's campaign makes too (the others compare the paper's arm with the paper)
ANY_ARM_PRODUCTS = ("fig7",)
#: the report's products a study makes: {product: study}
STUDY_PRODUCTS = {"table4_structures": "space_structure", "eq8_validity": "space_structure",
                  "plan_rig_check": "plan_rig_check"}
#: the roles of the designed campaign's identification tables
DESIGNED_ROLES = ("paper", "designed", "heldout")
#: the designed campaign's files in its results folder, by role
DESIGNED_FILES = {"plan": "plan.json", "design": "design.md", "report_json": "report.json", "report": "report.md",
                  "model": "model/response_model.json", "model_md": "model/response_model.md",
                  "shipped": "model/shipped.txt"}

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
#: the entry modules of each stage (package paths; :func:`campaign.pipeline.digests.code_digest`)
STAGE_CODE = {
    "simulate": ("pipeline/sweep.py",), "identify": ("pipeline/stages.py", "identify/table.py"),
    "fit": ("pipeline/fit.py",), "tables": ("pipeline/tabulate.py",),
    "calibration_report": ("pipeline/calibration_report.py",), "designed": ("design/designed_campaign.py",),
    "designed_model": ("design/designed_model.py",),
}
#: the robot files every stage's digest covers
_ROBOT_FILES = "model/robot/*/*"


class Output(NamedTuple):
    """One file a job writes, and how the report shows it: None, or Snakemake's ``report()``
    keywords with ``caption`` the name of its caption ``workflow/report/<caption>.rst``."""

    path: str
    report: Mapping[str, Any] | None = None


def _figure_report(name: str, category: str, fmt: str, **labels) -> dict:
    return {"caption": name, "category": category, "subcategory": "Figures", "labels": {**labels, "format": fmt}}


def log_path(root: str, rule: str, unit: str | None = None) -> str:
    """Log of one job: ``<root>/logs/<rule>[/<unit>].log``."""
    return str(Path(root, "logs", rule, *([unit] if unit else [])).with_suffix(".log"))


class JobOutputs:
    """The code digests of the jobs, and the outputs, inputs and logs of the jobs after the
    simulations (fixed_base, flexible_base, the figures' jobs) by what the campaign can make:
    a part of :class:`campaign.pipeline.campaign_plan.CampaignPlan`, which names the files and
    says what each product requires."""

    @staticmethod
    def stage_code(stage: str) -> str:
        """The digest of a stage's code (:data:`STAGE_CODE`) with the robot files."""
        return digests.code_digest(*STAGE_CODE[stage], _ROBOT_FILES)

    @staticmethod
    def figure_code(name: str) -> str:
        """Digest of a figure's module and every package module it imports, with the robot files."""
        return digests.code_digest(f"report/figures/{name}.py", _ROBOT_FILES)

    @staticmethod
    def study_code(name: str) -> str:
        """Digest of a study's module (and what it imports), with the robot files."""
        return digests.code_digest(f"studies/{name}.py", _ROBOT_FILES)

    def figure_outputs(self, name: str, category: str) -> dict[str, Output]:
        """{<name>_png, <name>_pdf} of one figure, both shown in the report."""
        png, pdf = self.figure_files(name)
        label = f"Figure {name[len('fig'):]}"
        return {f"{name}_png": Output(png, _figure_report(name, category, "PNG", figure=label)),
                f"{name}_pdf": Output(pdf, _figure_report(name, category, "vector PDF", figure=label))}

    def planner_map_outputs(self) -> dict[str, Output]:
        """The planner's workspace and direction maps, PNG and PDF, shown in the report."""
        out = {}
        for which in ("workspace", "directions"):
            report = {"caption": f"plan_{which}", "category": "Impact planner", "subcategory": "Maps"}
            png, pdf = self.figure_files(f"plan_{which}")
            out[which] = Output(png, {**report, "labels": {"map": which, "format": "PNG"}})
            out[f"{which}_pdf"] = Output(pdf, {**report, "labels": {"map": which, "format": "vector PDF"}})
        return out

    def _table_outputs(self, name: str, category: str) -> dict[str, Output]:
        csv, md = self.table_files(name)
        html = Output(f"{self.results}/tables/{name}.html",
                      {"caption": name, "category": category, "subcategory": "Tables",
                       "labels": {"table": f"Table {name[len('table'):]}"}})
        return {f"{name}_csv": Output(csv), f"{name}_md": Output(md), f"{name}_html": html}

    def fixed_base_products(self) -> list[str]:
        """The products the fixed_base job makes, in the order it makes them (the fits
        ``fit_<class>`` first: Table 3 reads them). The fits are made whenever the default
        target asks for them (``fit_requirement`` met), Tables 2-3 only for a complete sweep."""
        out = [f"fit_{k}" for k in self.fit_classes()] if not self.fit_requirement() else []
        out += [p for p in ("table2", "table3") if not self.missing_requirement(p)]
        return out + [p for p in ("fig6", "fig7") if not self.missing_requirement(p)]

    def fixed_base_outputs(self) -> dict[str, Output]:
        """The fixed_base job's outputs, named ``<product>_<kind>`` (the fits ``fit_<class>``)."""
        out = {}
        for product in self.fixed_base_products():
            if product.startswith("fit_"):
                out[product] = Output(self.fit_jsons()[product[len("fit_"):]])
            elif product.startswith("table"):
                category = "Fixed base" if product == "table2" else "Virtual rotor inertia (lambda)"
                out.update(self._table_outputs(product, category))
            else:
                out.update(self.figure_outputs(product, "Fixed base"))
        return out

    def fixed_base_logs(self) -> dict[str, str]:
        """One log per product (the fits' under fit_lambda/<class>.log), then the job's own."""
        out = {p: self.log_file("fit_lambda", p[len("fit_"):]) if p.startswith("fit_") else self.log_file(p)
               for p in self.fixed_base_products()}
        return {**out, "job": self.log_file("fixed_base")}

    def flexible_base_products(self) -> list[str]:
        """The products the flexible_base job makes (Table 4 first: the calibration report reads it)."""
        return ((["table4"] if not self.missing_requirement("table4") else [])
                + (["calibration"] if self.calibration_targets() else []))

    def flexible_base_outputs(self) -> dict[str, Output]:
        """The flexible_base job's outputs: Table 4's and the calibration report's files."""
        products = self.flexible_base_products()
        out = self._table_outputs("table4", "Flexible base") if "table4" in products else {}
        if "calibration" in products:
            out["calibration_md"] = Output(self.calibration_file("md"))
            out["calibration_html"] = Output(self.calibration_file("html"), {
                "caption": "calibration", "category": "Calibration", "subcategory": "Fitted and held-out observations",
                "labels": {"report": "The simulated rig against the paper"}})
            out["calibration_csv"] = Output(self.calibration_file("csv"))
        return out

    def flexible_base_inputs(self) -> dict[str, Any]:
        """The flexible_base job's inputs: the flexible base's identification, the fits, the
        shipped response model (Table 4's model column) and Figure 9's trials (the calibration report)."""
        out = {"paper": self.paper_file, "rig": self.rig_file, "tables": self.ident_tables(self.flexible_base),
               **self.fit_jsons()}
        if "table4" in self.flexible_base_products():
            out["model"] = self.response_model
        if "calibration" in self.flexible_base_products():
            out["trials"] = self.figure_inputs("fig9")
        return out

    def flexible_base_logs(self) -> dict[str, str]:
        """One log per product, then the job's own."""
        out = {p: self.log_file("calibration_report" if p == "calibration" else p)
               for p in self.flexible_base_products()}
        return {**out, "job": self.log_file("flexible_base")}


class StudiesPlan:
    """The studies' files (:mod:`campaign.studies`).

    Parameters
    ----------
    results_root : str
        The configuration's ``results_root``.
    selected : sequence of str
        The studies the campaign's default target and report include (``studies:``).
    quick : bool
        A reduced run of each study (seconds; the tests), into a folder of its own.
    """

    def __init__(self, *, results_root: str, selected: Sequence[str], quick: bool):
        self.results_root = str(results_root)
        self.selected = list(selected)
        self.quick = bool(quick)
        #: every study, as the configuration key ``studies:`` names them
        self.names = tuple(study_registry.NAMES)

    def dir(self, name: str) -> str:
        """Folder of one study's files: ``<results_root>/studies/<study>[/quick]``."""
        return str(Path(self.results_root, "studies", name, *(["quick"] if self.quick else [])))

    def outputs(self, name: str) -> list[str]:
        """The files one study's job writes (campaign.studies.FILES)."""
        return [f"{self.dir(name)}/{f}" for f in study_registry.FILES[name]]

    def output(self, name: str, file: str) -> str:
        """One file of a study's job, by its name in campaign.studies.FILES."""
        if file not in study_registry.FILES[name]:
            raise InputError(f"study {name} writes no {file!r}; it writes {list(study_registry.FILES[name])}")
        return f"{self.dir(name)}/{file}"

    def log(self, name: str, rule: str) -> str:
        """Log of a job of one study, in the study's folder."""
        return log_path(self.dir(name), rule)

    def report_files(self, product: str) -> list[str]:
        """The rendered table (CSV, Markdown, HTML) or figure (PNG, PDF) of a study that the report shows."""
        stem = f"{self.dir(STUDY_PRODUCTS[product])}/report/{product}"
        return [f"{stem}.png", f"{stem}.pdf"] if product in FIGURES else [f"{stem}.csv", f"{stem}.md", f"{stem}.html"]

    def report_outputs(self, product: str, *, caption: str, category: str, subcategory: str,
                       labels: Mapping[str, str]) -> dict[str, Output]:
        """:meth:`report_files` as outputs named by suffix, the HTML or each figure format in the report."""
        out = {}
        for path in self.report_files(product):
            kind = path.rsplit(".", 1)[1]
            shown = {"csv": None, "md": None, "html": {}, "png": {"format": "PNG"}, "pdf": {"format": "vector PDF"}}[kind]
            out[kind] = Output(path, None if shown is None else {"caption": caption, "category": category,
                                                                 "subcategory": subcategory,
                                                                 "labels": {**labels, **shown}})
        return out

    def files(self, name: str) -> list[str]:
        """Everything of one study: its job's files and what the report shows of them."""
        return self.outputs(name) + [f for p, s in STUDY_PRODUCTS.items() if s == name for f in self.report_files(p)]

    def targets(self) -> list[str]:
        """The files of the studies the configuration lists under ``studies:``."""
        return [f for name in self.selected for f in self.files(name)]

    def all_files(self) -> list[str]:
        """The files of every study."""
        return [f for name in self.names for f in self.files(name)]


class DesignedPlan:
    """The designed campaign's files: its settings (``config/designed.yaml`` or the file the
    configuration key ``designed`` names), identification tables, model and logs.

    Parameters
    ----------
    settings_file : str
        The designed campaign's settings file.
    named : bool
        The configuration names the file (then it must exist; the project's own may be absent,
        and the designed rules are then not defined).
    results_root, archive_root : str
        The configuration's folders.
    structures : sequence of str
        The rig file's named structures (the held-out poses are struck under each).
    """

    def __init__(self, *, settings_file: str, named: bool, results_root: str, archive_root: str,
                 structures: Sequence[str]):
        self.file = str(settings_file)
        self.results_root, self.archive_root = str(results_root), str(archive_root)
        self.structures = sorted(structures)
        self.roles = DESIGNED_ROLES
        #: the settings as read (None when the file is absent); the workflow validates them
        #: against workflow/schemas/designed.schema.yaml, which fills in their defaults
        self.settings: dict | None = None
        if Path(self.file).is_file():
            self.settings = read_yaml(self.file)
        elif named:
            raise InputError(f"configuration key designed: {self.file!r} does not exist")

    @property
    def results(self) -> str:
        """The designed campaign's results folder: ``<results_root>/<its campaign>``."""
        return f"{self.results_root}/{self._campaign()}"

    @property
    def archive(self) -> str:
        """The designed campaign's archive folder: ``<archive_root>/<its campaign>``."""
        return f"{self.archive_root}/{self._campaign()}"

    def _campaign(self) -> str:
        if not self.settings:
            raise InputError(f"the designed campaign needs its settings {self.file}")
        return str(self.settings["campaign"])

    def path(self, role: str) -> str:
        """One of the designed campaign's files by role (:data:`DESIGNED_FILES`)."""
        return f"{self.results}/{DESIGNED_FILES[role]}"

    def table_pattern(self) -> str:
        """Output pattern of the identification CSV of one role and gain set."""
        return f"{self.results}/identification/{{role}}_{{gain}}.csv"

    def tables(self, role: str) -> list[str]:
        """Identification CSVs of one role of the designed campaign, every gain set."""
        return [self.table_pattern().format(role=role, gain=g) for g in vocabulary.gain_sets()]

    def flexible_pattern(self) -> str:
        """Output pattern of the held-out poses' identification on the flexible base, one
        structure and gain set."""
        return f"{self.results}/identification/flexible/{{structure}}_{{gain}}.csv"

    def flexible_tables(self) -> list[str]:
        """Identification CSVs of the held-out poses on the flexible base, every structure and gain set."""
        return [self.flexible_pattern().format(structure=s, gain=g) for s in self.structures
                for g in vocabulary.gain_sets()]

    def structure_archive(self, structure: str) -> str:
        """The archive folder of the held-out poses' trials under one named structure."""
        return f"{self.archive}/structures/{structure}"

    def study_inputs(self) -> list[str]:
        """The designed campaign's identification tables (study impact_resistance)."""
        if not self.settings:
            raise InputError(f"study impact_resistance needs the designed campaign's settings {self.file}")
        return [t for role in ("designed", "heldout") for t in self.tables(role)]

    def log(self, rule: str, unit: str | None = None) -> str:
        """Log of one job of the designed campaign."""
        return log_path(self.results, rule, unit)
