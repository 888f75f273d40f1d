r"""Scene files: what to simulate, read from TOML or JSON and validated in full
before any simulation starts.

A scene names materials (c, or kd = the spherical albedo, converted to c by the
exact engine), incident directions, how outgoing directions are tallied (mu_o
bins and Fourier orders cos(m phi), and/or |phi| bins), the effects wanted and
a precision target.  Example (TOML; the JSON form has the same nesting)::

    [scene]
    name = "order1"              # optional; default: the file stem; letters, digits, _ and - only
    seed = 1                     # integer in [0, 2^63 - 1] (the rule of --seed too)
    phase = "three_term"         # multiple scattering by "three_term" or "true" p
    sampler = "exact"            # eq. 5 ("exact") or eq. 6 ("approx"), true p only

    [[material]]
    c = 0.99                     # or kd = 0.5

    [incident]
    mu_i = [0.3, 0.7]

    [outgoing]
    mu_o = [0.0, 0.25, 0.5, 0.75, 1.0]   # bin edges, or an integer n (equal bins)
    fourier = [0, 1, 2]                   # orders m of cos(m phi)
    phi = 6                               # |phi| bins on [0, pi]: n, or edges (radians)

    [effects]
    list = ["single", "multiple", "collisions", "phase_difference", "albedo", "spherical_albedo"]
    collision_orders = 6         # "collisions": orders 2..N and the rest

    [precision]
    target_se = 2e-3             # or a table per effect: {multiple = 2e-3, albedo = 5e-4}
    max_paths = 2000000          # per job (material x incident direction x phase), in [1000, 2^32]
    batch = 100000               # photons per round, at most 10^7; the stopping rule is checked per round
    max_collisions = 100000      # the cap; what it cuts is tallied and reported
    slots = 0                    # photon slots per device (0: automatic)

Every error names ``file:line`` and the field (``material[2].c``); all errors
of a file are reported together, as one :class:`SceneError`.  NaN and infinite
numbers are refused anywhere, and so is a material whose Monte Carlo estimate
would have an infinite variance: c > 1/N = 0.999473 with the three-term phase
function (kd = 1 included), c > 0.998863 with ``phase_difference``
(:data:`fitlab.families.lambert_sphere.mc.sampling.C_LIMIT`).
"""

from __future__ import annotations

import bisect
import json
import math
import re
import tomllib
from dataclasses import dataclass, field, replace
from json.decoder import scanstring
from pathlib import Path

import numpy as np

from fitlab._io import InputFileError, read_regular_file
from fitlab._montecarlo import MAX_PATHS, MIN_PATHS_BUDGET
from fitlab.core import get_form
from fitlab.families.lambert_sphere.exact import albedo_inverse

__all__ = ["EFFECTS", "LIMITS", "NAME_RE", "Material", "Scene", "SceneError", "check_option", "load_scene",
           "parse_scene", "with_overrides"]

#: effect name -> one-line description
EFFECTS = {
    "single": "single scattering, closed form (eq. 10), never simulated",
    "multiple": "multiple scattering by Fourier order (or |phi| bin) per mu_o bin, and the total with single scattering",
    "collisions": "multiple scattering by number of collisions: orders 2..N and the rest",
    "phase_difference": "multiple scattering with the true minus the three-term phase function (correlated paths)",
    "albedo": "directional albedo a(mu_i)",
    "spherical_albedo": "spherical (Bond) albedo kd",
}
PHASES = ("three_term", "true")
SAMPLERS = ("exact", "approx")

#: Integer fields and the options that override them: one rule each, for the
#: scene file and the command line.  batch: the stopping rule and the progress
#: are checked once per round, so a round is at most 10^7 photons (seconds to a
#: few minutes); the seed is a 63-bit non-negative integer (JAX's key).
LIMITS = {
    "seed": (0, 2**63 - 1),
    "max_paths": (MIN_PATHS_BUDGET, MAX_PATHS),  # one rule for every family (fitlab._montecarlo)
    "batch": (100, 10**7),
    "max_collisions": (2, 10**8),
    "slots": (0, 2**22),
}
#: A scene name is a plain file-name stem (the outputs are <name>.csv, ...).
NAME_RE = re.compile(r"[A-Za-z0-9_-]{1,100}")

_KNOWN = {
    (): {"scene", "material", "incident", "outgoing", "effects", "precision"},
    ("scene",): {"name", "description", "seed", "phase", "sampler"},
    ("material",): {"c", "kd", "label"},
    ("incident",): {"mu_i"},
    ("outgoing",): {"mu_o", "fourier", "phi"},
    ("effects",): {"list", "collision_orders"},
    ("precision",): {"target_se", "max_paths", "batch", "max_collisions", "slots"},
}


#: the largest scene file read, in bytes
MAX_SCENE_BYTES = 1_000_000


class SceneError(ValueError):
    """A malformed scene; the message lists every problem as file:line: field: what."""


@dataclass(frozen=True)
class Material:
    label: str
    c: float
    kd: float | None = None  # as given in the scene, if given as kd


@dataclass(frozen=True)
class Scene:
    path: str
    name: str
    description: str
    seed: int
    phase: str
    sampler: str
    materials: tuple
    mu_i: tuple
    mu_edges: tuple
    orders: tuple
    phi_edges: tuple
    effects: tuple
    collision_orders: int
    target_se: dict = field(hash=False)
    max_paths: int = 2_000_000
    batch: int = 100_000
    max_collisions: int = 100_000
    slots: int = 0  # 0: automatic (fitlab.families.lambert_sphere.mc.transport.default_slots)


# --------------------------------------------------------------- line numbers
def _strip_comment(line: str) -> str:
    """The line without a trailing # comment (a # inside quotes is kept)."""
    quote = None
    for i, ch in enumerate(line):
        if quote:
            if ch == quote:
                quote = None
        elif ch in "\"'":
            quote = ch
        elif ch == "#":
            return line[:i]
    return line


def _toml_lines(text: str) -> dict:
    """Map key paths to the line that sets them (arrays of tables indexed from 0).

    A light scanner (tomllib gives no positions): table headers, array of
    tables headers, ``key = value`` lines (dotted keys too), and the items of
    array values, which may span several lines (path + (index,)).  Fields of
    inline tables map to the line of their table.
    """
    lines, table, counts = {}, (), {}
    key_re = re.compile(r'^\s*((?:[A-Za-z0-9_-]+|"[^"]*"|\'[^\']*\')(?:\s*\.\s*(?:[A-Za-z0-9_-]+|"[^"]*"|\'[^\']*\'))*)\s*=')
    src = [_strip_comment(s) for s in text.splitlines()]

    def split(name):
        return tuple(p.strip().strip("\"'") for p in name.split("."))

    def scan_value(no, col, path):
        """Scan the value at src[no-1][col:]; record array items; return the last line used."""
        stack, quote, item = [], None, []  # stack of open brackets; item: index per '[' level
        ln, i = no, col
        while ln <= len(src):
            s = src[ln - 1]
            while i < len(s):
                ch = s[i]
                if quote:
                    if ch == "\\":
                        i += 1
                    elif ch == quote:
                        quote = None
                elif ch in "\"'":
                    quote = ch
                    if stack and stack[-1] == "[" and item[-1][1]:
                        lines[path + tuple(k for k, _ in item)] = ln
                        item[-1][1] = False
                elif ch in "[{":
                    if stack and stack[-1] == "[" and item[-1][1]:
                        lines[path + tuple(k for k, _ in item)] = ln
                        item[-1][1] = False
                    stack.append(ch)
                    if ch == "[":
                        item.append([0, True])
                elif ch in "]}":
                    if stack:
                        if stack.pop() == "[":
                            item.pop()
                    if not stack:
                        return ln
                elif ch == "," and stack and stack[-1] == "[":
                    item[-1][0] += 1
                    item[-1][1] = True
                elif not ch.isspace() and stack and stack[-1] == "[" and item[-1][1]:
                    lines[path + tuple(k for k, _ in item)] = ln
                    item[-1][1] = False
                i += 1
            if not stack:
                return ln
            ln, i = ln + 1, 0
        return ln

    no = 1
    while no <= len(src):
        line = src[no - 1]
        s = line.strip()
        m = re.match(r"^\[\[\s*([^\]]+?)\s*\]\]", s)
        if m:
            name = split(m.group(1))
            idx = counts.get(name, 0)
            counts[name] = idx + 1
            table = name + (idx,)
            lines.setdefault(name, no)
            lines[table] = no
        elif re.match(r"^\[\s*([^\]]+?)\s*\]", s):
            table = split(re.match(r"^\[\s*([^\]]+?)\s*\]", s).group(1))
            lines[table] = no
        else:
            m = key_re.match(line)
            if m:
                path = table + split(m.group(1))
                lines[path] = no
                no = max(no, scan_value(no, m.end(), path))
        no += 1
    return lines


def _json_lines(text: str) -> dict:
    """Map key paths of valid JSON text to the line of each key (array items: their index)."""
    newlines = [i for i, ch in enumerate(text) if ch == "\n"]
    lines = {}
    ws = re.compile(r"[ \t\n\r]*")
    num = re.compile(r"-?(?:0|[1-9]\d*)(?:\.\d+)?(?:[eE][-+]?\d+)?")

    def line_of(i):
        return bisect.bisect_left(newlines, i) + 1

    def value(i, path):
        i = ws.match(text, i).end()
        ch = text[i]
        if ch == "{":
            i = ws.match(text, i + 1).end()
            if text[i] == "}":
                return i + 1
            while True:
                i = ws.match(text, i).end()
                key, j = scanstring(text, i + 1)
                lines[path + (key,)] = line_of(i)
                j = ws.match(text, j).end() + 1  # ':'
                i = ws.match(text, value(j, path + (key,))).end()
                if text[i] == ",":
                    i += 1
                    continue
                return i + 1
        if ch == "[":
            i = ws.match(text, i + 1).end()
            if text[i] == "]":
                return i + 1
            k = 0
            while True:
                i = ws.match(text, i).end()
                lines[path + (k,)] = line_of(i)
                i = ws.match(text, value(i, path + (k,))).end()
                k += 1
                if text[i] == ",":
                    i += 1
                    continue
                return i + 1
        if ch == '"':
            return scanstring(text, i + 1)[1]
        for lit in ("true", "false", "null", "NaN", "Infinity", "-Infinity"):
            if text.startswith(lit, i):
                return i + len(lit)
        return num.match(text, i).end()

    value(0, ())
    return lines


# ------------------------------------------------------------------ checking
class _Checker:
    def __init__(self, path: str, lines: dict):
        self.path, self.lines, self.errors = path, lines, []

    def line(self, keypath: tuple) -> int:
        p = tuple(keypath)
        while p:
            if p in self.lines:
                return self.lines[p]
            p = p[:-1]
        return 1

    def fail(self, keypath: tuple, msg: str):
        name = ""
        for part in keypath:
            name += f"[{part}]" if isinstance(part, int) else (("." if name else "") + part)
        line = self.line(keypath)
        self.errors.append((line, f"{self.path}:{line}: {name or '(top level)'}: {msg}"))

    # typed getters: return None after recording an error
    def number(self, d, keypath, lo=-math.inf, hi=math.inf, default=None, integer=False):
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
        if not (lo <= v <= hi) or (isinstance(v, float) and not math.isfinite(v)):
            self.fail(keypath, f"{v!r} is outside [{lo}, {hi}]")
            return None
        return v

    def choice(self, d, keypath, options, default):
        v = d.get(keypath[-1], default)
        if v not in options:
            self.fail(keypath, f"expected one of {list(options)}, got {v!r}")
            return None
        return v

    def unknown(self, d, keypath, known):
        for k in d:
            if k not in known:
                self.fail(tuple(keypath) + (k,), f"unknown field (known here: {', '.join(sorted(known))})")


def _edges(ck: _Checker, value, keypath, hi: float, what: str):
    """Bin edges from an integer n (equal bins on [0, hi]) or an increasing list in [0, hi]."""
    if isinstance(value, int) and not isinstance(value, bool):
        if not 1 <= value <= 1000:
            ck.fail(keypath, f"number of {what} bins must lie in [1, 1000], got {value}")
            return None
        return tuple(float(x) for x in [hi * k / value for k in range(value + 1)])
    if not isinstance(value, list) or len(value) < 2:
        ck.fail(keypath, f"expected an integer number of bins or a list of >= 2 bin edges, got {value!r}")
        return None
    for k, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not (0.0 <= v <= hi + 1e-12):
            ck.fail(tuple(keypath) + (k,), f"bin edge {v!r} is not a number in [0, {hi:g}]")
            return None
    if any(b <= a for a, b in zip(value[:-1], value[1:])):
        ck.fail(keypath, f"bin edges must increase strictly, got {value}")
        return None
    return tuple(float(v) for v in value)


def _c_of_kd(kd: float, phase: str) -> float:
    """c whose exact spherical albedo is kd (three-term half space, or fitlab.families.lambert_sphere.exact 'true'):
    :func:`fitlab.families.lambert_sphere.exact.albedo_inverse`, bracketed around the published eq. 39 map
    (the ``paper`` preset of the c_of_kd form ``rational_power``)."""

    model = "three_term" if phase == "three_term" else "true"
    guess = float(get_form("c_of_kd", "rational_power")("paper", np.asarray(float(kd)))) if 0.0 < kd <= 1.0 else None
    return albedo_inverse(kd, model, guess)


def _non_finite(v, keypath):
    """(key path, value) of every NaN or infinite float in a parsed scene."""
    if isinstance(v, float) and not math.isfinite(v):
        yield keypath, v
    elif isinstance(v, dict):
        for k, x in v.items():
            yield from _non_finite(x, keypath + (k,))
    elif isinstance(v, list):
        for k, x in enumerate(v):
            yield from _non_finite(x, keypath + (k,))


def _walks(phase: str, effects) -> tuple:
    """The walk phases (transport.WalkConfig.phase) a scene's effects run."""
    out = []
    if any(e in effects for e in ("multiple", "collisions", "albedo", "spherical_albedo")):
        out.append(phase)
    if "phase_difference" in effects:
        out.append("both")
    return tuple(out)


def _unbounded(walk: str, c: float):
    from fitlab.families.lambert_sphere.mc.sampling import unbounded_reason  # JAX, only when a scene is checked

    return unbounded_reason(walk, c)


def check_option(name: str, value) -> int | float:
    """A command-line override (``seed``, ``max_paths`` or ``target_se``), by the
    scene file's own rule; a string is parsed first.  Raises a one-line SceneError."""
    flag = "--" + name.replace("_", "-")
    v = value
    if isinstance(v, str):
        try:
            v = int(v.strip()) if name != "target_se" else float(v.strip())
        except ValueError:
            v = None
    if name == "target_se":
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 < v < math.inf:
            raise SceneError(f"{flag}: expected a positive finite number, got {value!r}")
        return float(v)
    lo, hi = LIMITS[name]
    if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
        raise SceneError(f"{flag}: expected an integer in [{lo}, {hi}], got {value!r}")
    return v


def with_overrides(scene: Scene, target_se=None, max_paths=None, seed=None) -> Scene:
    """The scene with command-line overrides (None: keep), each checked by :func:`check_option`."""

    changes, errors = {}, []
    for name, value in (("target_se", target_se), ("max_paths", max_paths), ("seed", seed)):
        if value is not None:
            try:
                changes[name] = check_option(name, value)
            except SceneError as exc:
                errors.append(str(exc))
    if errors:
        raise SceneError("\n".join(errors))
    if "target_se" in changes:
        changes["target_se"] = {e: changes["target_se"] for e in scene.effects}
    return replace(scene, **changes) if changes else scene


def parse_scene(text: str, path: str = "<scene>", fmt: str | None = None, resolve_kd: bool = True) -> Scene:
    """Parse and validate scene text (format from ``fmt`` or the file suffix: toml or json).

    Materials given by kd get their c from the exact engine (``resolve_kd``;
    without it their c is NaN: enough to validate a scene, not to run it).
    """
    fmt = fmt or ("json" if str(path).endswith(".json") else "toml")
    try:
        if fmt == "json":
            raw = json.loads(text)
            try:
                lines = _json_lines(text)
            except (IndexError, ValueError, AttributeError):  # positions are a courtesy: never fail on them
                lines = {}
        else:
            raw = tomllib.loads(text)
            lines = _toml_lines(text)
    except json.JSONDecodeError as exc:
        raise SceneError(f"{path}:{exc.lineno}: not valid JSON: {exc.msg} (column {exc.colno})") from None
    except tomllib.TOMLDecodeError as exc:
        m = re.search(r"at line (\d+), column (\d+)", str(exc))
        where = f"{m.group(1)}" if m else "1"
        raise SceneError(f"{path}:{where}: not valid TOML: {exc}") from None
    if not isinstance(raw, dict):
        raise SceneError(f"{path}:1: (top level): expected a table/object")
    ck = _Checker(str(path), lines)
    for keypath, v in _non_finite(raw, ()):
        ck.fail(keypath, f"{v!r} is not a finite number")
    if ck.errors:  # NaN/inf anywhere: refused before any other check reads the value
        raise SceneError("\n".join(text for _, text in sorted(ck.errors, key=lambda e: e[0])))
    ck.unknown(raw, (), _KNOWN[()])
    sections = {}
    for name in ("scene", "incident", "outgoing", "effects", "precision"):
        v = raw.get(name, {})
        if not isinstance(v, dict):
            ck.fail((name,), f"expected a table, got {v!r}")
            v = {}
        ck.unknown(v, (name,), _KNOWN[(name,)])
        sections[name] = v
    sc, inc, out, eff, prec = (sections[k] for k in ("scene", "incident", "outgoing", "effects", "precision"))

    name = sc.get("name", Path(str(path)).stem)
    if not isinstance(name, str) or not NAME_RE.fullmatch(name):
        given = "" if "name" in sc else " (the file stem: set scene.name)"
        ck.fail(("scene", "name"), f"expected a plain file-name stem of 1-100 letters, digits, '_' or '-', "
                                   f"got {name!r}{given}")
    description = sc.get("description", "")
    if not isinstance(description, str):
        ck.fail(("scene", "description"), "expected a string")
    seed = ck.number(sc, ("scene", "seed"), *LIMITS["seed"], default=0, integer=True)
    phase = ck.choice(sc, ("scene", "phase"), PHASES, "three_term")
    sampler = ck.choice(sc, ("scene", "sampler"), SAMPLERS, "exact")

    # effects
    effects = eff.get("list")
    if effects is None:
        ck.fail(("effects", "list"), f"missing: give a list of effects from {list(EFFECTS)}")
        effects = []
    elif not isinstance(effects, list) or not effects:
        ck.fail(("effects", "list"), f"expected a non-empty list of effects from {list(EFFECTS)}, got {effects!r}")
        effects = []
    else:
        for k, e in enumerate(effects):
            if e not in EFFECTS:
                ck.fail(("effects", "list", k), f"unknown effect {e!r} (known: {', '.join(EFFECTS)})")
        if len(set(effects)) != len(effects):
            ck.fail(("effects", "list"), "an effect is listed twice")
    effects = tuple(e for e in effects if e in EFFECTS)
    coll = ck.number(eff, ("effects", "collision_orders"), 2, 1000, default=6, integer=True)
    if "collision_orders" in eff and "collisions" not in effects:
        ck.fail(("effects", "collision_orders"), "given, but 'collisions' is not among the effects")
    if sampler == "approx" and phase != "true":
        ck.fail(("scene", "sampler"), "eq. 6 ('approx') samples the true phase function: set phase = \"true\"")
    if sampler == "approx" and "phase_difference" in effects:
        ck.fail(("scene", "sampler"), "phase_difference weighs paths by p/q and needs the exact sampler (eq. 5)")

    # materials
    mats_raw = raw.get("material", [])
    if not isinstance(mats_raw, list) or not mats_raw:
        ck.fail(("material",), "expected at least one [[material]] with c = ... or kd = ...")
        mats_raw = []
    materials = []
    for i, m in enumerate(mats_raw):
        kp = ("material", i)
        if not isinstance(m, dict):
            ck.fail(kp, f"expected a table, got {m!r}")
            continue
        ck.unknown(m, kp, _KNOWN[("material",)])
        if ("c" in m) == ("kd" in m):
            ck.fail(kp, "give exactly one of c (single-scattering albedo) or kd (spherical albedo)")
            continue
        key = "c" if "c" in m else "kd"
        v = ck.number(m, kp + (key,), 0.0, 1.0)
        label = m.get("label", f"{key}={v}")
        if not isinstance(label, str):
            ck.fail(kp + ("label",), "expected a string")
        if v is not None:
            materials.append((label, key, float(v)))

    # incident / outgoing
    need_mu_i = any(e in effects for e in ("single", "multiple", "collisions", "phase_difference", "albedo"))
    mu_i = ()
    if "mu_i" in inc:
        v = inc["mu_i"]
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            v = [v]
        if not isinstance(v, list) or not v:
            ck.fail(("incident", "mu_i"), f"expected a cosine or a list of cosines in [0, 1], got {v!r}")
        else:
            for k, x in enumerate(v):
                if isinstance(x, bool) or not isinstance(x, (int, float)) or not 0.0 <= x <= 1.0:
                    ck.fail(("incident", "mu_i", k), f"expected a cosine in [0, 1], got {x!r}")
            mu_i = tuple(float(x) for x in v if isinstance(x, (int, float)) and not isinstance(x, bool))
    elif need_mu_i:
        ck.fail(("incident", "mu_i"), "missing: the effects " + ", ".join(
            e for e in effects if e not in ("spherical_albedo",)) + " need incident directions")
    mu_edges = _edges(ck, out["mu_o"], ("outgoing", "mu_o"), 1.0, "mu_o") if "mu_o" in out else ()
    orders = ()
    if "fourier" in out:
        v = out["fourier"]
        if not isinstance(v, list) or not v or any(isinstance(m, bool) or not isinstance(m, int) or not 0 <= m <= 16 for m in v):
            ck.fail(("outgoing", "fourier"), f"expected a list of Fourier orders m in 0..16, got {v!r}")
        elif len(set(v)) != len(v):
            ck.fail(("outgoing", "fourier"), "an order is listed twice")
        else:
            orders = tuple(v)
    phi_edges = _edges(ck, out["phi"], ("outgoing", "phi"), math.pi, "phi") if "phi" in out else ()
    for e in ("single", "multiple", "phase_difference"):
        if e in effects:
            if not mu_edges and "mu_o" not in out:
                ck.fail(("outgoing", "mu_o"), f"missing: effect {e!r} needs mu_o bins")
            elif not (orders or phi_edges) and "fourier" not in out and "phi" not in out:
                ck.fail(("outgoing",), f"effect {e!r} needs fourier = [orders] or phi = bins")
    if (orders or phi_edges) and not mu_edges and "mu_o" not in out:
        ck.fail(("outgoing", "mu_o"), "fourier/phi tallies need mu_o bins")

    # precision
    tse = prec.get("target_se")
    target = {}
    if tse is None:
        ck.fail(("precision", "target_se"), "missing: the standard error at which each tally stops")
    elif isinstance(tse, dict):
        for k, v in tse.items():
            if k not in EFFECTS:
                ck.fail(("precision", "target_se", k), f"unknown effect {k!r}")
            elif isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 < v < math.inf:
                ck.fail(("precision", "target_se", k), f"expected a positive finite number, got {v!r}")
            else:
                target[k] = float(v)
        for e in effects:
            if e != "single" and e not in target:
                ck.fail(("precision", "target_se"), f"no target for effect {e!r}")
    elif isinstance(tse, bool) or not isinstance(tse, (int, float)) or not 0 < tse < math.inf:
        ck.fail(("precision", "target_se"), f"expected a positive finite number or a table per effect, got {tse!r}")
    else:
        target = {e: float(tse) for e in effects}
    max_paths = ck.number(prec, ("precision", "max_paths"), *LIMITS["max_paths"], default=2_000_000, integer=True)
    batch = ck.number(prec, ("precision", "batch"), *LIMITS["batch"], default=100_000, integer=True)
    max_coll = ck.number(prec, ("precision", "max_collisions"), *LIMITS["max_collisions"], default=100_000,
                         integer=True)
    slots = ck.number(prec, ("precision", "slots"), *LIMITS["slots"], default=0, integer=True)
    if slots is not None and 0 < slots < 64:
        ck.fail(("precision", "slots"), f"photon slots per device: 0 (automatic) or >= 64, got {slots}")

    if ck.errors:
        raise SceneError("\n".join(text for _, text in sorted(ck.errors, key=lambda e: e[0])))
    mats = []
    walks = _walks(phase, effects)
    for i, (label, key, v) in enumerate(materials):
        c = v if key == "c" else (_c_of_kd(v, phase) if resolve_kd else math.nan)
        mats.append(Material(label=label, c=c, kd=v if key == "kd" else None))
        for walk in walks:
            why = _unbounded(walk, c)
            if why:
                ck.fail(("material", i, key), (f"kd = {v:g} needs " if key == "kd" else "") + why)
                break
    if ck.errors:
        raise SceneError("\n".join(text for _, text in sorted(ck.errors, key=lambda e: e[0])))
    return Scene(
        path=str(path), name=name, description=description, seed=int(seed), phase=phase, sampler=sampler,
        materials=tuple(mats), mu_i=mu_i, mu_edges=mu_edges, orders=orders, phi_edges=phi_edges,
        effects=effects, collision_orders=int(coll), target_se=target, max_paths=int(max_paths),
        batch=int(batch), max_collisions=int(max_coll), slots=int(slots),
    )


def load_scene(path, resolve_kd: bool = True) -> Scene:
    """Read and validate a scene file (.toml or .json); see :func:`parse_scene`."""
    p = Path(path)
    if p.suffix not in (".toml", ".json"):
        raise SceneError(f"{p}:1: (file): a scene is a .toml or .json file")
    try:  # a regular file of at most MAX_SCENE_BYTES, checked before it is opened: a FIFO never blocks
        text = read_regular_file(p, MAX_SCENE_BYTES).decode("utf-8")
    except InputFileError as exc:
        raise SceneError(f"{p}:1: (file): {exc.refusal('scene')}") from None
    except OSError as exc:
        raise SceneError(f"{p}:1: (file): cannot read: {exc.strerror}") from None
    except UnicodeDecodeError as exc:  # binary garbage: TOML and JSON are UTF-8 text
        raise SceneError(f"{p}:1: (file): not a UTF-8 text file (byte {exc.object[exc.start]:#04x} at offset "
                         f"{exc.start})") from None
    return parse_scene(text, str(p), resolve_kd=resolve_kd)
