"""The project's one YAML reader: what it reads as PyYAML's safe loader does, and what it refuses."""

from __future__ import annotations

import pytest
import yaml

from campaign.core.errors import InputError
from campaign.core.yamlfile import (
    MAX_YAML_BYTES,
    MAX_YAML_DEPTH,
    MAX_YAML_NODES,
    parse_yaml_bytes,
    read_yaml,
    yaml_load,
)


@pytest.mark.parametrize("text", [
    "a: 1\nb: [1, 2.5, x, null, true]\nc: {d: {e: f}}\n",
    "base: &b {x: 1, y: 2}\nother: {<<: *b, y: 3}\n",      # a merge key: explicit keys win, no duplicate
    "- &a [1, 2]\n- *a\n- *a\n",
    "x: '2001-01-01'\ny: 0x10\nz: .inf\n",
])
def test_reads_what_safe_load_reads(text):
    assert yaml_load(text) == yaml.safe_load(text)


def test_scientific_floats_without_a_sign_are_floats():
    assert yaml_load("a: 2.5e8\nb: 1e-3\nc: 1E3\n") == {"a": 2.5e8, "b": 1e-3, "c": 1e3}


@pytest.mark.parametrize("text, line, first", [
    ("a: 1\nb: 2\na: 3\n", 3, 1),
    ("top:\n  x: 1\n  y: 2\n  x: 3\n", 4, 2),
    ("{a: 1, a: 2}\n", 1, 1),
    ("- {k: 1}\n- {k: 1, k: 2}\n", 2, 2),
])
def test_a_key_given_twice_is_refused_naming_it_and_both_lines(text, line, first):
    with pytest.raises(InputError) as info:
        parse_yaml_bytes("f.yaml", text.encode())
    message = str(info.value)
    assert message.startswith(f"f.yaml: refused (line {line}, ") and "is given twice" in message
    assert f"(first on line {first})" in message


def test_an_alias_bomb_is_refused_while_composed():
    bomb = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
        f"{b}: &{b} [{', '.join([f'*{a}'] * 9)}]\n" for a, b in zip("abcdefgh", "bcdefghi", strict=True))
    with pytest.raises(yaml.YAMLError, match=f"more than {MAX_YAML_NODES:,} nodes"):
        yaml_load(bomb)
    # a few aliases of a small node are fine
    assert yaml_load("a: &a [1, 2]\nb: [*a, *a]\n") == {"a": [1, 2], "b": [[1, 2], [1, 2]]}


def test_the_node_limit_counts_expanded_aliases():
    """A mapping {a: <100 scalars>, b: [*a x k]} holds 1 + 1 + 101 + 1 + 1 + 101 k nodes
    expanded: the largest k within the limit reads, one more alias is refused."""

    def text(k: int) -> str:
        return "a: &a [" + ", ".join(["0"] * 100) + "]\nb: [" + ", ".join(["*a"] * k) + "]\n"

    k = (MAX_YAML_NODES - 105) // 101
    assert len(yaml_load(text(k))["b"]) == k
    with pytest.raises(yaml.YAMLError, match="nodes with its aliases expanded"):
        yaml_load(text(k + 1))


@pytest.mark.parametrize("text, names", [
    ("a: &a [1, *a]\n", "recursive alias"),
    ("[" * (MAX_YAML_DEPTH + 1) + "]" * (MAX_YAML_DEPTH + 1), f"nested more than {MAX_YAML_DEPTH} levels"),
    ("x: " + "9" * 5000 + "\n", "Exceeds the limit (4300 digits)"),
    ("x: 2001-13-45\n", "month must be in 1..12"),
    ("x: [1,\n", "not valid YAML (line 2, column 1)"),
])
def test_refusals_are_one_line_naming_the_file(text, names):
    with pytest.raises(InputError) as info:
        parse_yaml_bytes("f.yaml", text.encode())
    assert names in str(info.value) and str(info.value).startswith("f.yaml: ") and "\n" not in str(info.value)


def test_a_file_over_the_size_limit_is_not_parsed(tmp_path):
    path = tmp_path / "big.yaml"
    path.write_bytes(b"a: 1\n" + b"#" * MAX_YAML_BYTES)
    with pytest.raises(InputError, match=r"big.yaml: larger than 1 MiB, not read"):
        read_yaml(path)
    path.write_bytes(b"a: 1\n" + b"#" * (MAX_YAML_BYTES - 10))
    assert read_yaml(path) == {"a": 1}
