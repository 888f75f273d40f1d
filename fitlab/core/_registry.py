r"""The family registry: every target, form and family hook fitlab knows.

Families are found, on first use, among the packages of :mod:`fitlab.families`
and the ``fitlab.families`` entry points of installed distributions; a module
anywhere may also call :func:`register_family` itself (how a test registers a
toy family).  Names are global: two families may not register one target.

The registry is lazy: a command imports only the families it uses.  A built-in family's package states
what the registry needs to know before importing it in a literal ``MANIFEST`` (its target names, in order;
its hooks, each the module that holds it; whether it has a program and declares the default one), which the
registry reads from the package's source without running it.  The family itself (its targets, forms,
program: sympy, the exact engine) is imported when first needed: :func:`get_target` or :func:`get_family`
of one of its names, or :func:`targets` / :func:`families` (every family).  :func:`target_names` and
:func:`families_offering` import no family; :func:`resolve_hook` imports the hook's module only.  Registering
checks the family against its manifest (ValueError, one line, naming what differs).  A package without a
literal ``MANIFEST`` is imported when the registry first loads, as an entry point's family is.

A built-in family that fails to import is an error, every time.  An entry point that fails to load
(it raises, or its family clashes with another) is left out, with whatever it registered before it
failed: one line on stderr names it, once per process, and :func:`broken_families` says why; every
other family works.
"""

from __future__ import annotations

import ast
import importlib
import pkgutil
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from importlib.metadata import entry_points
from pathlib import Path

from fitlab.core._hooks import ProgramContract, check_hook, check_program
from fitlab.core._target import Target

__all__ = [
    "Family",
    "register_family",
    "unregister_family",
    "families",
    "get_family",
    "targets",
    "get_target",
    "target_names",
    "forms_for",
    "get_form",
    "family_service",
    "resolve_hook",
    "broken_families",
    "manifest_hooks",
    "did_you_mean",
]


@dataclass(frozen=True, eq=False)
class Family:
    """Everything one BRDF family contributes.

    name: the family's name (its folder's name for the built-in ones).
    description: one line.
    targets: its :class:`Target` s, in the order commands list them.
    forms: its :class:`fitlab.forms.Form` s (each names its target).
    libraries: the candidate-term libraries of ``fitlab discover``: a function returning target -> tuple of
        libraries (the first primary), called only by discover (so that pysindy loads only there).
    codegen: the program its generated code prints beyond one routine per target (a
        :class:`fitlab.codegen.ProgramSpec`, which meets :class:`fitlab.core.ProgramContract`: checked when
        the family registers), or None.
    hooks: further family services by name (runtime models, Monte Carlo scenes, report methods, tables, audit),
        each a callable the generic command of that name looks up; it returns the service, imported only
        then (JAX, Mitsuba stay unloaded until a command needs them).  What a hook returns is checked
        against the hook's contract, a ``typing.Protocol``, when it is resolved (:func:`family_service`,
        :func:`resolve_hook`), with a one-line TypeError naming the first missing member: ``simulate``
        returns a :class:`fitlab.scenes.SimulateHook` (:data:`HOOK_CONTRACTS`), ``tables``, ``audit``,
        ``render``, ``bench``, ``report``, ``table_export`` and ``brdf_grid`` the protocols of
        :mod:`fitlab.core._hooks` (:func:`fitlab.core.check_hook`).
    default_program: whether its program is the one ``fitlab codegen`` (and ``fitlab.codegen.generate``,
        ``load_program``) prints when no family is named: at most one family says so (the Lambert sphere; the
        rule is :func:`fitlab.codegen.program.default_program_family`).
    """

    name: str
    description: str
    targets: tuple[Target, ...]
    forms: tuple = ()
    libraries: Callable[[], Mapping[str, tuple]] = dict
    codegen: ProgramContract | None = None
    hooks: Mapping[str, Callable] = field(default_factory=dict)
    default_program: bool = False


#: hook name -> "module:function" that checks what the hook returns against its contract (a
#: ``typing.Protocol``), raising a one-line TypeError naming the first missing member; run when the hook
#: is resolved (:func:`family_service`, :func:`resolve_hook`), since resolving imports the service.  The
#: hooks not named here are checked by :func:`fitlab.core.check_hook` (their protocols are in
#: :mod:`fitlab.core._hooks`)
HOOK_CONTRACTS = {"simulate": "fitlab.scenes:check_simulate_hook"}


@dataclass(frozen=True, eq=False)
class _Pending:
    """A built-in family known from its package's ``MANIFEST``, not imported yet."""

    name: str
    module: str  # the package whose import registers the family
    targets: tuple[str, ...]
    hooks: Mapping[str, Callable]
    default_program: bool
    program: bool


#: every registered family, in registration order
_FAMILIES: dict[str, Family] = {}
#: every target of a registered family
_TARGETS: dict[str, Target] = {}
#: every family, registered (a Family) or known from its manifest (a _Pending), in the order commands list them
_SLOTS: dict[str, Family | _Pending] = {}
#: target name -> its family's name, for every target of _SLOTS
_OWNER: dict[str, str] = {}
#: built-in family name -> its package (imported, when the family is needed, every time: cheap once imported)
_BUILTIN: dict[str, str] = {}
#: the built-in packages being imported now (a registry call made while one imports does not import it again)
_IMPORTING: set[str] = set()
_LOADED = False
#: entry point name -> why it was left out (one line)
_BROKEN: dict[str, str] = {}


def manifest_hooks(package: str, hooks: Mapping[str, str]) -> dict[str, Callable]:
    """A family's hooks from its manifest's ``hooks``: name -> where the service is, relative to ``package``:
    ``"module"`` (the module is the service), ``"module:NAME"`` (an attribute of it) or ``"module:NAME()"``
    (what calling that attribute returns).  Each hook imports its module only when called."""

    def hook(spec: str) -> Callable:
        module, _, attr = spec.partition(":")
        call = attr.endswith("()")
        attr = attr.removesuffix("()")

        def service():
            value: object = importlib.import_module(f"{package}.{module}")
            if attr:
                value = getattr(value, attr)
            return value() if call and callable(value) else value

        service.__qualname__ = f"hook[{package}.{spec}]"
        return service

    return {name: hook(spec) for name, spec in hooks.items()}


def _manifest(package: str, folder: Path) -> _Pending | None:
    """The built-in family of ``package`` from the literal ``MANIFEST`` in its ``__init__.py`` (read, not run),
    or None when it states none (then the package is imported)."""
    try:
        tree = ast.parse((folder / "__init__.py").read_text(encoding="utf-8"))
    except (OSError, SyntaxError, ValueError):
        return None  # importing it says what is wrong
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "MANIFEST" for t in node.targets):
            try:
                m = ast.literal_eval(node.value)
                return _Pending(name=package.rpartition(".")[2], module=package, targets=tuple(m["targets"]),
                                hooks=manifest_hooks(package, m.get("hooks", {})),
                                default_program=bool(m.get("default_program", False)),
                                program=bool(m.get("program", False)))  # fmt: skip
            except (ValueError, TypeError, KeyError, SyntaxError):
                return None
    return None


def _check_manifest(family: Family, pending: _Pending) -> None:
    """ValueError (one line) where a family differs from what its manifest stated."""
    names = tuple(t.name for t in family.targets)
    where = f"family {family.name}: its MANIFEST ({pending.module}) "
    if names != pending.targets:
        raise ValueError(where + f"lists the targets {', '.join(pending.targets)}; it registers {', '.join(names)}")
    if set(family.hooks) != set(pending.hooks):
        raise ValueError(where + f"lists the hooks {', '.join(sorted(pending.hooks))}; it registers "
                                 f"{', '.join(sorted(family.hooks))}")  # fmt: skip
    if family.default_program != pending.default_program or (family.codegen is not None) != pending.program:
        raise ValueError(where + f"states program={pending.program}, default_program={pending.default_program}; it "
                                 f"registers program={family.codegen is not None}, "
                                 f"default_program={family.default_program}")  # fmt: skip


def _taken(name: str, names) -> None:
    """ValueError when a family ``name`` may not have the targets ``names`` (another family has one)."""
    names = list(names)
    clash = [n for n in names if _OWNER.get(n, name) != name]
    if clash or len(set(names)) != len(names):
        raise ValueError(f"family {name}: target names {clash or names} are taken")


def register_family(family: Family) -> Family:
    """Add ``family``: its targets become visible to every command, its forms to their targets.

    Refused (ValueError) when a target name is taken by another family, when a form names a target the
    family does not register, or when two forms of one target share a name; a built-in family also when it
    differs from its package's ``MANIFEST``."""
    other = _FAMILIES.get(family.name)
    if other is not None and other is not family:
        raise ValueError(f"a family named {family.name!r} is already registered")
    for hook, value in family.hooks.items():
        if not callable(value):
            raise ValueError(f"family {family.name}: hook {hook!r} is not callable (a hook returns its service)")
    check_program(family.codegen, family.name)
    names = [t.name for t in family.targets]
    _taken(family.name, names)
    pending = _SLOTS.get(family.name)
    if isinstance(pending, _Pending):
        _check_manifest(family, pending)
    forms: dict[str, dict] = {n: {} for n in names}
    for f in family.forms:
        if f.target not in forms:
            raise ValueError(f"family {family.name}: form {f.key} names a target the family does not register")
        if f.name in forms[f.target]:
            raise ValueError(f"family {family.name}: form {f.key} defined twice")
        if set(f.inputs) != set(next(t for t in family.targets if t.name == f.target).inputs):
            raise ValueError(f"family {family.name}: form {f.key} takes {f.inputs}, not its target's inputs")
        forms[f.target][f.name] = f
    for t in family.targets:
        object.__setattr__(t, "family", family.name)
        object.__setattr__(t, "_forms", forms[t.name])
        if t.default_form not in forms[t.name]:
            raise ValueError(
                f"family {family.name}: target {t.name}'s default form {t.default_form!r} is not registered"
            )
    _FAMILIES[family.name] = family
    _SLOTS[family.name] = family  # a manifest's place in the order is kept
    for t in family.targets:
        _TARGETS[t.name] = t
        _OWNER[t.name] = family.name
    return family


def _slot_targets(slot: Family | _Pending) -> tuple[str, ...]:
    """The target names of a registered family or of one known from its manifest."""
    return slot.targets if isinstance(slot, _Pending) else tuple(t.name for t in slot.targets)


def unregister_family(name: str) -> None:
    """Remove a family and its targets (for tests that register a toy family)."""
    family = _FAMILIES.pop(name, None)
    if family is not None:
        for t in family.targets:
            _TARGETS.pop(t.name, None)
    slot = _SLOTS.pop(name, None)
    if slot is not None:
        for target in _slot_targets(slot):
            if _OWNER.get(target) == name:
                del _OWNER[target]


def _load() -> None:
    """Know every family: the built-in ones from their manifests (imported only where a package states none),
    the entry points' by loading them."""
    global _LOADED
    if _LOADED:
        return
    import fitlab.families as builtin

    # a family that fails to import is an error every time, never an empty registry
    for info in sorted(pkgutil.iter_modules(builtin.__path__), key=lambda m: m.name):
        package = f"{builtin.__name__}.{info.name}"
        _BUILTIN[info.name] = package
        if info.name in _SLOTS:
            continue  # registered already (its package imported before the registry loaded)
        pending = _manifest(package, Path(getattr(info.module_finder, "path", "")) / info.name) if info.ispkg else None
        if pending is None:
            _import_builtin(info.name)
            continue
        _taken(pending.name, pending.targets)
        _SLOTS[pending.name] = pending
        for t in pending.targets:
            _OWNER[t] = pending.name
    for ep in entry_points(group="fitlab.families"):
        before = set(_FAMILIES)
        try:
            ep.load()
        except Exception as exc:  # noqa: BLE001 - a third party's family must not take the others down
            for name in set(_FAMILIES) - before:  # what it registered before it failed goes too
                unregister_family(name)
            text = "; ".join(line.strip() for line in str(exc).splitlines() if line.strip())
            _BROKEN[ep.name] = f"{type(exc).__name__}: {text}" if text else type(exc).__name__
            print(
                f"fitlab: the family entry point {ep.name!r} ({ep.value}) failed to load and is left out: "
                f"{_BROKEN[ep.name]}",
                file=sys.stderr,
            )
    _LOADED = True


def _import_builtin(name: str) -> None:
    """Import the built-in family ``name``'s package (its import registers it); an error when it fails, or
    when it registers no family of that name."""
    package = _BUILTIN[name]
    if package in _IMPORTING:
        return  # a registry call while it imports: it is being registered
    _IMPORTING.add(package)
    try:
        importlib.import_module(package)
    finally:
        _IMPORTING.discard(package)
    if name not in _FAMILIES:
        raise ImportError(
            f"{package} registered no family {name!r} (a built-in family registers under its folder's name)"
        )


def _ensure(name: str) -> Family | None:
    """The family ``name`` (of _SLOTS), imported if it was only known from its manifest."""
    if name in _BUILTIN:
        _import_builtin(name)  # every time (cheap once imported): a built-in that fails to import is an error
    return _FAMILIES.get(name)


def _ensure_all() -> None:
    _load()
    for name in list(_SLOTS):
        _ensure(name)


def broken_families() -> dict[str, str]:
    """Entry point name -> why it was left out (one line), for every ``fitlab.families`` entry point that
    failed to load."""
    _load()
    return dict(_BROKEN)


def family_programs() -> tuple[tuple[str, bool, bool], ...]:
    """(name, has a program, declares the default program) of every family, in listing order, read from the
    manifests where a built-in family is not imported yet (cheap: no family is imported for it)."""
    _load()
    out = []
    for name, slot in _SLOTS.items():
        if isinstance(slot, _Pending):
            out.append((name, slot.program, slot.default_program))
        else:
            out.append((name, slot.codegen is not None, slot.default_program))
    return tuple(out)


def families() -> dict[str, Family]:
    """name -> :class:`Family` of every registered family (every built-in family is imported)."""
    _ensure_all()
    return {name: _FAMILIES[name] for name in _SLOTS if name in _FAMILIES}


def get_family(name: str) -> Family:
    """The family ``name`` (imported if it was not; the others are not)."""
    _load()
    if name not in _SLOTS:
        raise KeyError(f"unknown family {name!r}; families: {', '.join(_SLOTS)}")
    family = _ensure(name)
    if family is None:  # a registry call while the family's package imports
        raise KeyError(f"family {name!r} is being imported; it is not registered yet")
    return family


def targets() -> dict[str, Target]:
    """name -> :class:`Target` of every registered target, family by family (every built-in family is
    imported; :func:`target_names` imports none)."""
    _ensure_all()
    return {t.name: t for name in _SLOTS if name in _FAMILIES for t in _FAMILIES[name].targets}


def target_names() -> tuple[str, ...]:
    """The name of every target, family by family, in the order of :func:`targets`, importing no built-in
    family."""
    _load()
    return tuple(t for slot in _SLOTS.values() for t in _slot_targets(slot))


def did_you_mean(name: str, names, listing: str = "") -> str:
    """What follows "unknown NAME" in a refusal: ``"; did you mean H0?"`` (or "H0 or H1"), the closest of
    ``names`` to the misspelled ``name`` (difflib's ratio of at least 0.6, ignoring case; at most three), then
    `` (LISTING)`` when ``listing`` is given (where every name is listed, e.g. "fitlab refit --list"); with none
    close, ``"; choose one of A, B, ..."``."""
    import difflib

    names = list(names)
    by_case = {n.lower(): n for n in reversed(names)}
    close = difflib.get_close_matches(str(name).lower(), list(by_case), n=3, cutoff=0.6)
    if not close:
        return f"; choose one of {', '.join(names)}"
    found = [by_case[c] for c in close]
    return (f"; did you mean {', '.join(found[:-1]) + ' or ' if len(found) > 1 else ''}{found[-1]}?"
            f"{f' ({listing})' if listing else ''}")  # fmt: skip


def get_target(name: str) -> Target:
    """The target ``name``: its family is imported if it was not (the others are not)."""
    _load()
    family = _OWNER.get(name)
    if family is None:
        raise KeyError(f"unknown target {name!r}{did_you_mean(name, target_names(), 'fitlab refit --list names them')}")
    _ensure(family)
    if name not in _TARGETS:  # a registry call while the family's package imports
        raise KeyError(f"target {name!r}: its family {family!r} is being imported; it is not registered yet")
    return _TARGETS[name]


def families_offering(name: str) -> list[str]:
    """The names of the registered families whose hooks include ``name``, in registration order (importing no
    built-in family: their manifests name their hooks)."""
    _load()
    return [fname for fname, slot in _SLOTS.items() if name in slot.hooks]


def family_service(name: str, family: str | None = None):
    """The service ``name`` (a family hook: ``hooks[name]()``) of ``family``, or (None) of the one registered
    family that offers it.

    KeyError (one line) when the family does not offer it, when no family does, or when several do and
    none is named (then the caller must choose)."""
    offering = families_offering(name)
    if family is not None:
        if family not in offering:
            raise KeyError(f"family {family!r} offers no {name!r}; families that do: {', '.join(offering) or 'none'}")
        return _service(family, name)
    if len(offering) != 1:
        raise KeyError(
            f"{len(offering)} families offer {name!r} ({', '.join(offering) or 'none'}); name one with --family"
        )
    return _service(offering[0], name)


def resolve_hook(family: str, name: str):
    """What ``family``'s hook ``name`` returns (``hooks[name]()``), checked against the hook's contract
    (:data:`HOOK_CONTRACTS`, else :func:`fitlab.core.check_hook`): TypeError, one line naming the first
    missing member.  KeyError when the family has no such hook.  A built-in family not imported yet is not
    imported for it: its manifest says which module holds the hook, and only that module is imported."""
    _load()
    if family not in _SLOTS:
        raise KeyError(f"unknown family {family!r}; families: {', '.join(_SLOTS)}")
    hooks = _SLOTS[family].hooks
    if name not in hooks:
        raise KeyError(f"family {family!r} has no {name!r} hook")
    service = hooks[name]()
    if name in HOOK_CONTRACTS:
        module, function = HOOK_CONTRACTS[name].split(":")
        getattr(importlib.import_module(module), function)(service, family)
    else:
        check_hook(service, family, name)
    return service


_service = resolve_hook


def forms_for(target: str) -> Mapping:
    """name -> Form of a target's registered forms."""
    return get_target(target).forms


def get_form(target: str, name: str):
    forms = forms_for(target)
    if name not in forms:
        raise KeyError(f"target {target} has no form {name!r}; forms: {', '.join(forms)}")
    return forms[name]
