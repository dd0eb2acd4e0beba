"""The subcommands' shared argument reading (campaign.cli.args): a value that starts like a
negative number follows its option as a word of its own, on argparse's public API only."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from campaign.cli.args import join_negative_values, key_value, parse_vector
from campaign.cli.main import build_parser
from campaign.core.errors import InputError

CLI = Path(__file__).resolve().parents[2] / "campaign" / "cli"


@pytest.mark.parametrize("argv, joined", [
    (["--q", "-10,150,90"], ["--q=-10,150,90"]),
    (["meff", "--direction", "-.5,0,0", "--json"], ["meff", "--direction=-.5,0,0", "--json"]),
    (["plan", "--mass", "-1", "--top", "-2"], ["plan", "--mass=-1", "--top=-2"]),
    # an option already joined, a short option, a word that is not a number, and all after "--" stay
    (["--q=-1,0,0", "-q", "-1", "--json", "-x"], ["--q=-1,0,0", "-q", "-1", "--json", "-x"]),
    (["--", "--q", "-1"], ["--", "--q", "-1"]),
    (["--q"], ["--q"]),
])
def test_a_negative_value_is_joined_to_its_option(argv, joined):
    assert join_negative_values(argv) == joined


@pytest.mark.parametrize("argv, dest, value", [
    (["meff", "--q", "-10,150,90"], "q", "-10,150,90"),
    (["plan", "--point", "-0.6,-0.15,-0.15"], "point", "-0.6,-0.15,-0.15"),
    (["map", "directions", "--q", "-5,150,90", "--out", "m.png"], "q", "-5,150,90"),
    (["trial", "--direction", "-1,0,0", "--speed", "1", "--out", "t.nc"], "direction", "-1,0,0"),
    (["design", "--prior", "high=-1,2,3"], "prior", ["high=-1,2,3"]),
])
def test_every_subcommand_takes_a_negative_value_as_a_separate_word(argv, dest, value):
    args = build_parser(argv).parse_args(argv)
    assert getattr(args, dest) == value


def test_the_cli_uses_no_private_attribute_of_another_object():
    """argparse's public API only: no ``obj._name`` on anything but ``self``/``cls``."""
    hits = []
    for path in sorted(CLI.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if (isinstance(node, ast.Attribute) and node.attr.startswith("_") and not node.attr.startswith("__")
                    and not (isinstance(node.value, ast.Name) and node.value.id in ("self", "cls"))):
                hits.append(f"{path.name}:{node.lineno} .{node.attr}")
    assert hits == []


def test_vectors_and_settings_name_the_bad_value():
    assert parse_vector("-1,0,0.5", option="--direction", size=3) == [-1.0, 0.0, 0.5]
    with pytest.raises(InputError, match=r"--q 1,2: expected 3 comma-separated values \[deg\], got 2"):
        parse_vector("1,2", option="--q", size=3, units="deg")
    with pytest.raises(InputError, match="value 2 'x' is not a number"):
        parse_vector("1,x,3", option="--q", size=3)
    assert key_value("contact.stiffness=2e3") == ("contact.stiffness", 2000.0)
