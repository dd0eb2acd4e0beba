"""The package's layout: no import cycle among campaign's modules, no module over 800 lines.

Read with the standard library's ``ast`` (nothing is imported). Every import counts, also
those inside functions: a lazy import defers the cost, not the dependency.
"""

from __future__ import annotations

from campaign.imports import PACKAGE, closure, graph, modules

MAX_LINES = 800


def _graph() -> dict[str, set[str]]:
    return {name: set(deps) for name, deps in graph().items()}


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
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
        for w in graph[v]:
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

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_the_graph_sees_the_package_and_its_imports():
    """The checker reads what it should: the split packages, relative imports at every
    level, and an import inside a function (runner imports identify lazily)."""
    graph = _graph()
    assert {"campaign.identify", "campaign.identify.trial", "campaign.archive", "campaign.bench",
            "campaign.rig.integrate"} <= set(graph)
    assert "campaign.identify.options" in graph["campaign.identify.trial"]
    assert "campaign.identify" in graph["campaign.runner"]
    assert "campaign.errors" in graph["campaign.identify.trial"]


def test_cycle_finder_finds_a_circle_through_three_modules():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": set()}) == []


def test_no_import_cycle_among_campaign_modules():
    cycles = _cycles(_graph())
    assert cycles == [], "modules that import each other in a circle: " + "; ".join(" <-> ".join(c) for c in cycles)


def test_no_module_over_800_lines():
    long = {name: n for name, path in modules().items() if (n := len(path.read_text().splitlines())) > MAX_LINES}
    assert long == {}, f"modules over {MAX_LINES} lines: {long}"


def test_closure_follows_lazy_imports_and_package_inits():
    """A stage's digest covers what its entry module runs: the simulation's stroke check
    imports the planner inside a function, and the planner imports eq 7-14's module."""
    files = {p.relative_to(PACKAGE).as_posix() for p in closure([PACKAGE / "rig" / "simulate.py"])}
    assert {"rig/simulate.py", "rig/__init__.py", "__init__.py", "plan.py", "exiit.py", "errors.py"} <= files
    assert "figures/fig5.py" not in files


def test_closure_of_a_module_that_imports_nothing_of_the_package_is_itself():
    assert closure([PACKAGE / "errors.py"]) == [PACKAGE / "__init__.py", PACKAGE / "errors.py"]
