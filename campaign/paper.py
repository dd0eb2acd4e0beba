"""The paper's conventions and published values, read from ``config/paper.yaml``.

Configurations, the paper-to-DH angle mapping and the impact direction live in the
config folder, not in code; this module only reads and checks them.
"""

from __future__ import annotations

import functools
import os
import re
from pathlib import Path

import numpy as np
import yaml

from .errors import InputError

__all__ = ["yaml_load", "read_yaml", "copy_tree", "config_dir", "load_paper", "paper_q", "configuration_q", "impact_direction"]


class _Loader(yaml.SafeLoader):
    """SafeLoader that also reads YAML 1.2 floats such as ``2.5e8`` (PyYAML needs ``2.5e+8``)."""


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"""^(?:[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?(?:[eE][-+]?[0-9]+)
    |[-+]?(?:[0-9][0-9_]*)\.[0-9_]*
    |[-+]?\.[0-9_]+(?:[eE][-+]?[0-9]+)?
    |[-+]?\.(?:inf|Inf|INF)
    |\.(?:nan|NaN|NAN))$""", re.X),
    list("-+0123456789."),
)


def yaml_load(stream):
    """Parse YAML with scientific-notation floats read as floats."""
    return yaml.load(stream, Loader=_Loader)


def config_dir() -> Path:
    """The project's ``config/`` folder (``$CAMPAIGN_CONFIG_DIR`` overrides it)."""
    env = os.environ.get("CAMPAIGN_CONFIG_DIR")
    path = Path(env) if env else Path(__file__).resolve().parents[1] / "config"
    if not (path / "paper.yaml").is_file():
        raise FileNotFoundError(
            f"config folder {path} has no paper.yaml; install the project editable "
            "(pip install -e .) or set CAMPAIGN_CONFIG_DIR"
        )
    return path


@functools.lru_cache(maxsize=32)
def _parse(path: str, content: bytes):
    try:
        return yaml_load(content.decode("utf-8"))
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        where = getattr(exc, "problem_mark", None)
        at = f" (line {where.line + 1}, column {where.column + 1})" if where is not None else ""
        problem = getattr(exc, "problem", None) or type(exc).__name__
        raise InputError(f"{path}: not valid YAML{at}: {problem}") from None


def copy_tree(node):
    """Copy of a parsed YAML tree (its dicts and lists; the scalars are immutable)."""
    if isinstance(node, dict):
        return {k: copy_tree(v) for k, v in node.items()}
    if isinstance(node, list):
        return [copy_tree(v) for v in node]
    return node


def read_yaml(path, *, copy: bool = True):
    """Parse the YAML file ``path``, once per content.

    The cache is keyed on the file's bytes (read every call, tens of microseconds), so a
    file edited on disk is picked up at once, even when rewritten within one tick of the
    file system's clock with the same size, where its mtime would not change. With
    ``copy=False`` the cached tree itself is returned: the caller must not modify it."""
    path = str(path)
    with open(path, "rb") as fh:
        content = fh.read()
    tree = _parse(path, content)
    return copy_tree(tree) if copy else tree


def load_paper() -> dict:
    """The parsed ``paper.yaml`` (cached while the file is unchanged; treat as read-only)."""
    return read_yaml(config_dir() / "paper.yaml", copy=False)


def paper_q(q_paper_deg) -> np.ndarray:
    """Map the paper's joint angles [deg] to the model's DH angles [rad]."""
    q = np.asarray(q_paper_deg, dtype=float)
    off = np.asarray(load_paper()["offset_deg"], dtype=float)
    if q.shape != off.shape:
        raise ValueError(f"expected {off.size} paper angles, got {q.tolist()}")
    return np.radians(q + off)


def configuration_q(config) -> np.ndarray:
    """DH angles [rad] of the paper's configuration ``config`` (1, 2 or 3)."""
    table = load_paper()["configurations"]
    try:
        key = int(config)
    except (TypeError, ValueError):
        key = None
    if key not in table:
        raise ValueError(f"unknown configuration {config!r}; known: {sorted(table)}")
    return paper_q(table[key])


def impact_direction() -> np.ndarray:
    """Unit impact direction n of the paper, base frame."""
    n = np.asarray(load_paper()["impact_direction"], dtype=float)
    return n / np.linalg.norm(n)
