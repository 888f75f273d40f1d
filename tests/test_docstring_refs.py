"""Every relative cross-reference in the families' docstrings (``:mod:`.x```, ``:func:`..x.y```, ...) names a
module that exists from where it is written, and a name that module defines: statically (ast, no import), so
that a module moved to another folder cannot keep pointing at its old neighbours."""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FAMILIES = ROOT / "fitlab" / "families"
REF = re.compile(r":(?:func|mod|data|class|attr|meth):`(\.+[A-Za-z_][\w.]*)`")


def _module_file(parts: list[str]) -> Path | None:
    base = ROOT.joinpath(*parts)
    for p in (base.with_suffix(".py"), base / "__init__.py"):
        if p.is_file():
            return p
    return None


def _names(path: Path) -> set[str]:
    """What a module defines or imports at its top level (functions, classes, assignments, imports)."""
    names: set[str] = set()
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            names |= {n.id for t in targets for n in ast.walk(t) if isinstance(n, ast.Name)}
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names |= {(a.asname or a.name).split(".")[0] for a in node.names}
    return names


def _resolves(path: Path, ref: str) -> bool:
    package = list(path.relative_to(ROOT).with_suffix("").parts)
    package = package[:-1]  # a module's references start from its package, as an __init__'s do
    dots = len(ref) - len(ref.lstrip("."))
    base = package[: len(package) - (dots - 1)] if dots > 1 else package
    parts = base + ref.lstrip(".").split(".")
    for k in range(len(parts), len(base), -1):
        module = _module_file(parts[:k])
        if module is not None:
            rest = parts[k:]
            return not rest or rest[0] in _names(module) or _module_file(parts[: k + 1]) is not None
    return False


def test_every_relative_reference_in_the_families_resolves():
    bad = [f"{p.relative_to(ROOT)}: {m.group(1)}" for p in sorted(FAMILIES.rglob("*.py"))
           for m in REF.finditer(p.read_text()) if not _resolves(p, m.group(1))]
    assert not bad, "references that name nothing: " + "; ".join(bad)
