"""Sphinx configuration of the campaign's user guide (``make docs`` builds it into docs/_build)."""

from __future__ import annotations

import os
import sys

# The guide documents the package of this checkout, also when it is not installed.
sys.path.insert(0, os.path.abspath(".."))

import campaign  # noqa: E402


def _write_api_pages(out: str) -> None:
    """One ``automodule`` page per public module of the package (a leading underscore in
    any part of the name is private); a file is rewritten only when its text changes."""
    import pkgutil

    names = ["campaign"] + [m.name for m in pkgutil.walk_packages(campaign.__path__, "campaign.")]
    names = [n for n in names if not any(part.startswith("_") for part in n.split("."))]
    os.makedirs(out, exist_ok=True)
    for name in names:
        text = f"{name}\n{'=' * len(name)}\n\n.. automodule:: {name}\n"
        path = os.path.join(out, f"{name}.rst")
        if not os.path.exists(path) or open(path, encoding="utf-8").read() != text:
            with open(path, "w", encoding="utf-8") as f:
                f.write(text)
    for stale in set(os.listdir(out)) - {f"{n}.rst" for n in names}:
        os.remove(os.path.join(out, stale))


_write_api_pages(os.path.join(os.path.dirname(os.path.abspath(__file__)), "generated"))

project = "campaign"
author = "The campaign developers"
copyright = "the campaign developers"
version = release = campaign.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
]
# Equations are written as plain-text literal blocks, in the names the code uses, so the
# guide reads the same offline (no MathJax from a CDN) and in the docstrings.
highlight_language = "none"
exclude_patterns = ["_build"]
root_doc = "index"

# API reference: one page per public module, written below into docs/generated/ (not
# committed) and filled by autodoc from the docstrings; numpydoc sections through napoleon.
# The pages are written here rather than by autosummary's generator because that resolves a
# module that shares its name with a function its package re-exports to the function.
autosummary_generate = False
autodoc_default_options = {"members": True, "show-inheritance": True}
autodoc_member_order = "bysource"
# Signatures without annotations: the numpydoc "Parameters" sections state each type in
# words (units, shapes), and annotations of third-party types (numpy, Pinocchio, xarray)
# have no inventory to resolve against offline.
autodoc_typehints = "none"
napoleon_google_docstring = False
napoleon_numpy_docstring = True
napoleon_use_param = False
napoleon_use_rtype = False
# "Attributes" as attribute entries: they keep "start, end : float" as one entry
napoleon_use_ivar = False

# Every cross-reference to the package's public names must resolve (-n); names of other
# projects have no inventory offline, so references outside ``campaign`` are not checked.
nitpicky = True
# Private names (a leading underscore) have no page either, e.g. a private base class.
nitpick_ignore_regex = [(r"py:.*", r"(?!campaign\b).*"), (r"py:.*", r".*\._[^.]*")]

html_theme = "alabaster"
html_title = f"campaign {release}"
html_theme_options = {
    "description": "Impact dynamics of long-reach manipulators on a simulated VES-II",
    "fixed_sidebar": True,
    "page_width": "1100px",
    "sidebar_width": "240px",
}
html_static_path = ["_static"]
html_css_files = ["guide.css"]
html_show_sourcelink = False



# The module autodoc is documenting now: its docstring is processed before its members are
# filtered, so the skip hook below knows which page a member would land on.
_current_module: list[str] = [""]


def _note_module(app, what, name, obj, options, lines):
    if what == "module":
        _current_module[0] = name


def _skip_member(app, what, name, obj, skip, options):
    """Keep four kinds of members out of the API reference: the lazily imported third-party
    modules (``xr = LazyModule("xarray")``), a NamedTuple's generated field aliases, a
    package's re-export of a function that has the name of the submodule defining it
    (function and module would be one target twice; the function stays on its module's
    page), and a package's re-export of another package's name (it is documented on that
    package's page)."""
    from campaign.core.lazy import LazyModule

    if isinstance(obj, LazyModule):
        return True
    # a NamedTuple's fields: their "Attributes" section already documents them
    if what == "class" and (getattr(obj, "__doc__", None) or "").startswith("Alias for field number"):
        return True
    here = _current_module[0]
    defined_in = getattr(obj, "__module__", None)
    if what == "module" and defined_in == f"{here}.{name}":
        return True
    if (what == "module" and isinstance(defined_in, str) and defined_in.startswith("campaign.")
            and defined_in != here and not defined_in.startswith(f"{here}.")):
        return True
    return skip


def _python_domain():
    """The Python domain with one rule more: a bare name (a numpydoc ``Raises`` entry such as
    ``InputError``) that names both a package's public name and the module entry it comes
    from (``campaign.core.InputError``, ``campaign.core.errors.InputError``) refers to the
    module's, where the object is defined."""
    from sphinx.domains.python import PythonDomain

    class CampaignPythonDomain(PythonDomain):
        def find_obj(self, env, modname, classname, name, type, searchmode=0):
            matches = super().find_obj(env, modname, classname, name, type, searchmode)
            if len(matches) > 1:
                full = [m[0] for m in matches]

                def re_export(target: str) -> bool:
                    package, _, tail = target.rpartition(".")
                    return any(o != target and o.startswith(f"{package}.") and o.endswith(f".{tail}") for o in full)

                matches = [m for m in matches if not re_export(m[0])] or matches
            return matches

    return CampaignPythonDomain


def setup(app):
    app.connect("autodoc-process-docstring", _note_module)
    app.connect("autodoc-skip-member", _skip_member)
    app.add_domain(_python_domain(), override=True)
