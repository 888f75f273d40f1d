"""docs/architecture.md against the code, statically (ast, no fitlab import): the paths and dotted names it
gives exist, it names every capability and every service protocol with every member, every module that reads or writes files is in
its I/O section, and the import direction it draws holds (families on top, reached only by discovery)."""

from __future__ import annotations

import ast
import re
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOC = (ROOT / "docs" / "architecture.md").read_text()
PLACEHOLDERS = ("my_family", "<name>", "*")


def _sources() -> list[Path]:
    return sorted(p for p in (ROOT / "fitlab").rglob("*.py") if "generated" not in p.parts)


@cache
def _tree(path: Path) -> ast.Module:
    return ast.parse(path.read_text(), str(path))


def _module_file(dotted: str) -> Path | None:
    base = ROOT / Path(*dotted.split("."))
    for p in (base.with_suffix(".py"), base / "__init__.py"):
        if p.is_file():
            return p
    return None


def _top_level_names(path: Path) -> set[str]:
    names: set[str] = set()
    for node in _tree(path).body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            for t in node.targets if isinstance(node, ast.Assign) else [node.target]:
                names.update(n.id for n in ast.walk(t) if isinstance(n, ast.Name))
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names.update((a.asname or a.name).split(".")[0] for a in node.names)
        elif isinstance(node, ast.If) and ast.unparse(node.test) == "TYPE_CHECKING":
            # a package that imports its names on first use (fitlab.codegen) states them for type checkers
            names.update((a.asname or a.name).split(".")[0] for n in node.body
                         if isinstance(n, (ast.Import, ast.ImportFrom)) for a in n.names)  # fmt: skip
    if path.name == "__init__.py":  # submodules
        names.update(p.stem for p in path.parent.glob("*.py"))
        names.update(p.name for p in path.parent.iterdir() if (p / "__init__.py").is_file())
    return names


def _section(title: str) -> str:
    m = re.search(rf"^## {re.escape(title)}\n(.*?)(?=^## |\Z)", DOC, re.S | re.M)
    assert m, f"docs/architecture.md has no section {title!r}"
    return m.group(1)


def test_every_path_the_doc_names_exists():
    paths = set(re.findall(r"(?<![\w/.])((?:fitlab|tests|docs)/[\w./*<>-]*\w/?)", DOC))
    checked = [p for p in paths if not any(x in p for x in PLACEHOLDERS)]
    assert len(checked) > 30
    missing = sorted(p for p in checked if not (ROOT / p).exists())
    assert not missing, f"docs/architecture.md names paths that do not exist: {missing}"
    for path, test in re.findall(r"(tests/\w+\.py)::(\w+)", DOC):
        assert f"def {test}(" in (ROOT / path).read_text(), f"{path} has no {test}"


def test_every_dotted_name_the_doc_gives_exists():
    names = set(re.findall(r"\bfitlab(?:\.\w+)+", DOC))
    names = {n for n in names if not any(x in n for x in ("my_family",))}
    assert len(names) > 40
    wrong = []
    for name in sorted(names):
        parts = name.split(".")
        for k in range(len(parts), 0, -1):  # the longest prefix that is a module
            path = _module_file(".".join(parts[:k]))
            if path is not None:
                break
        if path is None:
            wrong.append(f"{name}: no module")
        elif k < len(parts) and parts[k] not in _top_level_names(path):
            wrong.append(f"{name}: {'.'.join(parts[:k])} defines no {parts[k]}")
    assert not wrong, "docs/architecture.md: " + "; ".join(wrong)


def _protocols(path: Path) -> dict[str, list[str]]:
    """name -> members (annotated attributes and methods) of every Protocol class in ``path``."""
    out = {}
    for node in _tree(path).body:
        if isinstance(node, ast.ClassDef) and any("Protocol" in ast.unparse(b) for b in node.bases):
            out[node.name] = [s.target.id for s in node.body if isinstance(s, ast.AnnAssign)] + [
                s.name for s in node.body if isinstance(s, ast.FunctionDef) and not s.name.startswith("_")
            ]
    return out


#: the modules that declare the family contract: capabilities and their services' protocols
CONTRACT = ["fitlab/core/_family.py", "fitlab/core/_capabilities.py", "fitlab/scenes/_protocol.py",
            "fitlab/codegen/program.py", "fitlab/discover/library.py", "fitlab/report/methods.py"]  # fmt: skip


@pytest.mark.parametrize("module", ["fitlab/core/_capabilities.py", "fitlab/scenes/_protocol.py",
                                    "fitlab/report/methods.py"])  # fmt: skip
def test_every_service_protocol_and_member_is_named(module):
    protocols = _protocols(ROOT / module)
    assert protocols
    for name, members in protocols.items():
        if name.endswith("Bench"):  # the call shapes of Benchmarks' fields
            continue
        assert f"`{name}`" in DOC or re.search(rf"`fitlab\.[\w.]+\.{name}`", DOC), (
            f"docs/architecture.md does not name {name} ({module})"
        )
        missing = [m for m in members if not re.search(rf"`{m}[`(]", DOC)]
        assert not missing, f"docs/architecture.md does not name {name}'s members {missing}"


def _capabilities() -> set[str]:
    """Every capability class of the contract's modules: those whose bases are Capability or a capability."""
    found: set[str] = set()
    for module in CONTRACT:
        for node in _tree(ROOT / module).body:
            if isinstance(node, ast.ClassDef):
                bases = {ast.unparse(b) for b in node.bases}
                if "Capability" in bases or bases & found:
                    found.add(node.name)
    return found


def test_every_capability_is_in_the_table():
    capabilities = _capabilities()
    assert len(capabilities) >= 12
    table = _section("The family contract")
    missing = sorted(c for c in capabilities if not re.search(rf"^\| `(?:fitlab\.[\w.]+\.)?{c}` \|", table, re.M))
    assert not missing, f"the capability table lacks {missing}"


WRITES = {"atomic_write_text", "atomic_write_bytes", "atomic_write_many", "write_text", "write_bytes", "copyfile",
          "savez", "replace", "mkdtemp", "TemporaryDirectory"}  # fmt: skip
READS = {"read_regular_file", "read_text", "read_bytes", "load", "fromfile", "spec_from_file_location"}


_IO_WORDS = re.compile(r"\b(?:" + "|".join(sorted(WRITES | READS | {"open"})) + r")\(")


def _calls(path: Path) -> set[str]:
    out: set[str] = set()
    if not _IO_WORDS.search(path.read_text()):
        return out
    for node in ast.walk(_tree(path)):
        if isinstance(node, ast.Call):
            f = node.func
            name = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", "")
            if name not in WRITES and name not in READS and name != "open":
                continue
            if name == "load" and not (isinstance(f, ast.Attribute) and ast.unparse(f.value) in ("np", "numpy")):
                continue  # np.load only (json.load reads a file object opened elsewhere; store.load is a fit)
            if name == "replace" and not (isinstance(f, ast.Attribute) and ast.unparse(f.value) == "os"):
                continue
            if name == "open" and len(node.args) > 1 and isinstance(node.args[1], ast.Constant):
                name = "open-write" if set(str(node.args[1].value)) & set("wax") else "open-read"
            out.add(name)
    return out


def _named(rel: str, text: str) -> bool:
    """``rel`` (fitlab/a/b/c.py) is in ``text``, whole or as a folder given there and the rest of the path."""
    if f"`{rel}`" in text or f"{rel}" in text:
        return True
    parts = rel.split("/")
    return any(f"`{'/'.join(parts[:k])}/`" in text and f"`{'/'.join(parts[k:])}`" in text
               for k in range(1, len(parts)))  # fmt: skip


def test_every_module_that_reads_or_writes_files_is_in_the_io_section():
    io = _section("Where files are read and written")
    unnamed = []
    for path in _sources():
        rel = path.relative_to(ROOT).as_posix()
        if rel in ("fitlab/_io.py",):
            continue
        calls = _calls(path)
        kinds = [k for k, names in (("writes", WRITES | {"open-write"}), ("reads", READS | {"open-read"}))
                 if calls & names]  # fmt: skip
        if kinds and not _named(rel, io):
            unnamed.append(f"{rel} ({', '.join(kinds)})")
    assert not unnamed, "docs/architecture.md's I/O section does not name: " + "; ".join(unnamed)
    assert "only place" not in io


def _statements(node):
    for field in ("body", "orelse", "handlers", "finalbody", "cases"):
        for child in getattr(node, field, None) or ():
            if isinstance(child, (ast.stmt, ast.excepthandler)) or type(child).__name__ == "match_case":
                yield child


def _imports(path: Path):
    """(module imported, inside a function) of every import in ``path``, relative ones resolved."""
    rel = path.relative_to(ROOT).with_suffix("")
    package = list(rel.parts[:-1])  # the package a relative import starts from (a module's or __init__'s)

    def visit(node, inside):  # statements only: an import is one
        for child in _statements(node):
            fn = isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef))
            if isinstance(child, ast.Import):
                for a in child.names:
                    yield a.name, inside
            elif isinstance(child, ast.ImportFrom):
                base = child.module or ""
                if child.level:
                    up = package[: len(package) - (child.level - 1)]
                    base = ".".join(up + ([child.module] if child.module else []))
                for a in child.names:
                    yield (f"{base}.{a.name}" if base in ("fitlab", "fitlab.families") else base), inside
            yield from visit(child, inside or fn)

    yield from visit(_tree(path), False)


def _family(dotted: str) -> str | None:
    parts = dotted.split(".")
    return parts[2] if len(parts) > 2 and parts[:2] == ["fitlab", "families"] else None


def test_families_are_on_top_and_reached_only_by_discovery():
    bad = []
    for path in _sources():
        rel = path.relative_to(ROOT).as_posix()
        mine = _family(".".join(p for p in path.relative_to(ROOT).with_suffix("").parts if p != "__init__"))
        text = path.read_text()
        suspect = rf"fitlab\.families(?!\.{mine}\b)|fitlab\.cli|^\s*from \." if mine else r"\bfamilies\b"
        if not re.search(suspect, text, re.M):  # no import that could break the rule: not parsed (speed)
            continue
        for module, _inside in _imports(path):
            theirs = _family(module)
            # the registry discovers the families, in the built-in ones' tuple (fitlab.families.BUILTIN)
            generic = mine is None and not rel.startswith("fitlab/core/") and rel != "fitlab/families/__init__.py"
            if generic and (theirs is not None or module == "fitlab.families"):
                bad.append(f"{rel} imports the family module {module}")
            if mine is not None and theirs is not None and theirs != mine:
                bad.append(f"{rel} imports another family's {module}")
            if mine is not None and (module == "fitlab.cli" or module.startswith("fitlab.cli.")):
                bad.append(f"{rel} imports {module}")
    assert not bad, "; ".join(bad)
