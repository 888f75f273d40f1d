r"""Scene files of the microsurface walk: the schema (fields and rules) that the shared loader
:mod:`fitlab.scenes` applies to a TOML file (parsed with tomllib, never evaluated), in full, before any
simulation starts; every problem is one line ``file:line: field: what``, and all of a file's problems
come together in one :class:`SceneError`.

Details: docs/microsurface.md, section ``fitlab.families.microfacet_energy.mc.scene``."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from fitlab import scenes
from fitlab._montecarlo import MAX_PATHS, MIN_PATHS_BUDGET, PRECISIONS
from fitlab.families.microfacet_energy.mc.microsurface import DISTRIBUTIONS
from fitlab.families.microfacet_energy.mc.walk import KINDS
from fitlab.families.microfacet_energy.mc.walk_fresnel import FRESNEL
from fitlab.scenes import MAX_SCENE_BYTES, NAME_RE, SceneError  # noqa: F401 - re-exported: this module's names

__all__ = [
    "SceneError",
    "Material",
    "Scene",
    "SceneSchema",
    "SCHEMA",
    "parse_scene",
    "load_scene",
    "with_overrides",
    "LIMITS",
    "NAME_RE",
    "ALPHA_RANGE",
    "TARGETS",
]

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
_KNOWN = {
    "": {"scene", "material", "incident", "outgoing", "precision"},
    "scene": {"name", "description", "seed"},
    "material": {"label", "kind", "distribution", "alpha", "alpha_x", "alpha_y", "fresnel", "f0", "eta", "k", "albedo"},
    "incident": {"mu_i"},
    "outgoing": {"mu_o", "phi", "orders", "transmission_lobe"},
    "precision": {"target_se", "max_paths", "batch", "max_bounces", "slots", "float"},
}


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
    walk_precision: str = "float32"  # [precision] float: the walk's path state (fitlab._montecarlo.PRECISIONS)


def _material(ck: scenes.Checker, m, i: int):
    kp = ("material", i)
    if not isinstance(m, dict):
        ck.fail(kp, f"expected a table, got {m!r}")
        return None
    ck.unknown(m, kp, _KNOWN["material"])
    label = m.get("label", f"material{i}")
    if not isinstance(label, str) or not label:
        ck.fail(kp + ("label",), "expected a non-empty string")
    kind = ck.choice(m, kp + ("kind",), KINDS, None)
    dist = ck.choice(m, kp + ("distribution",), DISTRIBUTIONS, None)
    lo, hi = ALPHA_RANGE
    if "alpha" in m:
        if "alpha_x" in m or "alpha_y" in m:
            ck.fail(kp + ("alpha",), "give alpha, or alpha_x and alpha_y, not both")
            return None
        ax = ay = ck.number(m, kp + ("alpha",), lo, hi)
    elif "alpha_x" in m or "alpha_y" in m:
        ax = ck.number(m, kp + ("alpha_x",), lo, hi)
        ay = ck.number(m, kp + ("alpha_y",), lo, hi)
    else:
        ck.fail(kp + ("alpha",), "missing: give alpha (isotropic) or alpha_x and alpha_y")
        return None
    fres = ck.choice(m, kp + ("fresnel",), FRESNEL, "one")
    params = {}
    wanted = {"schlick": ("f0",), "conductor": ("eta", "k")}.get(fres, ()) if kind == "conductor" else ()
    if kind == "diffuse":
        wanted = ("albedo",)
        if "fresnel" in m:
            ck.fail(kp + ("fresnel",), "a diffuse facet has no Fresnel factor (give albedo)")
    if kind == "dielectric":
        wanted = ("eta",)
        if "fresnel" in m:
            ck.fail(kp + ("fresnel",), "a dielectric's Fresnel factor is the exact one of its eta (give eta)")
    ranges = {"f0": (0.0, 1.0), "eta": (1e-6, 100.0), "k": (0.0, 100.0), "albedo": (0.0, 1.0)}
    for key in ("f0", "eta", "k", "albedo"):
        if key in wanted:
            params[key] = ck.number(m, kp + (key,), *ranges[key], default=1.0 if key == "albedo" else None)
            if kind == "dielectric" and key == "eta" and params[key] == 1.0:
                ck.fail(
                    kp + (key,),
                    "eta = 1 is no interface (every path passes straight through, the "
                    "transmitted lobe is a delta): give eta != 1",
                )
                params[key] = None
        elif key in m:
            ck.fail(
                kp + (key,),
                f"not used by kind = {kind!r}" + (f" with fresnel = {fres!r}" if kind == "conductor" else ""),
            )
    if None in (kind, dist, ax, ay, fres) or None in params.values() or not isinstance(label, str):
        return None
    return Material(
        label=label,
        kind=kind,
        distribution=dist,
        alpha_x=float(ax),
        alpha_y=float(ay),
        fresnel=fres if kind == "conductor" else "one",
        **{k: float(v) for k, v in params.items()},
    )


def _mu_i(ck: scenes.Checker, inc) -> tuple:
    v = inc.get("mu_i")
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        v = [v]
    if not isinstance(v, list) or not v:
        ck.fail(("incident", "mu_i"), f"expected a cosine or a list of cosines in (0, 1], got {v!r}")
        return ()
    bad = [x for x in v if isinstance(x, bool) or not isinstance(x, (int, float)) or not 0.0 < x <= 1.0]
    if bad:
        ck.fail(("incident", "mu_i"), f"expected cosines in (0, 1], got {bad[0]!r}")
    elif len(set(v)) != len(v):
        ck.fail(("incident", "mu_i"), "a cosine is listed twice")
    else:
        return tuple(float(x) for x in v)
    return ()


def _targets(ck: scenes.Checker, prec) -> dict:
    return ck.per_key(
        prec, ("precision", "target_se"), TARGETS, TARGETS, "row kind", "the standard error at which a job stops"
    )


class SceneSchema:
    """The microsurface walk's scene files (a :class:`fitlab.scenes.SceneSchema`)."""

    family = "microfacet_energy"
    noun = "microsurface scene"
    suffixes = (".toml",)
    limits = LIMITS

    def target_keys(self, scene: Scene):
        return TARGETS

    def parse(self, raw: dict, ck: scenes.Checker) -> Scene:
        ck.unknown(raw, (), _KNOWN[""])
        sc, inc, out, prec = (ck.table(raw, (k,), _KNOWN[k]) for k in ("scene", "incident", "outgoing", "precision"))
        name = ck.name(sc, ("scene", "name"))
        description = sc.get("description", "")
        if not isinstance(description, str):
            ck.fail(("scene", "description"), "expected a string")
        seed = ck.number(sc, ("scene", "seed"), *LIMITS["seed"], default=0, integer=True)

        mats_raw = raw.get("material")
        materials = []
        if not isinstance(mats_raw, list) or not mats_raw:
            ck.fail(("material",), "expected at least one [[material]]")
        else:
            for i, m in enumerate(mats_raw):
                mat = _material(ck, m, i)
                if mat is not None:
                    materials.append(mat)
            labels = [m.label for m in materials]
            if len(set(labels)) != len(labels):
                ck.fail(("material",), f"material labels must differ, got {labels}")

        mu_i = _mu_i(ck, inc)
        mu_edges = ck.edges(out.get("mu_o", 8), ("outgoing", "mu_o"), 1.0, "mu_o")
        phi_edges = ck.edges(out.get("phi", 6), ("outgoing", "phi"), math.pi, "|phi_o|")
        orders = ck.number(out, ("outgoing", "orders"), *LIMITS["orders"], default=4, integer=True)
        transmission_lobe = out.get("transmission_lobe", True)
        if not isinstance(transmission_lobe, bool):
            ck.fail(("outgoing", "transmission_lobe"), f"expected true or false, got {transmission_lobe!r}")

        target = _targets(ck, prec)
        nums = {}
        for key, default in (("max_paths", 1_000_000), ("batch", 100_000), ("max_bounces", 1000), ("slots", 1024)):
            if key == "slots" and type(prec.get(key)) is int and prec[key] == 0:
                nums[key] = 0  # automatic: the walk's default for the platform
                continue
            nums[key] = ck.number(prec, ("precision", key), *LIMITS[key], default=default, integer=True)

        walk_float = ck.choice(prec, ("precision", "float"), PRECISIONS, "float32")

        ck.raise_errors()
        return Scene(
            path=ck.path,
            name=name,
            description=description,
            seed=int(seed),
            materials=tuple(materials),
            mu_i=mu_i,
            mu_edges=mu_edges,
            phi_edges=phi_edges,
            orders=int(orders),
            target_se=target,
            transmission_lobe=transmission_lobe,
            walk_precision=walk_float,
            **{k: int(v) for k, v in nums.items()},
        )


SCHEMA = SceneSchema()


def parse_scene(text: str, path: str = "<scene>") -> Scene:
    """Parse and validate TOML scene text; raises :class:`SceneError` listing every problem."""
    return scenes.parse_scene(SCHEMA, text, path, "toml")


def load_scene(path) -> Scene:
    """Read and validate a .toml scene file; see :func:`parse_scene`."""
    return scenes.load_scene(SCHEMA, path)


def with_overrides(scene: Scene, target_se=None, max_paths=None, seed=None) -> Scene:
    """The scene with command-line overrides (None: keep), each checked by the scene file's rule
    (strings are parsed); raises a one-line-per-problem SceneError."""
    return scenes.scene_with_overrides(SCHEMA, scene, target_se=target_se, max_paths=max_paths, seed=seed)
