r"""Scene files of the microsurface walk: TOML (parsed with tomllib, never evaluated), validated in
full before any simulation starts; every problem is one line ``file:line: field: what``, and all of
a file's problems come together in one :class:`SceneError`.

Example::

    [scene]
    name = "white_ggx"          # optional; default: the file stem; letters, digits, _ and - only
    description = "..."         # optional
    seed = 1                    # integer in [0, 2^63 - 1]

    [[material]]
    label = "white"             # optional; default "material<i>"
    kind = "conductor"          # "conductor" (mirror facets), "diffuse" (Lambertian facets) or "dielectric"
    distribution = "ggx"        # "ggx" or "beckmann" slopes
    alpha = 0.5                 # or alpha_x = 0.3 and alpha_y = 0.6 (anisotropic); each in [1e-3, 2]
    fresnel = "one"             # conductor: "one" (F = 1), "schlick" (with f0 in [0, 1]),
                                #   "conductor" (with eta in (0, 100], k in [0, 100]: eta + i k)
    # albedo = 0.8              # diffuse: the facets' albedo in [0, 1] (default 1)
    # eta = 1.5                 # dielectric: n_lower / n_upper in [1e-6, 100], not 1 (required); light
                                #   arrives from the upper medium; eta < 1 is light from inside a medium of
                                #   index 1 / eta (the walk's flip symmetry), so that case needs no option

    [incident]
    mu_i = [0.5, 0.9]           # cosines in (0, 1]

    [outgoing]
    mu_o = 8                    # mu_o bins: a count (equal bins on [0, 1]) or increasing edges in [0, 1]
    phi = 6                     # |phi_o| bins on [0, pi] (phi = pi: the mirror side): count or edges
    orders = 4                  # orders 1..orders tallied one by one, the rest together (1..64)
    transmission_lobe = true    # dielectrics: also the transmitted lobe, in (|mu_o|, |phi_o|) bins (default
                                #   true; false keeps only its totals by order); ignored by opaque facets

    [precision]
    target_se = 0.01            # or {lobe = 0.02, albedo = 2e-3}: lobe rows in 1/sr (f mu_o), albedos in 1
    max_paths = 1000000         # per job (material x mu_i), in [1000, 2^32]
    batch = 100000              # paths per round, in [100, 10^7]; the stopping rule is checked per round
    max_bounces = 1000          # scattering events after which a path is stopped and tallied as capped
    slots = 1024                # lanes of the vectorised walk per device, in [64, 2^20], or 0: 1024 on a
                                #   CPU, 65536 on an accelerator
"""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path

from fitlab._io import InputFileError, read_regular_file
from fitlab._montecarlo import MAX_PATHS, MIN_PATHS_BUDGET
from fitlab.families.microfacet_energy.microsurface.fresnel import FRESNEL
from fitlab.families.microfacet_energy.microsurface.microsurface import DISTRIBUTIONS
from fitlab.families.microfacet_energy.microsurface.walk import KINDS

__all__ = ["SceneError", "Material", "Scene", "parse_scene", "load_scene", "with_overrides", "LIMITS", "NAME_RE",
           "ALPHA_RANGE", "TARGETS"]

LIMITS = {
    "seed": (0, 2**63 - 1),
    "max_paths": (MIN_PATHS_BUDGET, MAX_PATHS),  # one rule for every family (fitlab._montecarlo)
    "batch": (100, 10**7),
    "max_bounces": (1, 10**6),
    "slots": (64, 2**20),
    "orders": (1, 64),
}
ALPHA_RANGE = (1e-3, 2.0)
#: the kinds of rows a standard-error target applies to
TARGETS = ("lobe", "albedo")
NAME_RE = re.compile(r"[A-Za-z0-9_-]{1,100}")
_KNOWN = {
    "": {"scene", "material", "incident", "outgoing", "precision"},
    "scene": {"name", "description", "seed"},
    "material": {"label", "kind", "distribution", "alpha", "alpha_x", "alpha_y", "fresnel", "f0", "eta", "k",
                 "albedo"},
    "incident": {"mu_i"},
    "outgoing": {"mu_o", "phi", "orders", "transmission_lobe"},
    "precision": {"target_se", "max_paths", "batch", "max_bounces", "slots"},
}


#: the largest scene file read, in bytes
MAX_SCENE_BYTES = 1_000_000


class SceneError(ValueError):
    """A malformed scene; the message lists every problem as file:line: field: what."""


@dataclass(frozen=True)
class Material:
    label: str
    kind: str
    distribution: str
    alpha_x: float
    alpha_y: float
    fresnel: str = "one"
    f0: float = 1.0
    eta: float = 1.0
    k: float = 0.0
    albedo: float = 1.0

    @property
    def isotropic(self) -> bool:
        return self.alpha_x == self.alpha_y

    @property
    def lossless(self) -> bool:
        """Whether every scattering keeps the weight and reflects (F = 1 conductor, albedo-1 diffuse facets):
        the reflected albedo of all orders is 1."""
        return (self.kind == "conductor" and self.fresnel == "one") or (self.kind == "diffuse" and self.albedo == 1.0)

    @property
    def conserves_energy(self) -> bool:
        """Whether reflection and transmission of all orders add up to 1 (lossless, or a dielectric)."""
        return self.lossless or self.kind == "dielectric"


@dataclass(frozen=True)
class Scene:
    path: str
    name: str
    description: str
    seed: int
    materials: tuple
    mu_i: tuple
    mu_edges: tuple
    phi_edges: tuple
    orders: int
    target_se: dict = field(hash=False)
    max_paths: int = 1_000_000
    batch: int = 100_000
    max_bounces: int = 1000
    slots: int = 1024
    transmission_lobe: bool = True


def _line_index(text: str) -> dict:
    """(table, index, key) -> line, from a light scan of the TOML text (tomllib gives no positions):
    table headers, [[material]] headers counted from 0, and ``key =`` lines; used for messages only."""
    lines, table, index, counts = {}, "", None, {}
    for no, raw in enumerate(text.splitlines(), start=1):
        s = raw.strip()
        m = re.match(r"^\[\[\s*([A-Za-z0-9_-]+)\s*\]\]", s)
        if m:
            table = m.group(1)
            index = counts.get(table, 0)
            counts[table] = index + 1
            lines.setdefault((table, index, None), no)
            continue
        m = re.match(r"^\[\s*([A-Za-z0-9_-]+)\s*\]", s)
        if m:
            table, index = m.group(1), None
            lines.setdefault((table, None, None), no)
            continue
        m = re.match(r"^([A-Za-z0-9_-]+)\s*=", s)
        if m:
            lines.setdefault((table, index, m.group(1)), no)
    return lines


class _Checker:
    def __init__(self, path: str, text: str):
        self.path, self.lines, self.errors = path, _line_index(text), []

    def fail(self, table: str, index, key, msg: str):
        line = self.lines.get((table, index, key)) or self.lines.get((table, index, None)) or 1
        name = table + (f"[{index}]" if index is not None else "") + (f".{key}" if key else "")
        self.errors.append((line, f"{self.path}:{line}: {name or '(top level)'}: {msg}"))

    def number(self, d, table, index, key, lo, hi, default=None, integer=False):
        if key not in d:
            if default is None:
                self.fail(table, index, key, "missing")
            return default
        v = d[key]
        ok = isinstance(v, int) if integer else isinstance(v, (int, float))
        if isinstance(v, bool) or not ok:
            self.fail(table, index, key, f"expected {'an integer' if integer else 'a number'}, got {v!r}")
            return None
        if isinstance(v, float) and not math.isfinite(v):
            self.fail(table, index, key, f"{v!r} is not a finite number")
            return None
        if not lo <= v <= hi:
            fmt = "d" if integer else "g"
            self.fail(table, index, key, f"{v!r} is outside [{lo:{fmt}}, {hi:{fmt}}]")
            return None
        return v

    def choice(self, d, table, index, key, options, default):
        v = d.get(key, default)
        if v not in options:
            self.fail(table, index, key, f"expected one of {list(options)}, got {v!r}")
            return None
        return v

    def unknown(self, d, table, index, known):
        for k in d:
            if k not in known:
                self.fail(table, index, k, f"unknown field (known here: {', '.join(sorted(known))})")


def _edges(ck: _Checker, d, key, hi: float, default: int, what: str):
    """Bin edges from a count n (equal bins on [0, hi]) or a strictly increasing list in [0, hi]."""
    v = d.get(key, default)
    if isinstance(v, int) and not isinstance(v, bool):
        if not 1 <= v <= 1000:
            ck.fail("outgoing", None, key, f"number of {what} bins must lie in [1, 1000], got {v}")
            return None
        return tuple(hi * j / v for j in range(v + 1))
    if not isinstance(v, list) or len(v) < 2:
        ck.fail("outgoing", None, key, f"expected a number of bins or a list of >= 2 edges, got {v!r}")
        return None
    for x in v:
        if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x) or not 0.0 <= x <= hi:
            ck.fail("outgoing", None, key, f"bin edge {x!r} is not a number in [0, {hi:g}]")
            return None
    if any(b <= a for a, b in zip(v[:-1], v[1:])):
        ck.fail("outgoing", None, key, f"bin edges must increase strictly, got {v}")
        return None
    return tuple(float(x) for x in v)


def _material(ck: _Checker, m, i: int):
    if not isinstance(m, dict):
        ck.fail("material", i, None, f"expected a table, got {m!r}")
        return None
    ck.unknown(m, "material", i, _KNOWN["material"])
    label = m.get("label", f"material{i}")
    if not isinstance(label, str) or not label:
        ck.fail("material", i, "label", "expected a non-empty string")
    kind = ck.choice(m, "material", i, "kind", KINDS, None)
    dist = ck.choice(m, "material", i, "distribution", DISTRIBUTIONS, None)
    lo, hi = ALPHA_RANGE
    if "alpha" in m:
        if "alpha_x" in m or "alpha_y" in m:
            ck.fail("material", i, "alpha", "give alpha, or alpha_x and alpha_y, not both")
            return None
        ax = ay = ck.number(m, "material", i, "alpha", lo, hi)
    elif "alpha_x" in m or "alpha_y" in m:
        ax = ck.number(m, "material", i, "alpha_x", lo, hi)
        ay = ck.number(m, "material", i, "alpha_y", lo, hi)
    else:
        ck.fail("material", i, "alpha", "missing: give alpha (isotropic) or alpha_x and alpha_y")
        return None
    fres = ck.choice(m, "material", i, "fresnel", FRESNEL, "one")
    params = {}
    wanted = {"schlick": ("f0",), "conductor": ("eta", "k")}.get(fres, ()) if kind == "conductor" else ()
    if kind == "diffuse":
        wanted = ("albedo",)
        if "fresnel" in m:
            ck.fail("material", i, "fresnel", "a diffuse facet has no Fresnel factor (give albedo)")
    if kind == "dielectric":
        wanted = ("eta",)
        if "fresnel" in m:
            ck.fail("material", i, "fresnel", "a dielectric's Fresnel factor is the exact one of its eta (give eta)")
    ranges = {"f0": (0.0, 1.0), "eta": (1e-6, 100.0), "k": (0.0, 100.0), "albedo": (0.0, 1.0)}
    for key in ("f0", "eta", "k", "albedo"):
        if key in wanted:
            params[key] = ck.number(m, "material", i, key, *ranges[key], default=1.0 if key == "albedo" else None)
            if kind == "dielectric" and key == "eta" and params[key] == 1.0:
                ck.fail("material", i, key, "eta = 1 is no interface (every path passes straight through, the "
                                            "transmitted lobe is a delta): give eta != 1")
                params[key] = None
        elif key in m:
            ck.fail("material", i, key, f"not used by kind = {kind!r}" + (f" with fresnel = {fres!r}"
                                                                           if kind == "conductor" else ""))
    if None in (kind, dist, ax, ay, fres) or None in params.values() or not isinstance(label, str):
        return None
    return Material(label=label, kind=kind, distribution=dist, alpha_x=float(ax), alpha_y=float(ay),
                    fresnel=fres if kind == "conductor" else "one", **{k: float(v) for k, v in params.items()})


def parse_scene(text: str, path: str = "<scene>") -> Scene:
    """Parse and validate TOML scene text; raises :class:`SceneError` listing every problem."""
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        m = re.search(r"at line (\d+)", str(exc))
        raise SceneError(f"{path}:{m.group(1) if m else 1}: not valid TOML: {exc}") from None
    ck = _Checker(str(path), text)
    ck.unknown(raw, "", None, _KNOWN[""])
    sec = {}
    for name in ("scene", "incident", "outgoing", "precision"):
        v = raw.get(name, {})
        if not isinstance(v, dict):
            ck.fail(name, None, None, f"expected a table, got {v!r}")
            v = {}
        ck.unknown(v, name, None, _KNOWN[name])
        sec[name] = v
    sc, inc, out, prec = sec["scene"], sec["incident"], sec["outgoing"], sec["precision"]

    name = sc.get("name", Path(str(path)).stem)
    if not isinstance(name, str) or not NAME_RE.fullmatch(name):
        ck.fail("scene", None, "name", f"expected 1-100 letters, digits, '_' or '-', got {name!r}")
    description = sc.get("description", "")
    if not isinstance(description, str):
        ck.fail("scene", None, "description", "expected a string")
    seed = ck.number(sc, "scene", None, "seed", *LIMITS["seed"], default=0, integer=True)

    mats_raw = raw.get("material")
    materials = []
    if not isinstance(mats_raw, list) or not mats_raw:
        ck.fail("material", None, None, "expected at least one [[material]]")
    else:
        for i, m in enumerate(mats_raw):
            mat = _material(ck, m, i)
            if mat is not None:
                materials.append(mat)
        labels = [m.label for m in materials]
        if len(set(labels)) != len(labels):
            ck.fail("material", None, None, f"material labels must differ, got {labels}")

    mu_i = ()
    v = inc.get("mu_i")
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        v = [v]
    if not isinstance(v, list) or not v:
        ck.fail("incident", None, "mu_i", f"expected a cosine or a list of cosines in (0, 1], got {v!r}")
    else:
        bad = [x for x in v if isinstance(x, bool) or not isinstance(x, (int, float)) or not 0.0 < x <= 1.0]
        if bad:
            ck.fail("incident", None, "mu_i", f"expected cosines in (0, 1], got {bad[0]!r}")
        elif len(set(v)) != len(v):
            ck.fail("incident", None, "mu_i", "a cosine is listed twice")
        else:
            mu_i = tuple(float(x) for x in v)

    mu_edges = _edges(ck, out, "mu_o", 1.0, 8, "mu_o")
    phi_edges = _edges(ck, out, "phi", math.pi, 6, "|phi_o|")
    orders = ck.number(out, "outgoing", None, "orders", *LIMITS["orders"], default=4, integer=True)
    transmission_lobe = out.get("transmission_lobe", True)
    if not isinstance(transmission_lobe, bool):
        ck.fail("outgoing", None, "transmission_lobe", f"expected true or false, got {transmission_lobe!r}")

    tse = prec.get("target_se")
    target = {}
    if tse is None:
        ck.fail("precision", None, "target_se", "missing: the standard error at which a job stops")
    elif isinstance(tse, dict):
        for k, x in tse.items():
            if k not in TARGETS:
                ck.fail("precision", None, "target_se", f"unknown row kind {k!r} (known: {', '.join(TARGETS)})")
            elif isinstance(x, bool) or not isinstance(x, (int, float)) or not 0 < x < math.inf:
                ck.fail("precision", None, "target_se", f"{k}: expected a positive finite number, got {x!r}")
            else:
                target[k] = float(x)
        for k in TARGETS:
            if k not in tse:
                ck.fail("precision", None, "target_se", f"no target for {k!r} rows")
    elif isinstance(tse, bool) or not isinstance(tse, (int, float)) or not 0 < tse < math.inf:
        ck.fail("precision", None, "target_se", f"expected a positive finite number or a table, got {tse!r}")
    else:
        target = {k: float(tse) for k in TARGETS}
    nums = {}
    for key, default in (("max_paths", 1_000_000), ("batch", 100_000), ("max_bounces", 1000), ("slots", 1024)):
        if key == "slots" and type(prec.get(key)) is int and prec[key] == 0:
            nums[key] = 0  # automatic: the walk's default for the platform
            continue
        nums[key] = ck.number(prec, "precision", None, key, *LIMITS[key], default=default, integer=True)

    if ck.errors:
        raise SceneError("\n".join(t for _, t in sorted(ck.errors, key=lambda e: e[0])))
    return Scene(path=str(path), name=name, description=description, seed=int(seed), materials=tuple(materials),
                 mu_i=mu_i, mu_edges=mu_edges, phi_edges=phi_edges, orders=int(orders), target_se=target,
                 transmission_lobe=transmission_lobe, **{k: int(v) for k, v in nums.items()})


def load_scene(path) -> Scene:
    """Read and validate a .toml scene file; see :func:`parse_scene`."""
    p = Path(path)
    if p.suffix != ".toml":
        raise SceneError(f"{p}:1: (file): a microsurface scene is a .toml file")
    try:  # a regular file of at most MAX_SCENE_BYTES, checked before it is opened: a FIFO never blocks
        text = read_regular_file(p, MAX_SCENE_BYTES).decode("utf-8")
    except InputFileError as exc:
        raise SceneError(f"{p}:1: (file): {exc.refusal('scene')}") from None
    except OSError as exc:
        raise SceneError(f"{p}:1: (file): cannot read: {exc}") from None
    except UnicodeDecodeError as exc:  # binary garbage: TOML is UTF-8 text
        raise SceneError(f"{p}:1: (file): not a UTF-8 text file (byte {exc.object[exc.start]:#04x} at offset "
                         f"{exc.start})") from None
    return parse_scene(text, str(p))


def with_overrides(scene: Scene, target_se=None, max_paths=None, seed=None) -> Scene:
    """The scene with command-line overrides (None: keep), each checked by the scene file's rule
    (strings are parsed); raises a one-line-per-problem SceneError."""
    changes, errors = {}, []
    for name, value in (("target_se", target_se), ("max_paths", max_paths), ("seed", seed)):
        if value is None:
            continue
        flag = "--" + name.replace("_", "-")
        v = value
        if isinstance(v, str):
            try:
                v = float(v.strip()) if name == "target_se" else int(v.strip())
            except ValueError:
                v = None
        if name == "target_se":
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 < v < math.inf:
                errors.append(f"{flag}: expected a positive finite number, got {value!r}")
            else:
                changes[name] = {k: float(v) for k in TARGETS}
        else:
            lo, hi = LIMITS[name]
            if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
                errors.append(f"{flag}: expected an integer in [{lo}, {hi}], got {value!r}")
            else:
                changes[name] = v
    if errors:
        raise SceneError("\n".join(errors))
    return replace(scene, **changes) if changes else scene
