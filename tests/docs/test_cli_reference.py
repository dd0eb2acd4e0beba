"""The CLI reference of the user guide (docs/cli.rst) documents every subcommand and option
of the ``campaign`` command, and no other; every subcommand runs through the CLI in a test,
and so does every command the README and the guide show.

The page documents a subcommand under ``.. program:: campaign <cmd>`` (``campaign archive
ls`` for a nested one) and each of its options and positional arguments with
``.. option::``; the parsers are :func:`campaign.cli.main.build_parser`'s.

What runs where:

* The console examples (``$ campaign ...`` in a console block of README.md or a page of
  ``docs/``) run in ``tests/docs/test_readme.py``, compared with the output they show.
* A command the README or the guide shows elsewhere (inline code, a ``sh`` block) is either
  one of those console examples or a key of :data:`RUN_BY_TEST`, which names the test that
  runs it through the CLI and, where the test runs it at a test-sized setting, which
  options differ and why. A line with a placeholder (``DIR``, ``<name>``, ``...``, a pipe)
  is a template: its subcommand and options must exist. A bare subcommand path
  (``campaign archive verify``) names the subcommand.
* Every leaf subcommand (``campaign bench stress``, ``campaign map``, ...) is run by a
  console example or by a :data:`RUN_BY_TEST` entry.

Each entry is checked: its test (or the fixture a test uses) exists, its source holds the
command line it runs as one literal sequence of words, and that line parses to the
documented one but for the options the entry names.
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import re
import shlex
from collections.abc import Mapping
from pathlib import Path

import pytest

from campaign.cli.main import build_parser

from console_examples import REPO, file_examples, sources

PAGE = REPO / "docs" / "cli.rst"


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def programs() -> dict[str, argparse.ArgumentParser]:
    """``{"campaign meff": parser, "campaign archive ls": parser, ...}``: every leaf command."""
    found = {}
    stack = [("campaign", build_parser())]
    while stack:
        name, parser = stack.pop()
        children = _subparsers(parser)
        if not children:
            found[name] = parser
        stack += [(f"{name} {child}", p) for child, p in children.items()]
    return found


def parser_options(parser: argparse.ArgumentParser) -> set[str]:
    """The long option strings and positional metavars (or choices) of a parser, help left out."""
    out = set()
    for action in parser._actions:
        if isinstance(action, argparse._HelpAction):
            continue
        if action.option_strings:
            out.add(max(action.option_strings, key=len))
        elif action.choices:
            out |= set(action.choices)
        else:
            out.add(action.metavar or action.dest)
    return out


def documented() -> dict[str, set[str]]:
    """``{program: names of its .. option:: entries}`` of the reference page."""
    found: dict[str, set[str]] = {}
    program = None
    for line in PAGE.read_text(encoding="utf-8").splitlines():
        if m := re.match(r"\.\. program:: (.+?)\s*$", line):
            program = m.group(1)
            found.setdefault(program, set())
        elif m := re.match(r"\.\. option:: (\S+)", line):
            assert program, f"option {m.group(1)} before any program directive"
            found[program].add(m.group(1))
    return found


PROGRAMS = programs()


def test_every_command_has_a_section_and_nothing_else_does():
    assert set(documented()) == set(PROGRAMS)


@pytest.mark.parametrize("program", sorted(PROGRAMS))
def test_every_option_is_documented_and_every_documented_option_exists(program):
    assert documented().get(program, set()) == parser_options(PROGRAMS[program])


# -- what runs each documented command ------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class RunBy:
    """A test that runs a documented command through the CLI.

    ``test`` is ``path::name`` of the test function, or of a fixture its file's tests use;
    ``runs`` the command line it runs, without ``campaign`` (``*``: a path the test
    chooses); ``changes`` ``{option: why}`` for each option whose value differs from the
    documented line's: a test-sized setting, or an output the test reads.
    """

    test: str
    runs: str
    changes: Mapping[str, str] = dataclasses.field(default_factory=dict)


_SMALL_CALIBRATION = ("a set-up of 4 trials, one free parameter and one evaluation; the committed one sweeps 27 "
                      "trials per evaluation and its fit takes minutes")
_CALIBRATE_REPORT = RunBy(
    "tests/pipeline/test_calibrate.py::test_calibrate_skip_fit_validate_reports_both_parts_and_writes_the_report",
    "calibrate --skip-fit --validate --report * --calibration *", {"--calibration": _SMALL_CALIBRATION})

#: the documented commands a console example does not run, each with the test that does
RUN_BY_TEST: dict[str, RunBy] = {
    "campaign bench stress --reduced": RunBy("tests/bench/test_stress.py::stress_run", "bench stress --reduced"),
    "campaign bench work-precision --quick --out bench/": RunBy(
        "tests/bench/test_cli_bench.py::test_work_precision_smoke_runs_to_the_end_and_writes_its_three_files",
        "bench work-precision --smoke --out *",
        {"--quick": "--quick takes minutes", "--smoke": "the same command, end to end, in seconds"}),
    "campaign bench work-precision --smoke": RunBy(
        "tests/bench/test_cli_bench.py::test_work_precision_smoke_runs_to_the_end_and_writes_its_three_files",
        "bench work-precision --smoke --out *", {"--out": "the test reads the files it writes"}),
    "campaign calibrate --skip-fit --validate --report calib/": _CALIBRATE_REPORT,
    "campaign calibrate --skip-fit --validate": dataclasses.replace(_CALIBRATE_REPORT, changes={
        "--calibration": _SMALL_CALIBRATION, "--report": "the test reads the report's files too"}),
    "campaign calibrate --no-write": RunBy(
        "tests/pipeline/test_calibrate.py::test_calibrate_no_write_fits_reports_and_leaves_the_rig_file_alone",
        "calibrate --no-write --calibration *", {"--calibration": _SMALL_CALIBRATION}),
    "campaign design --criterion E --candidates random --n-random 2000 --seed 0": RunBy(
        "tests/design/test_design.py::test_design_e_optimal_on_random_candidates_improves_on_the_paper_for_both_classes",
        "design --criterion E --candidates random --n-random 2000 --seed 0"),
    "campaign design --prior high=2.34,3.55,3.19": RunBy(
        "tests/design/test_design.py::test_design_at_a_fitted_prior_uses_it_for_its_class_only",
        "design --prior high=2.34,3.55,3.19"),
    "campaign recorded-lambda hits.csv --robot seven_axis --fit config_1 --predict config_2": RunBy(
        "tests/design/test_recorded.py::test_recorded_lambda_cli_reports_and_writes_json",
        "recorded-lambda * --robot * --fit config_1 --predict config_2",
        {"hits": "the test writes synthetic per-hit rows of a seven-axis test arm with a known lambda"}),
    "campaign trial --config 3 --gain zero --speed 1.5 --set pendulum.head_mass=2.0 --set contact.stiffness=40000 "
    "--out rig_trial.nc": RunBy(
        "tests/recordings/test_recordings.py::imported",
        "trial --config 3 --gain zero --speed 1.5 --set pendulum.head_mass=2.0 --set contact.stiffness=40000 --out * "
        "--quiet", {"--quiet": "the test reads the file it writes, not the line"}),
    "campaign import --format airhockey rig_hits/rig --object-mass 2.0333 --out recordings/rig": RunBy(
        "tests/recordings/test_recordings.py::imported", "import --format airhockey * --object-mass * --out *",
        {"source": "the test exports the rig's trial into its own temporary folder"}),
    "campaign identify-recordings recordings/rig --out rig_hits.csv": RunBy(
        "tests/recordings/test_recordings.py::imported", "identify-recordings * --out * --bootstrap 200",
        {"dir": "the folder the test imported into", "--bootstrap": "200 draws keep the test quick; 400 by default"}),
    "campaign design --k 6 --repeat-information": RunBy(
        "tests/design/test_design.py::test_design_repeating_information_strikes_three_high_poses_along_n_and_minus_n",
        "design --k 6 --repeat-information"),
}

#: a word of a template rather than a command: a metavar (DIR, robot=FOLDER), <name>, [optional],
#: ..., a pipe or redirection
_PLACEHOLDER = re.compile(r"\.\.\.|[<>|\[\]]|(^|=)[A-Z][A-Z0-9_]+$")
_MD_INLINE = re.compile(r"(?<!`)`(campaign [^`]+)`(?!`)")
_RST_INLINE = re.compile(r"``(campaign [^`]+)``")
_MD_SHELL = re.compile(r"```(?:sh|bash|shell)\n(.*?)```", re.S)
_RST_SHELL = re.compile(r"^([ \t]*)\.\. code-block:: (?:sh|bash|shell)[ \t]*$")


def _words(command: str) -> list[str]:
    """The words of a command line after ``campaign``, its comment left out."""
    words = shlex.split(command, comments=True)
    assert words[0] == "campaign", command
    return words[1:]


def _rst_shell_lines(text: str) -> list[str]:
    lines = text.splitlines()
    found = []
    for i, line in enumerate(lines):
        if m := _RST_SHELL.match(line):
            for following in lines[i + 1:]:
                if following.strip() and len(following) - len(following.lstrip()) <= len(m.group(1)):
                    break
                found.append(following.strip())
    return found


def shown_commands() -> list[tuple[str, str]]:
    """``(file, command)`` for every ``campaign ...`` command README.md and the guide show
    outside console blocks: inline code and lines of shell blocks."""
    found = []
    for path in [REPO / "README.md", *sorted((REPO / "docs").glob("*.rst"))]:
        text = path.read_text(encoding="utf-8")
        if path.suffix == ".md":
            inline = _MD_INLINE.findall(text)
            shell = [line.strip() for block in _MD_SHELL.findall(text) for line in block.splitlines()]
        else:
            inline, shell = _RST_INLINE.findall(text), _rst_shell_lines(text)
        for command in inline + [line for line in shell if line.startswith("campaign ")]:
            found.append((path.name, " ".join(command.split())))
    return found


def _parser_at(words: list[str]) -> tuple[list[str], argparse.ArgumentParser]:
    """The longest subcommand path at the start of ``words`` and its parser."""
    path, parser = [], build_parser()
    for word in words:
        children = _subparsers(parser)
        if word not in children:
            break
        path, parser = [*path, word], children[word]
    return path, parser


def _option_strings(parser: argparse.ArgumentParser) -> set[str]:
    return {s for action in parser._actions for s in action.option_strings}


def examples_run() -> list[list[str]]:
    """The words of every console example of the README and the guide."""
    return [_words(command) for path in sources() for command, _ in file_examples(path)]


def uncovered(programs, examples: list[list[str]], registry: Mapping[str, RunBy]) -> list[str]:
    """The leaf subcommands of ``programs`` that no example and no registry entry runs."""
    run = [*examples, *(entry.runs.split() for entry in registry.values())]
    return sorted(p for p in programs if not any(words[:len(p.split()) - 1] == p.split()[1:] for words in run))


def shown_problems(shown: list[tuple[str, str]], examples: list[list[str]], registry: Mapping[str, RunBy]) -> list[str]:
    """What is wrong with the commands shown outside console blocks: a concrete command no
    example or registry entry runs, a template or a path naming a subcommand or option that
    does not exist."""
    registered = [_words(key) for key in registry]
    problems = []
    for where, command in shown:
        words = _words(command)
        path, parser = _parser_at(words)
        if any(_PLACEHOLDER.search(w) for w in words):      # a template: its options must exist
            unknown = [w.split("=")[0] for w in words if w.startswith("--")
                       and w.split("=")[0] not in _option_strings(parser)]
            if unknown or (words and not path and not _PLACEHOLDER.search(words[0])):
                problems.append(f"{where}: {command}: no such subcommand or option {unknown or words[0]}")
        elif words == path:                                  # names a subcommand
            continue
        elif words not in examples and words not in registered:
            problems.append(f"{where}: {command}: neither a console example nor in RUN_BY_TEST")
    return problems


def _function(path: Path, name: str):
    tree = ast.parse(path.read_text(encoding="utf-8"))
    functions = {n.name: n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))}
    return functions.get(name), functions


def _sequences(function) -> list[list[str | None]]:
    """Each list, tuple and call's arguments in ``function``: its string constants, None for anything else."""
    found = []
    for node in ast.walk(function):
        elements = node.elts if isinstance(node, (ast.List, ast.Tuple)) else node.args if isinstance(node, ast.Call) \
            else None
        if elements is not None:
            found.append([e.value if isinstance(e, ast.Constant) and isinstance(e.value, str) else None
                          for e in elements])
    return found


def _holds(sequence: list[str | None], words: list[str]) -> bool:
    return any(all(w == "*" or sequence[i + j] == w for j, w in enumerate(words))
               for i in range(len(sequence) - len(words) + 1))


def _parsed(words: list[str]) -> dict | None:
    try:
        return vars(build_parser().parse_args(words))
    except SystemExit:
        return None


def entry_problems(command: str, entry: RunBy, *, root: Path = REPO) -> list[str]:
    """What is wrong with a registry entry: its test missing, not holding the command line it
    runs, or that line differing from ``command`` in an option the entry does not name (or
    naming one that does not differ)."""
    file, _, name = entry.test.partition("::")
    path = root / file
    if not path.is_file():
        return [f"{command}: {file} does not exist"]
    function, functions = _function(path, name)
    if function is None:
        return [f"{command}: {file} has no function {name}"]
    problems = []
    if not name.startswith("test_"):
        is_fixture = any("fixture" in ast.unparse(d) for d in function.decorator_list)
        used = any(f.startswith("test_") and name in [a.arg for a in n.args.args] for f, n in functions.items())
        if not (is_fixture and used):
            problems.append(f"{command}: {entry.test} is neither a test nor a fixture a test of its file uses")
    runs = entry.runs.split()
    if not any(_holds(seq, runs) for seq in _sequences(function)):
        problems.append(f"{command}: {entry.test} does not hold {runs}")
    documented, run = _parsed(_words(command)), _parsed([w if w != "*" else "PATH" for w in runs])
    if documented is None or run is None:
        return [*problems, f"{command}: the documented or the run line ({entry.runs}) does not parse"]
    _, parser = _parser_at(runs)
    stars = {a.dest for a in parser._actions for i, w in enumerate(runs)
             if w == "*" and i > 0 and runs[i - 1] in a.option_strings}
    differ = set()
    for dest in set(documented) | set(run):
        if documented.get(dest) != run.get(dest) and not (dest in stars and documented.get(dest) is not None):
            action = next(a for a in parser._actions if a.dest == dest)
            differ.add(max(action.option_strings, key=len) if action.option_strings else dest)
    if differ != set(entry.changes):
        problems.append(f"{command}: runs as {entry.runs}, which differs in {sorted(differ)}; the entry names "
                        f"{sorted(entry.changes)}")
    problems += [f"{command}: no reason given for {option}" for option, why in entry.changes.items() if not why.strip()]
    return problems


SHOWN = shown_commands()
EXAMPLES = examples_run()


def test_every_subcommand_runs_in_an_example_or_a_named_test():
    assert uncovered(PROGRAMS, EXAMPLES, RUN_BY_TEST) == []


def test_every_command_shown_outside_a_console_block_runs_or_is_a_template():
    assert len(SHOWN) >= 20
    assert shown_problems(SHOWN, EXAMPLES, RUN_BY_TEST) == []


def test_every_registry_entry_is_a_shown_command_that_no_console_example_runs():
    shown = [_words(c) for _, c in SHOWN]
    assert [k for k in RUN_BY_TEST if _words(k) not in shown or _words(k) in EXAMPLES] == []


@pytest.mark.parametrize("command", sorted(RUN_BY_TEST))
def test_the_named_test_runs_the_documented_command(command):
    assert entry_problems(command, RUN_BY_TEST[command]) == []


def test_the_checks_catch_a_subcommand_or_command_nothing_runs_and_a_wrong_entry(tmp_path):
    planted = {**PROGRAMS, "campaign ghost": PROGRAMS["campaign meff"]}
    assert uncovered(planted, EXAMPLES, RUN_BY_TEST) == ["campaign ghost"]
    registry = {k: v for k, v in RUN_BY_TEST.items() if not k.startswith("campaign bench stress")}
    assert uncovered(PROGRAMS, EXAMPLES, registry) == ["campaign bench stress"]
    assert shown_problems([("README.md", "campaign bench stress --reduced")], EXAMPLES, registry) == [
        "README.md: campaign bench stress --reduced: neither a console example nor in RUN_BY_TEST"]
    assert shown_problems([("x.rst", "campaign archive ls DIR --fromat csv")], EXAMPLES, registry) != []
    assert shown_problems([("x.rst", "campaign archive ls DIR --format csv"), ("x.rst", "campaign archive verify")],
                          EXAMPLES, registry) == []
    (tmp_path / "tests").mkdir()
    (tmp_path / "tests" / "test_x.py").write_text(
        "def test_stress(run):\n    run(['bench', 'stress', '--reduced'])\n\n"
        "def test_other(run):\n    run(['bench', 'stress'])\n\n"
        "def helper():\n    run(['bench', 'stress', '--reduced'])\n")
    command = "campaign bench stress --reduced"
    assert entry_problems(command, RunBy("tests/test_x.py::test_stress", "bench stress --reduced"), root=tmp_path) == []
    wrong = {
        "has no function test_gone": RunBy("tests/test_x.py::test_gone", "bench stress --reduced"),
        "test_y.py does not exist": RunBy("tests/test_y.py::test_stress", "bench stress --reduced"),
        "does not hold": RunBy("tests/test_x.py::test_other", "bench stress --reduced"),
        "neither a test nor a fixture": RunBy("tests/test_x.py::helper", "bench stress --reduced"),
        "differs in ['--reduced']; the entry names []": RunBy("tests/test_x.py::test_other", "bench stress"),
        "differs in []; the entry names ['--quiet']": RunBy("tests/test_x.py::test_stress", "bench stress --reduced",
                                                            {"--quiet": "a change that is none"}),
    }
    for expected, entry in wrong.items():
        problems = entry_problems(command, entry, root=tmp_path)
        assert len(problems) == 1 and expected in problems[0], (entry, problems)
