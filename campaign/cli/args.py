"""How the subcommands read their arguments: the parser, vectors, named lambdas, ``KEY=VALUE``
settings and values that start with ``-``.

:class:`OneLineParser` is every subcommand's parser: usage errors are one line, and an option
value that looks like a negative number, or a vector starting with one (``--direction
-1,0,0``), is taken as the value of the option before it, as if written ``--direction=-1,0,0``
(argparse on its own takes ``-1,0,0`` for an unknown option). Standard library and
:mod:`campaign.core.errors` only: ``campaign --help`` imports this module and no stage.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from collections.abc import Iterable, Sequence
from typing import Any

import yaml

from ..core.errors import InputError
from ..core.yamlfile import yaml_load

__all__ = ["NEGATIVE_VALUE", "OneLineParser", "join_negative_values", "parse_vector", "parse_named_lambdas",
           "key_value"]

#: an argument that starts like a negative number ("-1", "-.5", "-1,0,0"): a value, never an option
#: (no subcommand has an option spelled like a number)
NEGATIVE_VALUE = re.compile(r"^-\.?\d")


def join_negative_values(argv: Sequence[str]) -> list[str]:
    """``argv`` with each long option followed by a value that starts like a negative number
    written as one word, ``["--q", "-10,150,90"]`` -> ``["--q=-10,150,90"]``; nothing after
    ``--`` is touched."""
    out: list[str] = []
    words = list(argv)
    i = 0
    while i < len(words):
        word = words[i]
        if word == "--":
            out.extend(words[i:])
            break
        if (word.startswith("--") and len(word) > 2 and "=" not in word and i + 1 < len(words)
                and NEGATIVE_VALUE.match(words[i + 1])):
            out.append(f"{word}={words[i + 1]}")
            i += 2
            continue
        out.append(word)
        i += 1
    return out


class OneLineParser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line on stderr, as every other error of
    the command: ``campaign <cmd>: error: <what>; see 'campaign <cmd> --help'`` (status 2);
    a value starting like a negative number may follow its option as a word of its own
    (:func:`join_negative_values`)."""

    def parse_known_args(self, args: Sequence[str] | None = None, namespace: argparse.Namespace | None = None):
        words = sys.argv[1:] if args is None else args
        return super().parse_known_args(join_negative_values(words), namespace)

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())}; see '{self.prog} --help'\n")


def parse_vector(text: str, *, option: str, size: int, units: str = "") -> list[float]:
    """Parse ``"a,b,c"`` into ``size`` finite floats, or raise InputError naming the value.

    Parameters
    ----------
    text : str
        The option's value as typed.
    option : str
        Option name for the message (``"--lambda"``).
    size : int
        Number of values expected.
    units : str
        Units for the message.
    """
    unit = f" [{units}]" if units else ""
    parts = [s.strip() for s in str(text).split(",")]
    if len(parts) != size:
        raise InputError(f"{option} {text}: expected {size} comma-separated values{unit}, got {len(parts)}")
    out = []
    for i, s in enumerate(parts, start=1):
        try:
            v = float(s)
        except ValueError:
            raise InputError(f"{option} {text}: value {i} {s!r} is not a number") from None
        if not math.isfinite(v):
            raise InputError(f"{option} {text}: value {i} = {s} is not a finite number")
        out.append(v)
    return out


def parse_named_lambdas(texts: Iterable[str], *, nv: int) -> dict[str, list[float]]:
    """``--lambda NAME=L1,L2,L3`` options as ``{NAME: [L1, L2, L3]}`` (kg m^2, each >= 0), ``nv``
    values each (one per joint of the planner's robot)."""
    out: dict[str, list[float]] = {}
    for text in texts:
        name, sep, values = str(text).partition("=")
        if not sep or not name.strip():
            raise InputError(f"--lambda {text}: expected NAME=L1,L2,L3")
        lam = parse_vector(values, option=f"--lambda {name.strip()}", size=nv, units="kg m^2")
        if any(v < 0 for v in lam):
            raise InputError(f"--lambda {text}: lambda must be >= 0 kg m^2")
        if name.strip() in out:
            raise InputError(f"--lambda {text}: gain class {name.strip()!r} is given twice; give each class once")
        out[name.strip()] = lam
    return out


def key_value(text: str) -> tuple[str, Any]:
    """A ``--set KEY=VALUE`` option as ``(KEY, VALUE)``, the value read as YAML (an argparse ``type``)."""

    if "=" not in text:
        raise argparse.ArgumentTypeError(f"--set expects KEY=VALUE, got {text!r}")
    key, value = text.split("=", 1)
    try:
        return key.strip(), yaml_load(value)
    except yaml.YAMLError as exc:
        problem = getattr(exc, "problem", None) or type(exc).__name__
        raise argparse.ArgumentTypeError(f"--set {key.strip()}: the value is not valid YAML: {problem}") from None
