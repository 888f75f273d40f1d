"""MkDocs hooks of the site (mkdocs.yml): pages' figures rendered from the outputs, and the notebooks run once.

* ``{{ name(args) }}`` in a page is replaced by what :mod:`figures` function ``name`` renders from the committed
  outputs (the report's CSV, the audit's JSON, the fit files, the schema, the command's parsers); the arguments
  are Python literals, read by :func:`ast.literal_eval`.  An unknown name, bad arguments or a row the outputs do
  not hold fail the build.
* A mention of a page by its path, ``docs/NAME.md``, becomes a link to it (:func:`link_mentions`).
* The notebooks of notebooks/ become pages with their outputs: each is taken from ``$FITLAB_EXECUTED_NOTEBOOKS``
  where an executed copy of the same cells is there (tests/test_notebooks.py leaves them so: the suite runs each
  notebook once), else run here by ``notebooks/_build.py``'s :func:`execute`, which also checks the claims of its
  text; ``FITLAB_NOTEBOOK_SMALL=0`` runs them on full grids.
"""

from __future__ import annotations

import ast
import importlib.util
import os
import posixpath
import re
import sys
import tempfile
from pathlib import Path

from mkdocs.exceptions import PluginError
from mkdocs.plugins import event_priority
from mkdocs.structure.files import File

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(HERE))

import figures  # noqa: E402

MACRO = re.compile(r"\{\{\s*(?P<name>\w+)\((?P<args>[^{}]*)\)\s*\}\}")
#: the figures a page may ask for
MACROS = {
    name: getattr(figures, name)
    for name in ("use_table", "report_table", "report_value", "audit_table", "audit_value", "fits_table", "fit_schema",
                 "cli_help")
}  # fmt: skip


def expand(markdown: str, where: str = "page") -> str:
    """``markdown`` with every ``{{ name(args) }}`` replaced by its rendering."""

    def one(match: re.Match) -> str:
        name = match["name"]
        if name not in MACROS:
            raise PluginError(f"{where}: unknown figure {name!r} (known: {', '.join(MACROS)})")
        try:
            args = ast.literal_eval(f"({match['args']},)") if match["args"].strip() else ()
            return MACROS[name](*args)
        except (ValueError, SyntaxError, TypeError, figures.FigureError) as exc:
            raise PluginError(f"{where}: {match[0]}: {exc}") from exc

    return MACRO.sub(one, markdown)


MENTION = re.compile(r"(?<![\w/.\[(])docs/((?:[\w-]+/)*[\w-]+\.md)\b(?![\w\])])")


def link_mentions(markdown: str, page_uri: str, pages: set[str]) -> str:
    """Every mention of a page as ``docs/NAME.md`` (in text, or as a code span of its own) made a link to that page,
    outside code blocks: the pages name each other by path, which reads on GitHub and in a terminal alike."""
    base = posixpath.dirname(page_uri)

    def link(target: str, shown: str) -> str:
        return f"[{shown}]({posixpath.relpath(target, base or '.')})" if target in pages else shown

    out, fenced = [], False
    for line in markdown.splitlines(keepends=True):
        if line.lstrip().startswith(("```", "~~~")):
            fenced = not fenced
        if fenced or line.lstrip().startswith(("```", "~~~")) or "docs/" not in line:
            out.append(line)
            continue
        parts = re.split(r"(`[^`]*`)", line)
        for i, part in enumerate(parts):
            if part.startswith("`"):
                whole = re.fullmatch(r"`docs/((?:[\w-]+/)*[\w-]+\.md)`", part)
                parts[i] = link(whole[1], part) if whole else part
            else:
                parts[i] = MENTION.sub(lambda m: link(m[1], m[0]), part)
        out.append("".join(parts))
    return "".join(out)


def on_page_markdown(markdown: str, page, config, files) -> str:
    pages = {f.src_uri for f in files if f.src_uri.endswith(".md")}
    return link_mentions(expand(markdown, page.file.src_uri), page.file.src_uri, pages)


# -- notebooks ---------------------------------------------------------------------------------------------------
def _build_module():
    spec = importlib.util.spec_from_file_location("notebooks_build", ROOT / "notebooks" / "_build.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


_RUN: dict = {}  # notebook name -> the notebook this process executed (mkdocs serve builds again and again)


def executed_notebooks(names: list[str], out: Path) -> None:
    """Write into ``out`` an executed copy of each notebooks/NAME whose cells are the committed ones."""
    import shutil

    import nbformat

    build = _build_module()
    given = os.environ.get("FITLAB_EXECUTED_NOTEBOOKS")
    small = os.environ.get("FITLAB_NOTEBOOK_SMALL", "1") == "1"
    for name in names:
        committed = nbformat.read(ROOT / "notebooks" / name, as_version=4)
        candidate = Path(given) / name if given else None
        if candidate is not None and candidate.is_file():
            executed = nbformat.read(candidate, as_version=4)
            if build.same_cells(executed, committed):
                shutil.copyfile(candidate, out / name)
                continue
        if name not in _RUN or not build.same_cells(_RUN[name], committed):
            _RUN[name], _ = build.execute(ROOT / "notebooks" / name, small=small)
        nbformat.write(_RUN[name], out / name)


_FOLDERS: list[Path] = []  # the notebooks' folders of this build, removed when it ends


@event_priority(100)  # before mkdocs-jupyter's on_files, which turns .ipynb files into pages
def on_files(files, config):
    names = sorted(p.name for p in (ROOT / "notebooks").glob("*.ipynb"))
    root = Path(tempfile.mkdtemp(prefix="fitlab-site-notebooks-"))
    _FOLDERS.append(root)
    (root / "notebooks").mkdir()
    executed_notebooks(names, root / "notebooks")
    for name in names:  # a file of a second source folder: mkdocs-jupyter reads it from src_dir/notebooks/NAME
        files.append(
            File(
                f"notebooks/{name}",
                src_dir=str(root),
                dest_dir=config["site_dir"],
                use_directory_urls=config["use_directory_urls"],
            )
        )
    return files


def on_post_build(config):
    import shutil

    while _FOLDERS:
        shutil.rmtree(_FOLDERS.pop(), ignore_errors=True)
