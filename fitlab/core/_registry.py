r"""The family registry: every family, target and form fitlab knows.

The families are the built-in ones (the literal tuple :data:`fitlab.families.BUILTIN`), those of the
``fitlab.families`` entry points of installed distributions (each names a :class:`~fitlab.core.Family`
subclass), and any a module registers itself (:func:`register_family`, how a test adds a toy family).  Names
are global: two families may not have one name or one target.

The registry is lazy.  Knowing a family is importing its class, which names its targets
(:attr:`Family.target_names`): :func:`target_names`, :func:`offering` and :func:`family_with` import nothing
more.  A family's targets and forms are imported when first needed (:func:`get_target` or :func:`get_family`
of one of its names, or :func:`targets` / :func:`families`: every family), then checked: its targets are the
ones it named, in that order; each form is of one of its targets, takes that target's inputs, and has a name
of its own; each target's default form exists (ValueError, one line, naming what differs).

A built-in family that fails is an error, every time.  An entry point that fails (it raises, names no family
class, its family clashes with another, or its targets fail to import) is left out, with whatever it
registered: one line on stderr names it, once per process, and :func:`broken_families` says why; every
other family works.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Mapping, Sequence
from importlib.metadata import entry_points
from typing import TYPE_CHECKING, TypeVar, cast

from fitlab.core._family import Capability, Family
from fitlab.core._target import Target

if TYPE_CHECKING:
    from fitlab.forms import Form

__all__ = ["register_family", "unregister_family", "families", "get_family", "targets", "get_target",
           "family_names", "target_names", "forms_for", "get_form", "offering", "family_with", "broken_families",
           "did_you_mean"]  # fmt: skip

C = TypeVar("C", bound=Capability)

#: the package whose ``BUILTIN`` tuple holds the built-in families (imported by name: the families sit above
#: the generic code, which reaches them only through the registry)
BUILTIN_PACKAGE = "fitlab.families"


class _Registry:
    """The registry's state: one instance, :data:`_REGISTRY` (a test may swap in a fresh one)."""

    def __init__(self) -> None:
        #: every known family, in the order commands list them
        self.families: dict[str, Family] = {}
        #: target name -> its family's name, for every target of every known family
        self.owner: dict[str, str] = {}
        #: family name -> its targets by name, once imported and checked
        self.built: dict[str, dict[str, Target]] = {}
        #: the families whose targets are being imported now (a registry call made meanwhile does not recurse)
        self.building: set[str] = set()
        #: the built-in families' names (once loaded)
        self.builtin: set[str] = set()
        #: family name -> the entry point it came from
        self.entry: dict[str, str] = {}
        #: entry point name -> why it was left out (one line)
        self.broken: dict[str, str] = {}
        self.loaded = False

    def add(self, family: Family, entry: str | None = None) -> Family:
        other = self.families.get(family.name)
        if other is not None:
            if other is family:
                return other
            raise ValueError(f"a family named {family.name!r} is already registered")
        names = list(family.target_names)
        clash = [n for n in names if n in self.owner]
        if clash or len(set(names)) != len(names):
            raise ValueError(f"family {family.name}: target names {clash or names} are taken")
        self.families[family.name] = family
        for n in names:
            self.owner[n] = family.name
        if entry is not None:
            self.entry[family.name] = entry
        return family

    def remove(self, name: str) -> None:
        family = self.families.pop(name, None)
        if family is not None:
            for n in family.target_names:
                if self.owner.get(n) == name:
                    del self.owner[n]
        self.built.pop(name, None)
        self.entry.pop(name, None)

    def load(self) -> None:
        """Know every family: the built-in ones, then the entry points'."""
        if self.loaded:
            return
        # a built-in family that fails to import is an error every time: nothing is marked loaded before
        builtin = cast("Sequence[Family]", importlib.import_module(BUILTIN_PACKAGE).BUILTIN)
        self.loaded = True
        self.builtin = {f.name for f in builtin}
        known = list(self.families.values())  # registered before the registry loaded: they keep their place
        self.families.clear()
        self.owner.clear()
        for family in (*builtin, *known):
            self.add(family)
        for ep in entry_points(group="fitlab.families"):
            before = set(self.families)
            try:
                cls = ep.load()
                if not (isinstance(cls, type) and issubclass(cls, Family)):
                    raise TypeError(f"{ep.value} is no subclass of fitlab.core.Family")
                self.add(cls(), entry=ep.name)
            except Exception as exc:  # noqa: BLE001 - a third party's family must not take the others down
                for name in set(self.families) - before:  # what it registered before it failed goes too
                    self.remove(name)
                self.leave_out(ep.name, ep.value, exc)

    def leave_out(self, entry: str, value: str, exc: BaseException) -> None:
        text = "; ".join(line.strip() for line in str(exc).splitlines() if line.strip())
        self.broken[entry] = f"{type(exc).__name__}: {text}" if text else type(exc).__name__
        print(f"fitlab: the family entry point {entry!r} ({value}) failed to load and is left out: "
              f"{self.broken[entry]}", file=sys.stderr)  # fmt: skip

    def build(self, name: str) -> dict[str, Target] | None:
        """The targets of the family ``name``, imported and checked on first use; None while they import, or
        when the family came from an entry point and failed (then it is left out)."""
        built = self.built.get(name)
        if built is not None or name in self.building:
            return built
        family = self.families[name]
        self.building.add(name)
        try:
            built = _checked(family, tuple(family.targets()), tuple(family.forms()))
        except Exception as exc:
            entry = self.entry.get(name)
            if entry is None:
                raise
            self.remove(name)
            self.leave_out(entry, f"family {name}", exc)
            return None
        finally:
            self.building.discard(name)
        self.built[name] = built
        return built

    def build_all(self) -> dict[str, dict[str, Target]]:
        self.load()
        out = {}
        for name in list(self.families):
            built = self.build(name)
            if built is not None:
                out[name] = built
        return out


_REGISTRY = _Registry()


def _checked(family: Family, targets: tuple[Target, ...], forms: tuple[Form, ...]) -> dict[str, Target]:
    """``family``'s targets by name, each bound to the family and its forms; ValueError (one line) where the
    targets differ from the names the family states, or a form does not fit its target."""
    names = tuple(t.name for t in targets)
    if names != family.target_names:
        raise ValueError(f"family {family.name} names the targets {', '.join(family.target_names)}; its targets() "
                         f"gives {', '.join(names)}")  # fmt: skip
    by_name = {t.name: t for t in targets}
    bound: dict[str, dict[str, Form]] = {n: {} for n in names}
    for f in forms:
        if f.target not in bound:
            raise ValueError(f"family {family.name}: form {f.key} names a target the family does not have")
        if f.name in bound[f.target]:
            raise ValueError(f"family {family.name}: form {f.key} defined twice")
        if set(f.inputs) != set(by_name[f.target].inputs):
            raise ValueError(f"family {family.name}: form {f.key} takes {f.inputs}, not its target's inputs")
        bound[f.target][f.name] = f
    for t in targets:
        if t.default_form not in bound[t.name]:
            raise ValueError(f"family {family.name}: target {t.name}'s default form {t.default_form!r} is not one of "
                             "its forms")  # fmt: skip
    for t in targets:  # a Target is frozen: the registry is what binds it
        object.__setattr__(t, "family", family.name)
        object.__setattr__(t, "_forms", bound[t.name])
    return by_name


def loaded() -> bool:
    """Whether the registry knows every family already (then what an entry point's failure says was said)."""
    return _REGISTRY.loaded


def registered_here() -> list[str]:
    """Each family registered by a module of its own (:func:`register_family`), neither built-in nor an entry
    point's, as "name=module:class": what a cache keyed by the families must add to the installed ones."""
    return [f"{name}={type(f).__module__}:{type(f).__qualname__}" for name, f in _REGISTRY.families.items()
            if name not in _REGISTRY.builtin and name not in _REGISTRY.entry]  # fmt: skip


def register_family(family: Family) -> Family:
    """Add ``family`` (an instance of a :class:`Family` subclass); its targets are imported and checked on first
    use.  ValueError when its name or one of its target names is taken."""
    return _REGISTRY.add(family)


def unregister_family(name: str) -> None:
    """Remove a family and its targets (for tests that register a toy family)."""
    _REGISTRY.remove(name)


def broken_families() -> dict[str, str]:
    """Entry point name -> why it was left out (one line), for every ``fitlab.families`` entry point that
    failed."""
    _REGISTRY.build_all()
    return dict(_REGISTRY.broken)


def families() -> dict[str, Family]:
    """name -> :class:`Family` of every family, its targets and forms imported and checked."""
    built = _REGISTRY.build_all()
    return {name: _REGISTRY.families[name] for name in built}


def get_family(name: str) -> Family:
    """The family ``name``, its targets and forms imported and checked (the other families' are not)."""
    _REGISTRY.load()
    if name not in _REGISTRY.families:
        raise KeyError(f"unknown family {name!r}; families: {', '.join(_REGISTRY.families)}")
    if _REGISTRY.build(name) is None:
        raise KeyError(f"family {name!r}: its targets are being imported (or failed); it is not ready")
    return _REGISTRY.families[name]


def targets() -> dict[str, Target]:
    """name -> :class:`Target` of every target, family by family (every family's targets are imported;
    :func:`target_names` imports none)."""
    return {n: t for built in _REGISTRY.build_all().values() for n, t in built.items()}


def family_names() -> tuple[str, ...]:
    """The name of every family, in the order of :func:`families`, importing no family's targets."""
    _REGISTRY.load()
    return tuple(_REGISTRY.families)


def target_names() -> tuple[str, ...]:
    """The name of every target, family by family, in the order of :func:`targets`, importing no family's
    targets."""
    _REGISTRY.load()
    return tuple(n for family in _REGISTRY.families.values() for n in family.target_names)


def get_target(name: str) -> Target:
    """The target ``name``: its family's targets are imported if they were not (the other families' are not)."""
    _REGISTRY.load()
    family = _REGISTRY.owner.get(name)
    if family is None:
        raise KeyError(f"unknown target {name!r}{did_you_mean(name, target_names(), 'fitlab refit --list names them')}")
    built = _REGISTRY.build(family)
    if built is None:
        raise KeyError(f"target {name!r}: its family {family!r} is being imported (or failed); it is not ready")
    return built[name]


def forms_for(target: str) -> Mapping[str, Form]:
    """name -> Form of a target's forms."""
    return get_target(target).forms


def get_form(target: str, name: str) -> Form:
    forms = forms_for(target)
    if name not in forms:
        raise KeyError(f"target {target} has no form {name!r}; forms: {', '.join(forms)}")
    return forms[name]


def offering(capability: type[C]) -> dict[str, C]:
    """name -> family of every family that has ``capability`` (a :class:`Capability` among its bases), in the
    order of :func:`families`, importing no family's targets nor services."""
    _REGISTRY.load()
    return {name: f for name, f in _REGISTRY.families.items() if isinstance(f, capability)}


def family_with(capability: type[C], name: str | None = None) -> C:
    """The family ``name`` when it has ``capability``, or (None) the one family that has it.  KeyError (one line)
    when that family lacks it, when no family has it, or when several do and none is named (then the caller
    must choose)."""
    having = offering(capability)
    if name is not None:
        if name not in having:
            what = "family" if name in _REGISTRY.families else "unknown family"
            raise KeyError(f"{what} {name!r} has no {capability.noun}; families that have: "
                           f"{', '.join(having) or 'none'}")  # fmt: skip
        return having[name]
    if len(having) != 1:
        raise KeyError(f"{len(having)} families have {capability.noun} ({', '.join(having) or 'none'}); "
                       "name one with --family")  # fmt: skip
    return next(iter(having.values()))


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
