"""The package's layout: imports flow one way through the declared layers, no circle, small
modules and functions, no private name re-exported by a package or taken from another module,
every package naming its public interface in ``__all__``, and no base, gain or structure
name spelled outside the vocabulary.

Read with the standard library's ``ast`` (nothing is imported). Every import counts, also
one inside a function: a lazy import defers the cost, not the dependency. Each rule is a
function over a package folder, so the tests below also plant a violation of each in a
small package of their own and check that the rule finds it.
"""

from __future__ import annotations

import ast
import re
import textwrap
from pathlib import Path

import pytest

from campaign import LAYERS
from campaign.core.vocabulary import NAMES
from campaign.pipeline.digests import PACKAGE, closure, graph, lazy_face, modules

MAX_MODULE_LINES = 600
MAX_FUNCTION_LINES = 100
#: the module that spells the vocabulary's names, relative to the package
VOCABULARY = "core/vocabulary.py"
#: a line that uses one of those words for something else says so
NOT_A_NAME = "# not a vocabulary name"


# ---------------------------------------------------------------------------------------
# the rules
# ---------------------------------------------------------------------------------------
def layer_of(module: str, root_name: str, layers) -> int | None:
    """Index of the layer a module belongs to (the root package itself is the lowest)."""
    parts = module.split(".")
    if parts == [root_name]:
        return 0
    return layers.index(parts[1]) if parts[1] in layers else None


def upward_imports(root: Path, layers) -> list[str]:
    """Imports of a module from a layer above its own, and modules outside every layer."""
    found = []
    for module, deps in sorted(graph(root=root).items()):
        mine = layer_of(module, root.name, layers)
        if mine is None:
            found.append(f"{module} belongs to no layer")
            continue
        for dep in sorted(deps):
            theirs = layer_of(dep, root.name, layers)
            if theirs is None or theirs > mine:
                found.append(f"{module} ({layers[mine] if module != root.name else root.name}) imports {dep}")
    return found


def cycles(g: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in g.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(g):
        if v not in index:
            visit(v)
    return found


def long_modules(root: Path, limit: int = MAX_MODULE_LINES) -> dict[str, int]:
    return {name: n for name, path in modules(root=root).items() if (n := len(path.read_text().splitlines())) > limit}


def long_functions(root: Path, limit: int = MAX_FUNCTION_LINES) -> dict[str, int]:
    out = {}
    for name, path in modules(root=root).items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > limit:
                    out[f"{name}.{node.name} (line {node.lineno})"] = n
    return out


def private_reexports(root: Path) -> list[str]:
    """Names a package's ``__init__`` takes from its members that are private, or that it
    neither uses nor exports in ``__all__``."""
    found = []
    for name, path in modules(root=root).items():
        if path.name != "__init__.py":
            continue
        tree = ast.parse(path.read_text())
        used = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)}
        exported = set()
        for node in tree.body:
            if isinstance(node, ast.Assign) and any(getattr(t, "id", "") == "__all__" for t in node.targets):
                exported = set(ast.literal_eval(node.value))
        for node in tree.body:
            if isinstance(node, ast.ImportFrom) and node.level:    # a re-export of a package member
                for alias in node.names:
                    bound = alias.asname or alias.name
                    if bound.startswith("_") and not bound.startswith("__"):
                        found.append(f"{name} re-exports the private name {bound}")
                    elif bound not in exported and bound not in used:
                        found.append(f"{name} imports {bound} without exporting it in __all__")
    return found


def _docstrings(tree: ast.AST) -> set[int]:
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value, str):
                found.add(id(first.value))
    return found


def vocabulary_literals(root: Path, names, *, owner: str = VOCABULARY) -> list[str]:
    """String constants equal to one of ``names`` in any module but ``owner``: docstrings and
    lines marked :data:`NOT_A_NAME` aside, code names a base, gain set or structure through
    the vocabulary's constants."""
    found = []
    for name, path in modules(root=root).items():
        if path.relative_to(root.resolve()).as_posix() == owner:
            continue
        text = path.read_text()
        lines = text.splitlines()
        tree = ast.parse(text)
        skip = _docstrings(tree)
        for node in ast.walk(tree):
            if (isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value in names
                    and id(node) not in skip and NOT_A_NAME not in lines[node.lineno - 1]):
                found.append(f"{name} line {node.lineno}: {node.value!r}")
    return sorted(found)


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def private_imports(root: Path) -> list[str]:
    """Private names (one leading underscore) a module takes from another module of the
    package: ``from .x import _name``, or ``x._name`` of a module ``x`` bound by an import.
    A module's own private names are its own business."""
    known = modules(root=root)
    found = []
    for name, path in sorted(known.items()):
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        tree = ast.parse(path.read_text())
        bound: dict[str, str] = {}       # a local name -> the package module it is bound to
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split(".")
                    stem = ".".join(base[:len(base) - (node.level - 1)] + ([node.module] if node.module else []))
                else:
                    stem = node.module or ""
                for alias in node.names:
                    if f"{stem}.{alias.name}" in known:
                        bound[alias.asname or alias.name] = f"{stem}.{alias.name}"
                    elif stem in known and stem != name and _private(alias.name):
                        found.append(f"{name} imports {alias.name} from {stem}")
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    local, module = (alias.asname, alias.name) if alias.asname else (alias.name.split(".")[0],) * 2
                    if module in known:
                        bound[local] = module
        for node in ast.walk(tree):
            if (isinstance(node, ast.Attribute) and _private(node.attr) and isinstance(node.value, ast.Name)
                    and bound.get(node.value.id, name) != name):
                found.append(f"{name} reads {node.attr} of {bound[node.value.id]}")
    return found


def _top_level_names(tree: ast.Module) -> set[str]:
    """Names a module binds at its top level (also inside a top-level ``if`` or ``try``)."""
    out: set[str] = set()
    todo = list(tree.body)
    while todo:
        node = todo.pop()
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            out.add(node.name)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            out.update((a.asname or a.name).split(".")[0] for a in node.names)
        elif isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for target in targets:
                out.update(n.id for n in ast.walk(target) if isinstance(n, ast.Name))
        elif isinstance(node, (ast.If, ast.Try)):
            todo += node.body + node.orelse + getattr(node, "finalbody", []) + \
                [s for h in getattr(node, "handlers", []) for s in h.body]
    return out


def face_problems(root: Path) -> list[str]:
    """Each package's ``__init__`` names its public interface in a literal ``__all__``, and
    every name in it exists: bound by the ``__init__``, a member module or sub-package, or
    exported on first use (``lazy_exports``) from a member module that defines it at its
    top level; a lazily exported name is listed in ``__all__``."""
    known = modules(root=root)
    found = []
    for name, path in sorted(known.items()):
        if path.name != "__init__.py":
            continue
        tree = ast.parse(path.read_text())
        listed = None
        for node in tree.body:
            if isinstance(node, ast.Assign) and any(getattr(t, "id", "") == "__all__" for t in node.targets):
                try:
                    listed = list(ast.literal_eval(node.value))
                except ValueError:
                    found.append(f"{name}: __all__ is not a literal list of names")
                    listed = []
        if listed is None:
            found.append(f"{name} has no __all__")
            continue
        own = _top_level_names(tree)
        lazy = lazy_face(tree)
        exported = {n for names in lazy.values() for n in names}
        for member, names in lazy.items():
            module = f"{name}.{member}"
            if module not in known:
                found.append(f"{name} exports {', '.join(names)} from {module}, which does not exist")
                continue
            defined = _top_level_names(ast.parse(known[module].read_text()))
            found += [f"{name} exports {n} from {module}, which does not define it" for n in names
                      if n not in defined]
        found += [f"{name}.__all__ names {n}, which does not exist" for n in listed
                  if n not in own and n not in exported and f"{name}.{n}" not in known]
        found += [f"{name} exports {n} on first use without listing it in __all__" for n in sorted(exported)
                  if n not in listed]
    return found


# ---------------------------------------------------------------------------------------
# the campaign package
# ---------------------------------------------------------------------------------------
def test_every_package_of_campaign_is_a_declared_layer():
    packages = {p.name for p in PACKAGE.iterdir() if (p / "__init__.py").is_file()}
    assert packages == set(LAYERS)


def test_imports_flow_one_way_through_the_layers():
    assert upward_imports(PACKAGE, LAYERS) == []


def test_no_import_cycle_among_campaign_modules():
    found = cycles({k: set(v) for k, v in graph().items()})
    assert found == [], "modules that import each other in a circle: " + "; ".join(" <-> ".join(c) for c in found)


def test_no_module_over_600_lines():
    assert long_modules(PACKAGE) == {}


def test_no_function_over_100_lines():
    assert long_functions(PACKAGE) == {}


def test_no_package_re_exports_a_private_name():
    assert private_reexports(PACKAGE) == []


def test_no_base_gain_or_structure_name_is_spelled_outside_the_vocabulary():
    assert vocabulary_literals(PACKAGE, NAMES) == []


def workflow_literals(root: Path, names) -> list[str]:
    """Quoted base, gain or structure names in the workflow's rule files, Snakefile and
    scripts (read as text: a rule file is not Python), comment lines aside."""
    alternatives = "|".join(sorted(map(re.escape, names)))
    quoted = re.compile(rf"[\"']({alternatives})[\"']")
    found = []
    files = [root / "Snakefile", *sorted((root / "workflow").rglob("*.smk")),
             *sorted((root / "workflow").rglob("*.py"))]
    for path in (f for f in files if f.is_file()):
        for number, line in enumerate(path.read_text().splitlines(), 1):
            if not line.lstrip().startswith("#") and (hit := quoted.search(line)):
                found.append(f"{path.relative_to(root).as_posix()} line {number}: {hit.group(0)}")
    return found


def test_no_base_gain_or_structure_name_is_spelled_in_the_workflow():
    assert workflow_literals(PACKAGE.parent, NAMES) == []


def test_a_workflow_literal_is_found(tmp_path):
    (tmp_path / "workflow" / "rules").mkdir(parents=True)
    (tmp_path / "Snakefile").write_text('include: "workflow/rules/a.smk"\n')
    (tmp_path / "workflow" / "rules" / "a.smk").write_text(
        '# the "high" gains\nrule a:\n    params: gain="high", base=vocabulary.FIXED\n')
    assert workflow_literals(tmp_path, {"high", "fixed"}) == ["workflow/rules/a.smk line 3: \"high\""]


def test_no_module_takes_a_private_name_from_another():
    assert private_imports(PACKAGE) == []


def test_every_package_names_its_public_interface_and_every_name_exists():
    assert face_problems(PACKAGE) == []


def test_the_graph_sees_relative_imports_at_every_level_and_imports_inside_functions():
    g = graph()
    assert {"campaign.identify", "campaign.identify.trial", "campaign.archive", "campaign.rig.integrate"} <= set(g)
    assert "campaign.identify.options" in g["campaign.identify.trial"]
    assert "campaign.core.errors" in g["campaign.identify.trial"]
    # the workflow's configuration check imports the scene inside a function (start-up cost)
    assert "campaign.scene.description" in g["campaign.pipeline.config"]


def test_closure_follows_imports_and_package_inits():
    """A stage's digest covers what its entry module runs: the simulation job checks the stroke
    with the planner's predictions, which use eq 7-14's module."""
    files = {p.relative_to(PACKAGE).as_posix() for p in closure([PACKAGE / "pipeline" / "sweep.py"])}
    assert {"pipeline/sweep.py", "pipeline/__init__.py", "__init__.py", "rig/trial.py", "rig/__init__.py",
            "plan/stroke.py", "plan/prediction.py", "model/exiit.py", "core/errors.py"} <= files
    assert "report/figures/fig5.py" not in files


def test_closure_of_a_module_that_imports_nothing_of_the_package_is_itself_and_its_package_inits():
    """core's face imports only the lazy-export helper; the names it exports on first use are
    not run on import, so they are not part of the closure."""
    assert closure([PACKAGE / "core" / "errors.py"]) == [PACKAGE / "__init__.py", PACKAGE / "core" / "__init__.py",
                                                        PACKAGE / "core" / "errors.py", PACKAGE / "core" / "lazy.py"]


def test_a_name_from_a_lazy_face_depends_on_the_module_that_defines_it(tmp_path):
    root = _package(tmp_path, {
        "low/__init__.py": "from .lazy import lazy_exports\n__all__ = ['f', 'g']\n"
                           "__getattr__, __dir__ = lazy_exports(__name__, {'a': ('f',), 'b': ('g',)})\n",
        "low/lazy.py": "def lazy_exports(p, e):\n    return None, None\n",
        "low/a.py": "def f():\n    pass\n", "low/b.py": "def g():\n    pass\n",
        "high/c.py": "from ..low import f\n"})
    g = graph(root=root)
    assert g["pkg.high.c"] == {"pkg.low", "pkg.low.a"}
    assert g["pkg.low"] == {"pkg.low.lazy"}


# ---------------------------------------------------------------------------------------
# each rule finds a planted violation
# ---------------------------------------------------------------------------------------
def _package(tmp_path: Path, files: dict[str, str]) -> Path:
    root = tmp_path / "pkg"
    for rel, text in {"__init__.py": "", "low/__init__.py": "", "high/__init__.py": "", **files}.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(text))
    return root


def test_an_import_up_the_layers_is_found(tmp_path):
    root = _package(tmp_path, {"low/a.py": "def f():\n    from ..high import b\n", "high/b.py": "from ..low import a\n"})
    assert upward_imports(root, ("low", "high")) == ["pkg.low.a (low) imports pkg.high", "pkg.low.a (low) imports pkg.high.b"]
    assert upward_imports(root, ("high", "low")) == ["pkg.high.b (high) imports pkg.low", "pkg.high.b (high) imports pkg.low.a"]


def test_a_module_outside_the_layers_is_found(tmp_path):
    root = _package(tmp_path, {"loose.py": ""})
    assert upward_imports(root, ("low", "high")) == ["pkg.loose belongs to no layer"]


def test_a_circle_is_found(tmp_path):
    root = _package(tmp_path, {"low/a.py": "from . import b\n", "low/b.py": "from . import c\n",
                               "low/c.py": "from . import a\n", "low/d.py": "from . import a\n"})
    assert cycles({k: set(v) for k, v in graph(root=root).items()}) == [["pkg.low.a", "pkg.low.b", "pkg.low.c"]]
    assert cycles({"a": {"b"}, "b": {"c"}, "c": set()}) == []


def test_a_long_module_is_found(tmp_path):
    root = _package(tmp_path, {"low/long.py": "x = 1\n" * (MAX_MODULE_LINES + 1), "low/short.py": "x = 1\n" * 600})
    assert long_modules(root) == {"pkg.low.long": MAX_MODULE_LINES + 1}


def test_a_long_function_is_found(tmp_path):
    body = "    x = 1\n" * MAX_FUNCTION_LINES
    root = _package(tmp_path, {"low/f.py": f"def long():\n{body}\n\ndef short():\n{body[:-10]}\n"})
    assert long_functions(root) == {"pkg.low.f.long (line 1)": MAX_FUNCTION_LINES + 1}


def test_a_private_re_export_is_found(tmp_path):
    root = _package(tmp_path, {"low/__init__.py": "from .a import _hidden, shown, extra, used\n__all__ = ['shown']\n"
                                                  "y = used\n",
                               "low/a.py": "_hidden = shown = extra = used = 1\n"})
    assert private_reexports(root) == ["pkg.low re-exports the private name _hidden",
                                       "pkg.low imports extra without exporting it in __all__"]


def test_a_vocabulary_literal_is_found(tmp_path):
    root = _package(tmp_path, {
        "low/names.py": 'FIXED = "fixed"\n',
        "low/a.py": 'def f(base="fixed"):\n    """Only the fixed base."""\n    return {"high": 1, "fixed base": 2}\n',
        "high/b.py": 'from ..low.names import FIXED\nWORD = "zero"  # not a vocabulary name\nX = [FIXED, f"{FIXED}"]\n'})
    assert vocabulary_literals(root, {"fixed", "zero", "high"}, owner="low/names.py") == [
        "pkg.low.a line 1: 'fixed'", "pkg.low.a line 3: 'high'"]
    assert vocabulary_literals(root, {"fixed"}, owner="low/a.py") == ["pkg.low.names line 1: 'fixed'"]


def test_a_private_import_from_another_module_is_found(tmp_path):
    root = _package(tmp_path, {"low/a.py": "_hidden = _other = shown = 1\n",
                               "low/b.py": "from .a import _hidden, shown\nfrom . import a\nx = a._other\n",
                               "low/c.py": "from .. import low\nfrom ..low import a as mod\n_mine = 1\n"
                                           "y = _mine + mod.shown + low._secret\n"})
    assert private_imports(root) == ["pkg.low.b imports _hidden from pkg.low.a", "pkg.low.b reads _other of pkg.low.a",
                                     "pkg.low.c reads _secret of pkg.low"]


def test_a_package_without_a_face_or_with_a_missing_name_is_found(tmp_path):
    root = _package(tmp_path, {
        "low/__init__.py": "x = 1\n",
        "high/__init__.py": "from ..core import lazy_exports\nfrom .sub import g\n\ndef f():\n    pass\n\n"
                            "__all__ = ['f', 'g', 'sub', 'lazy_x', 'ghost']\n"
                            "__getattr__, __dir__ = lazy_exports(__name__, {'m': ('lazy_x', 'lazy_missing'), "
                            "'gone': ('y',)})\n",
        "high/sub.py": "g = 1\n", "high/m.py": "lazy_x = 1\n"})
    assert sorted(face_problems(root)) == sorted([
        "pkg has no __all__", "pkg.low has no __all__",
        "pkg.high exports lazy_missing from pkg.high.m, which does not define it",
        "pkg.high exports y from pkg.high.gone, which does not exist",
        "pkg.high.__all__ names ghost, which does not exist",
        "pkg.high exports lazy_missing on first use without listing it in __all__",
        "pkg.high exports y on first use without listing it in __all__",
    ])


@pytest.mark.parametrize("module", ["campaign.core.vocabulary", "campaign.core.yamlfile", "campaign.pipeline.paths",
                                    "campaign.pipeline.config", "campaign.pipeline.digests",
                                    "campaign.pipeline.campaign_plan", "campaign.pipeline.plan_parts"])
def test_what_the_workflow_imports_at_start_up_stays_light(module):
    """The workflow's wiring imports these on every start (a dry run included): at their top
    they import only the standard library, PyYAML and each other (with the robots' conventions,
    the file checks of campaign.core.files and the studies' file names, which import nothing
    heavier)."""
    tree = ast.parse(modules()[module].read_text())
    heavy = []
    for node in tree.body:
        if isinstance(node, ast.Import):
            heavy += [a.name for a in node.names if a.name.split(".")[0] in ("numpy", "pinocchio", "scipy", "xarray")]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            if node.module.split(".")[0] in ("numpy", "pinocchio", "scipy", "xarray", "h5py", "matplotlib"):
                heavy.append(node.module)
        elif isinstance(node, ast.ImportFrom) and node.level:
            target = (node.module or "").split(".")[0]
            light = ("", "errors", "files", "vocabulary", "yamlfile", "core", "config", "digests", "paths", "plan_parts",
                     "model.conventions")
            if target not in light and any(f"{node.module}.{a.name}" not in light for a in node.names):
                heavy.append("." * node.level + (node.module or ""))
    assert heavy == []
