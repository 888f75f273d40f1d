"""A griffe extension for the API reference: docstrings' Sphinx roles become links, and a role naming nothing fails.

fitlab's docstrings cite code as ``:func:`fitlab.x.f```, ``:mod:`.sibling``` (relative to the module's package, as
an import is) or ``:data:`NAME``` (in the same module or class).  mkdocstrings renders Markdown and knows no roles,
so each is rewritten into an optional autoref (a link where the target is on the site, plain code elsewhere).  A
role whose target is in fitlab but names nothing there is logged as a warning: ``mkdocs build --strict`` fails on
it, for every docstring of the package, rendered or not.  Names outside fitlab (numpy, jax, ...) stay code.
"""

from __future__ import annotations

import ast
import logging
import re
from typing import Any

import griffe

ROLE = re.compile(r":(?:func|mod|data|class|attr|meth|obj|exc|const):`~?(?P<target>[^`<>\s]+)`")
_log = logging.getLogger("mkdocs.plugins.fitlab.crossrefs")


def resolve(root: griffe.Module, obj: griffe.Object, target: str) -> str | None:
    """The absolute dotted path ``target`` names from ``obj``'s docstring, "" where it is outside fitlab, None
    where it names nothing in fitlab."""
    module = obj if isinstance(obj, griffe.Module) else obj.module
    package = module.path.split(".") if module.is_init_module else module.path.split(".")[:-1]
    if target.startswith("."):
        dots = len(target) - len(target.lstrip("."))
        base = package[: len(package) - (dots - 1)] if dots > 1 else package
        path = ".".join([*base, target.lstrip(".")])
    elif target.split(".")[0] == root.name:
        path = target
    else:  # a name in the object's scope (its class, its module), else something outside fitlab
        head = target.split(".")[0]
        for scope in (obj if obj.is_class or obj.is_module else obj.parent, module):
            if scope is not None and head in scope.all_members:
                member = scope.all_members[head]
                if member.is_alias and member.target_path.split(".")[0] != root.name:
                    return ""  # an imported module or name of another package
                return _exists(root, f"{scope.path}.{target}")
        return ""
    return _exists(root, path)


def _exists(root: griffe.Module, path: str) -> str | None:
    parts = path.split(".")
    if len(parts) == 2 and parts[1] in _lazy(root):  # fitlab.fit_table: the package's names given on first use
        return f"{_lazy(root)[parts[1]]}.{parts[1]}"
    try:
        root[".".join(parts[1:])] if len(parts) > 1 else root
    except (KeyError, griffe.AliasResolutionError, griffe.CyclicAliasError):
        return None
    return path


def _lazy(root: griffe.Module) -> dict[str, str]:
    """The package's ``_LAZY`` table: name -> the module that defines it (``fitlab.__getattr__`` imports it)."""
    lazy = root.members.get("_LAZY")
    return ast.literal_eval(str(lazy.value)) if lazy is not None and lazy.value is not None else {}


def unresolved(root: griffe.Module) -> list[tuple[str, str]]:
    """(object, reference) of every role in the package's docstrings that names nothing in fitlab."""
    return [(obj.path, m["target"]) for obj in _walk(root) if obj.docstring is not None
            for m in ROLE.finditer(obj.docstring.value) if resolve(root, obj, m["target"]) is None]  # fmt: skip


class SphinxRoles(griffe.Extension):
    """Rewrite every docstring's roles of the package (see the module's docstring)."""

    def on_package(self, *, pkg: griffe.Module, **kwargs: Any) -> None:
        if pkg.name != "fitlab":
            return
        for obj in _walk(pkg):
            if obj.docstring is not None:
                obj.docstring.value = ROLE.sub(lambda m, o=obj: self._link(pkg, o, m["target"]), obj.docstring.value)

    def _link(self, root: griffe.Module, obj: griffe.Object, target: str) -> str:
        path = resolve(root, obj, target)
        shown = target.lstrip(".")
        if path is None:
            _log.warning("%s: the docstring's reference %r names nothing", obj.path, target)
            return f"`{shown}`"
        if not path:
            return f"`{shown}`"
        return f'<autoref identifier="{path}" optional><code>{shown}</code></autoref>'


def _walk(obj: griffe.Object):
    yield obj
    for member in obj.members.values():
        if not member.is_alias and member.parent is obj:
            yield from _walk(member)
