"""The cluster profile's group names real rules, and every job after the simulations is in it.

profiles/slurm lists the rules of its downstream group by name, so a renamed or added rule
would silently run as its own SLURM job (or name a rule that no longer exists). The rules
come from the workflow itself (``snakemake --list-rules``) with the archive simulated and
reused (``finalize_archive`` and ``verify_archive`` exist one at a time). Needs neither
SLURM nor its plugin.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import yaml

import snakemake_forks

REPO = Path(__file__).resolve().parents[2]
PROFILE = yaml.safe_load((REPO / "profiles" / "slurm" / "config.yaml").read_text())
# rules that stay one SLURM job each (simulations, the calibration fit, the designed campaign's plan and
# trials) or only name targets
NOT_GROUPED = re.compile(r"simulate_\w+|\w+_study|study_\w+|studies|calibrate|all|trials|identification|archive|fig\d|"
                         r"table\d|plan_maps|eq8_validity|table4_structures|plan_rig_check|designed|designed_plan|"
                         r"designed_trials|designed_flexible_trials")


def workflow_rules(work: Path, *config: str) -> set[str]:
    proc = snakemake_forks.run(["-s", str(REPO / "Snakefile"), "--directory", str(work), "--configfile",
                                str(REPO / "config" / "tests" / "ci.yaml"), "--list-rules",
                                *(["--config", *config] if config else [])], cwd=work, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return set(proc.stdout.split())


@pytest.fixture(scope="module")
def rules(tmp_path_factory) -> set[str]:
    """The workflow's rules, listed in a folder laid out like the repository's root."""
    work = tmp_path_factory.mktemp("rules")
    (work / "config").symlink_to(REPO / "config")
    (work / "archive").mkdir()
    (work / "archive" / "reference").symlink_to(REPO / "archive" / "reference")
    return workflow_rules(work) | workflow_rules(work, "simulate=False", "reuse_archive=archive/reference")


def test_group_holds_exactly_the_downstream_rules(rules):
    grouped = {}
    for entry in PROFILE["groups"]:
        rule, _, group = entry.partition("=")
        grouped[rule] = group
    assert set(grouped.values()) == {"downstream"}
    assert sorted(set(grouped) - rules) == [], "the profile groups rules the workflow does not have"
    downstream = {r for r in rules if not NOT_GROUPED.fullmatch(r)}
    assert sorted(downstream - set(grouped)) == [], "jobs after the simulations outside the group"
    assert {"simulate_fixed", "simulate_flexible"} <= rules - set(grouped)


def test_group_components_join_the_whole_group():
    (entry,) = PROFILE["group-components"]
    group, _, n = entry.partition("=")
    # every downstream rule job of the full campaign fits in one SLURM job
    assert group == "downstream" and int(n) >= len(PROFILE["groups"]) * 4
