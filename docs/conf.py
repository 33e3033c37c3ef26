"""Sphinx configuration of the fe-mpm documentation site (`./run docs`).

Sources: the Markdown pages in docs/ (MyST), README.md as the front page, the
docstrings of fe_mpm (autodoc with napoleon: Google style, as ruff enforces), and the
demos, which are jupytext "light" scripts. Two folders are generated here at every
build and are git-ignored:

- docs/demos/: one Markdown page per demos/*.py, converted by jupytext and never run;
- docs/api/: one page per fe_mpm module that is not on the hand-written api.md.

Links are written for GitHub, relative to the file that holds them (a page links
``../demos/strip_footing.py``, the README ``docs/limitations.md``); ``_site_links``
points them at the site's pages when the pages are read.
"""

import importlib
import os
import pkgutil
import re
import types
from pathlib import Path

import jupytext

import fe_mpm

DOCS = Path(__file__).resolve().parent
REPO = DOCS.parent

project = "fe-mpm"
author = "the fe-mpm developers"
copyright = "fe-mpm developers, MIT licence"
release = fe_mpm.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.viewcode",
]
source_suffix = {".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build"]

# Pages are Markdown that GitHub renders as well: GitHub's anchors for their headings.
myst_heading_anchors = 3
myst_heading_slug_func = "github"

autodoc_member_order = "bysource"
autodoc_typehints = "description"
napoleon_google_docstring = True
napoleon_numpy_docstring = False

html_theme = "furo"
html_title = f"fe-mpm {release}"
html_static_path: list[str] = []


def _write_if_changed(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` unless it already holds it (keeps the build incremental)."""
    if not path.exists() or path.read_text() != text:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


def _sync_folder(folder: Path, pages: dict[str, str]) -> None:
    """Make ``folder`` hold exactly ``pages`` (file name -> text), removing stale pages."""
    folder.mkdir(exist_ok=True)
    for stale in set(p.name for p in folder.glob("*.md")) - set(pages):
        (folder / stale).unlink()
    for name, text in pages.items():
        _write_if_changed(folder / name, text)


# --- The demos as pages --------------------------------------------------------------


def _demo_page(script: Path) -> str:
    """The Markdown page of one demo script, converted by jupytext (not run)."""
    nb = jupytext.read(script, fmt="py:light")
    nb.metadata = {"jupytext": {"notebook_metadata_filter": "-all", "cell_metadata_filter": "-all"}}
    text = jupytext.writes(nb, fmt="md")
    note = (
        f"*This page is the script `demos/{script.name}`, converted by jupytext and "
        f"not run here: run it with "
        f"`./run python demos/{script.name}` (`--help` lists its options).*\n"
    )
    lines = text.splitlines(keepends=True)
    title = next((i for i, s in enumerate(lines) if s.startswith("# ")), None)
    if title is None:  # a script without a title: name the page after it
        lines[:0] = [f"# `demos/{script.name}`\n", "\n"]
        title = 0
    lines[title + 1 : title + 1] = ["\n", note]
    return "".join(lines)


DEMOS = sorted((REPO / "demos").glob("*.py"))
_sync_folder(DOCS / "demos", {f"{p.stem}.md": _demo_page(p) for p in DEMOS})

# --- The module reference --------------------------------------------------------------

# Documented on api.md; every other module gets a page of its own in docs/api/, less
# the objects these public modules re-export (each object is documented once).
PUBLIC_MODULES = ["fe_mpm", "fe_mpm.materials", "fe_mpm.meshes", "fe_mpm.scenes"]


def _public_names() -> set[tuple[str, int]]:
    """(name, id) of every object the public modules export."""
    exported = set()
    for name in PUBLIC_MODULES:
        module = importlib.import_module(name)
        names = getattr(module, "__all__", None)
        if names is None:
            names = [
                n
                for n, v in vars(module).items()
                if not n.startswith("_") and getattr(v, "__module__", None) == name
            ]
        exported.update((n, id(getattr(module, n))) for n in names)
    return exported


def _module_pages() -> dict[str, str]:
    """A page for every module of fe_mpm but the public and the private ones."""
    exported = _public_names()
    pages = {}
    for info in pkgutil.walk_packages(fe_mpm.__path__, "fe_mpm."):
        name = info.name
        if name in PUBLIC_MODULES or any(part.startswith("_") for part in name.split(".")):
            continue
        module = importlib.import_module(name)
        package, _, short = name.rpartition(".")
        options = "   :members:\n"
        if isinstance(getattr(importlib.import_module(package), short, None), types.FunctionType):
            # A module named as the function its package exports (fe_mpm.meshes.column):
            # the function keeps the name in the index.
            options += "   :no-index:\n"
        shown = sorted(n for n, v in vars(module).items() if (n, id(v)) in exported)
        if shown:
            options += f"   :exclude-members: {', '.join(shown)}\n"
        pages[f"{name}.md"] = (
            f"# `{name}`\n\n```{{eval-rst}}\n.. automodule:: {name}\n{options}```\n"
        )
    return pages


_sync_folder(DOCS / "api", _module_pages())

# --- Links written for GitHub, pointed at the site -------------------------------------

_LINK = re.compile(r"(\]\()([^)\s#]*)(#[^)\s]*)?(\))")


def _site_target(path: Path) -> Path | None:
    """The source in docs/ that a link to ``path`` (a file of the repository) shows."""
    if path == REPO / "README.md":
        return DOCS / "index.md"
    if path.parent == REPO / "demos" and path.suffix == ".py" and path in DEMOS:
        return DOCS / "demos" / f"{path.stem}.md"
    if DOCS in path.parents:
        return path
    return None


def _site_links(text: str, written_in: Path, shown_in: Path) -> str:
    """Point the relative links of ``text`` (written in folder ``written_in``) at the site.

    ``shown_in`` is the folder of the page that shows the text: the same folder, but for
    a file included in another page (the README in index.md).
    """

    def relink(m: re.Match) -> str:
        target = m.group(2)
        if not target or re.match(r"[a-zA-Z][a-zA-Z0-9+.-]*:", target):
            return m.group(0)  # an anchor on the same page, or a URL
        site = _site_target((written_in / target).resolve())
        if site is None:
            return m.group(0)
        return f"{m.group(1)}{os.path.relpath(site, shown_in)}{m.group(3) or ''}{m.group(4)}"

    return _LINK.sub(relink, text)


def _on_source_read(app, docname: str, source: list[str]) -> None:
    folder = (Path(app.srcdir) / docname).parent
    source[0] = _site_links(source[0], folder, folder)


def _on_include_read(app, relative_path, parent_docname, content: list[str]) -> None:
    written_in = (Path(app.srcdir) / relative_path).resolve().parent
    shown_in = (Path(app.srcdir) / app.env.docname).parent
    content[0] = _site_links(content[0], written_in, shown_in)


def setup(app):
    """Register the link rewriting for pages and for included files."""
    app.connect("source-read", _on_source_read)
    app.connect("include-read", _on_include_read)
