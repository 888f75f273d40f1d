r"""Checking a parsed scene: typed getters that record a problem and go on, so that every problem of a
file is reported together (one line each, ``file:line: field: what``, in line order); and the
command-line overrides (``--seed``, ``--max-paths``, ``--target-se``), checked by the scene file's rules."""

from __future__ import annotations

import math
import re
from dataclasses import replace
from pathlib import Path

from fitlab.scenes._document import Document, SceneError

__all__ = ["NAME_RE", "Checker", "keypath_name", "check_option", "with_overrides"]

#: A scene name is a plain file-name stem (the outputs are <name>.csv, ...).
NAME_RE = re.compile(r"[A-Za-z0-9_-]{1,100}")


def _positive_finite(v) -> bool:
    """A number (never a bool) in (0, inf): the rule of a target standard error, in a file or on the command line."""
    return not isinstance(v, bool) and isinstance(v, (int, float)) and 0 < v < math.inf


def keypath_name(keypath) -> str:
    """``("material", 1, "c")`` -> ``material[1].c``; () -> ``(top level)``."""
    name = ""
    for part in keypath:
        name += f"[{part}]" if isinstance(part, int) else (("." if name else "") + str(part))
    return name or "(top level)"


class Checker:
    """Collects the problems of one document; :meth:`raise_errors` raises them as one :class:`SceneError`."""

    def __init__(self, doc: Document):
        self.doc, self.path = doc, doc.path
        self.errors: list[tuple[tuple, str]] = []

    def fail(self, keypath, msg: str) -> None:
        """Record a problem of the field at ``keypath`` (a tuple of keys and array indices)."""
        self.errors.append((tuple(keypath), msg))

    def raise_errors(self) -> None:
        """Raise every recorded problem, one line each in line order (the order recorded within a line)."""
        if not self.errors:
            return
        lines = [(self.doc.line(kp), keypath_name(kp), msg) for kp, msg in self.errors]
        lines.sort(key=lambda e: e[0])
        raise SceneError("\n".join(f"{self.path}:{line}: {name}: {msg}" for line, name, msg in lines))

    # typed getters: return None after recording an error
    def number(self, d, keypath, lo=-math.inf, hi=math.inf, default=None, integer=False):
        """``d[keypath[-1]]``: a number (an integer when ``integer``; never a bool), finite, in [lo, hi];
        ``default`` when absent (absent without a default is a problem)."""
        key = keypath[-1]
        if key not in d:
            if default is None:
                self.fail(keypath, "missing")
            return default
        v = d[key]
        ok = isinstance(v, int) if integer else isinstance(v, (int, float))
        if isinstance(v, bool) or not ok:
            self.fail(keypath, f"expected {'an integer' if integer else 'a number'}, got {v!r}")
            return None
        if isinstance(v, float) and not math.isfinite(v):
            self.fail(keypath, f"{v!r} is not a finite number")
            return None
        if not lo <= v <= hi:
            self.fail(keypath, f"{v!r} is outside [{lo}, {hi}]")
            return None
        return v

    def choice(self, d, keypath, options, default):
        """``d[keypath[-1]]`` (``default`` when absent), one of ``options``."""
        v = d.get(keypath[-1], default)
        if v not in options:
            self.fail(keypath, f"expected one of {list(options)}, got {v!r}")
            return None
        return v

    def unknown(self, d, keypath, known) -> None:
        """Record every key of ``d`` not in ``known``."""
        for k in d:
            if k not in known:
                self.fail(tuple(keypath) + (k,), f"unknown field (known here: {', '.join(sorted(known))})")

    def table(self, d, keypath, known) -> dict:
        """``d[keypath[-1]]`` as a table ({} when absent or not a table, the latter recorded), its unknown
        keys recorded."""
        v = d.get(keypath[-1], {})
        if not isinstance(v, dict):
            self.fail(keypath, f"expected a table, got {v!r}")
            return {}
        self.unknown(v, keypath, known)
        return v

    def per_key(self, d, keypath, known, required, noun: str, missing: str, every=None) -> dict:
        """``d[keypath[-1]]``, a positive finite number per key: one number for every key of ``every`` (default
        ``known``), or a table of them by key (each key one of ``known``, each of ``required`` present);
        {key: float} without the keys of a problem, which is recorded (``noun`` names a key in the messages,
        ``missing`` says what the field is)."""
        v = d.get(keypath[-1])
        if v is None:
            self.fail(keypath, f"missing: {missing}")
            return {}
        if isinstance(v, dict):
            out = {}
            for k, x in v.items():
                if k not in known:
                    self.fail(tuple(keypath) + (k,), f"unknown {noun} {k!r} (known: {', '.join(known)})")
                elif not _positive_finite(x):
                    self.fail(tuple(keypath) + (k,), f"expected a positive finite number, got {x!r}")
                else:
                    out[k] = float(x)
            for k in required:
                if k not in v:
                    self.fail(keypath, f"no target for {noun} {k!r}")
            return out
        if not _positive_finite(v):
            self.fail(keypath, f"expected a positive finite number or a table per {noun}, got {v!r}")
            return {}
        return {k: float(v) for k in (known if every is None else every)}

    def edges(self, value, keypath, hi: float, what: str):
        """Bin edges on [0, hi]: from a count n (n equal bins, 1 <= n <= 1000) or a strictly increasing
        list of >= 2 numbers in [0, hi]; None after recording a problem."""
        if isinstance(value, int) and not isinstance(value, bool):
            if not 1 <= value <= 1000:
                self.fail(keypath, f"number of {what} bins must lie in [1, 1000], got {value}")
                return None
            return tuple(float(x) for x in [hi * k / value for k in range(value + 1)])
        if not isinstance(value, list) or len(value) < 2:
            self.fail(keypath, f"expected an integer number of bins or a list of >= 2 bin edges, got {value!r}")
            return None
        for k, v in enumerate(value):
            if (
                isinstance(v, bool)
                or not isinstance(v, (int, float))
                or not math.isfinite(v)
                or not 0.0 <= v <= hi + 1e-12
            ):
                self.fail(tuple(keypath) + (k,), f"bin edge {v!r} is not a number in [0, {hi:g}]")
                return None
        if any(b <= a for a, b in zip(value[:-1], value[1:])):
            self.fail(keypath, f"bin edges must increase strictly, got {value}")
            return None
        return tuple(float(v) for v in value)

    def name(self, d, keypath) -> str:
        """The scene's name: ``d[keypath[-1]]``, else the file's stem; a plain file-name stem
        (:data:`NAME_RE`), since the outputs are named after it."""
        given = keypath[-1] in d
        name = d.get(keypath[-1], Path(str(self.path)).stem)
        if not isinstance(name, str) or not NAME_RE.fullmatch(name):
            self.fail(
                keypath,
                f"expected a plain file-name stem of 1-100 letters, digits, '_' or '-', got "
                f"{name!r}{'' if given else ' (the file stem: set scene.name)'}",
            )
        return name

    def non_finite(self, v=None, keypath=()) -> None:
        """Record every NaN or infinite number anywhere in ``v`` (the whole document by default)."""
        if v is None and not keypath:
            v = self.doc.data
        if isinstance(v, float) and not math.isfinite(v):
            self.fail(keypath, f"{v!r} is not a finite number")
        elif isinstance(v, dict):
            for k, x in v.items():
                self.non_finite(x, tuple(keypath) + (k,))
        elif isinstance(v, list):
            for k, x in enumerate(v):
                self.non_finite(x, tuple(keypath) + (k,))


def check_option(name: str, value, limits) -> int | float:
    """A command-line override (``seed``, ``max_paths`` or ``target_se``) by the scene file's own rule
    (``limits[name]``: the closed range of an integer field); a string is parsed first.  Raises a one-line
    :class:`SceneError` naming the flag."""
    flag = "--" + name.replace("_", "-")
    v = value
    if isinstance(v, str):
        try:
            v = int(v.strip()) if name != "target_se" else float(v.strip())
        except ValueError:
            v = None
    if name == "target_se":
        if not _positive_finite(v):
            raise SceneError(f"{flag}: expected a positive finite number, got {value!r}")
        return float(v)
    lo, hi = limits[name]
    if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
        raise SceneError(f"{flag}: expected an integer in [{lo}, {hi}], got {value!r}")
    return v


def with_overrides(scene, limits, target_keys, target_se=None, max_paths=None, seed=None):
    """``scene`` (a dataclass with fields seed, max_paths and target_se) with the command-line overrides
    (None: keep), each checked by :func:`check_option`; ``--target-se`` sets the target of every key of
    ``target_keys``.  Every bad override is one line of one :class:`SceneError`."""
    changes, errors = {}, []
    for name, value in (("target_se", target_se), ("max_paths", max_paths), ("seed", seed)):
        if value is not None:
            try:
                changes[name] = check_option(name, value, limits)
            except SceneError as exc:
                errors.append(str(exc))
    if errors:
        raise SceneError("\n".join(errors))
    if "target_se" in changes:
        changes["target_se"] = dict.fromkeys(target_keys, changes["target_se"])
    return replace(scene, **changes) if changes else scene
