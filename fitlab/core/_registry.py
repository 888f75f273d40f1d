r"""The family registry: every target, form and family hook fitlab knows.

Families are found, on first use, among the packages of :mod:`fitlab.families`
and the ``fitlab.families`` entry points of installed distributions; a module
anywhere may also call :func:`register_family` itself (how a test registers a
toy family).  Names are global: two families may not register one target.

A built-in family that fails to import is an error, every time.  An entry point that fails to load
(it raises, or its family clashes with another) is left out, with whatever it registered before it
failed: one line on stderr names it, once per process, and :func:`broken_families` says why; every
other family works.
"""

from __future__ import annotations

import importlib
import pkgutil
import sys
from dataclasses import dataclass, field
from importlib.metadata import entry_points
from typing import Callable, Mapping

from fitlab.core._hooks import ProgramContract, check_hook, check_program
from fitlab.core._target import Target

__all__ = ["Family", "register_family", "unregister_family", "families", "get_family", "targets", "get_target",
           "forms_for", "get_form", "family_service", "resolve_hook", "broken_families"]


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

_FAMILIES: dict[str, Family] = {}
_TARGETS: dict[str, Target] = {}
_LOADED = False
#: entry point name -> why it was left out (one line)
_BROKEN: dict[str, str] = {}


def register_family(family: Family) -> Family:
    """Add ``family``: its targets become visible to every command, its forms to their targets.

    Refused (ValueError) when a target name is taken by another family, when a form names a target the
    family does not register, or when two forms of one target share a name."""
    other = _FAMILIES.get(family.name)
    if other is not None and other is not family:
        raise ValueError(f"a family named {family.name!r} is already registered")
    for hook, value in family.hooks.items():
        if not callable(value):
            raise ValueError(f"family {family.name}: hook {hook!r} is not callable (a hook returns its service)")
    check_program(family.codegen, family.name)
    names = [t.name for t in family.targets]
    clash = [n for n in names if n in _TARGETS and _TARGETS[n].family != family.name]
    if clash or len(set(names)) != len(names):
        raise ValueError(f"family {family.name}: target names {clash or names} are taken")
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
            raise ValueError(f"family {family.name}: target {t.name}'s default form {t.default_form!r} is not registered")
    _FAMILIES[family.name] = family
    for t in family.targets:
        _TARGETS[t.name] = t
    return family


def unregister_family(name: str) -> None:
    """Remove a family and its targets (for tests that register a toy family)."""
    family = _FAMILIES.pop(name, None)
    if family is not None:
        for t in family.targets:
            _TARGETS.pop(t.name, None)


def _load() -> None:
    global _LOADED
    if _LOADED:
        return
    import fitlab.families as builtin

    # a family that fails to import is an error every time, never an empty registry
    for info in sorted(pkgutil.iter_modules(builtin.__path__), key=lambda m: m.name):
        importlib.import_module(f"{builtin.__name__}.{info.name}")
    for ep in entry_points(group="fitlab.families"):
        before = set(_FAMILIES)
        try:
            ep.load()
        except Exception as exc:  # noqa: BLE001 - a third party's family must not take the others down
            for name in set(_FAMILIES) - before:  # what it registered before it failed goes too
                unregister_family(name)
            text = "; ".join(line.strip() for line in str(exc).splitlines() if line.strip())
            _BROKEN[ep.name] = f"{type(exc).__name__}: {text}" if text else type(exc).__name__
            print(f"fitlab: the family entry point {ep.name!r} ({ep.value}) failed to load and is left out: "
                  f"{_BROKEN[ep.name]}", file=sys.stderr)
    _LOADED = True


def broken_families() -> dict[str, str]:
    """Entry point name -> why it was left out (one line), for every ``fitlab.families`` entry point that
    failed to load."""
    _load()
    return dict(_BROKEN)


def families() -> dict[str, Family]:
    """name -> :class:`Family` of every registered family."""
    _load()
    return dict(_FAMILIES)


def get_family(name: str) -> Family:
    _load()
    if name not in _FAMILIES:
        raise KeyError(f"unknown family {name!r}; families: {', '.join(_FAMILIES)}")
    return _FAMILIES[name]


def targets() -> dict[str, Target]:
    """name -> :class:`Target` of every registered target, family by family."""
    _load()
    return dict(_TARGETS)


def get_target(name: str) -> Target:
    _load()
    if name not in _TARGETS:
        raise KeyError(f"unknown target {name!r}; choose one of {', '.join(_TARGETS)}")
    return _TARGETS[name]


def families_offering(name: str) -> list[str]:
    """The names of the registered families whose hooks include ``name``, in registration order."""
    return [fname for fname, f in families().items() if name in f.hooks]


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
        raise KeyError(f"{len(offering)} families offer {name!r} ({', '.join(offering) or 'none'}); "
                       "name one with --family")
    return _service(offering[0], name)


def resolve_hook(family: str, name: str):
    """What ``family``'s hook ``name`` returns (``hooks[name]()``), checked against the hook's contract
    (:data:`HOOK_CONTRACTS`, else :func:`fitlab.core.check_hook`): TypeError, one line naming the first
    missing member.  KeyError when the family has no such hook."""
    hooks = get_family(family).hooks
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
