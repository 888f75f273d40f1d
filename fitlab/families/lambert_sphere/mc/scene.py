r"""Scene files of the Lambert sphere's Monte Carlo: the schema (fields and rules) that the shared loader
:mod:`fitlab.scenes` applies to a TOML or JSON file, in full, before any simulation starts.

Details: docs/montecarlo.md, section ``fitlab.families.lambert_sphere.mc.scene``."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from fitlab import scenes
from fitlab._montecarlo import MAX_PATHS, MIN_PATHS_BUDGET, PRECISIONS
from fitlab.core import get_form
from fitlab.families.lambert_sphere.exact import albedo_inverse
from fitlab.scenes import MAX_SCENE_BYTES, NAME_RE, SceneError  # noqa: F401 - re-exported: this module's names

__all__ = [
    "EFFECTS",
    "LIMITS",
    "NAME_RE",
    "SCHEMA",
    "Material",
    "Scene",
    "SceneError",
    "SceneSchema",
    "check_option",
    "load_scene",
    "parse_scene",
    "with_overrides",
]

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
_KNOWN = {
    (): {"scene", "material", "incident", "outgoing", "effects", "precision"},
    ("scene",): {"name", "description", "seed", "phase", "sampler"},
    ("material",): {"c", "kd", "label"},
    ("incident",): {"mu_i"},
    ("outgoing",): {"mu_o", "fourier", "phi"},
    ("effects",): {"list", "collision_orders"},
    ("precision",): {"target_se", "max_paths", "batch", "max_collisions", "slots", "float"},
}


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
    walk_precision: str = "float32"  # [precision] float: the walk's path state (fitlab._montecarlo.PRECISIONS)


def _c_of_kd(kd: float, phase: str) -> float:
    """c whose exact spherical albedo is kd, in the half space the scene walks (the three-term one, or the true
    one: the whole phase function in every collision): :func:`fitlab.families.lambert_sphere.exact.albedo_inverse`
    with that phase, bracketed around the published eq. 39 map (the ``paper`` preset of the c_of_kd form
    ``rational_power``)."""

    guess = float(get_form("c_of_kd", "rational_power")("paper", np.asarray(float(kd)))) if 0.0 < kd <= 1.0 else None
    return albedo_inverse(kd, guess=guess, phase="three_term" if phase == "three_term" else "true")


def _walks(phase: str, effects) -> tuple:
    """The walk phases (transport.WalkConfig.phase) a scene's effects run."""
    out = []
    if any(e in effects for e in ("multiple", "collisions", "albedo", "spherical_albedo")):
        out.append(phase)
    if "phase_difference" in effects:
        out.append("both")
    return tuple(out)


def _unbounded(walk: str, c: float):
    from fitlab.families.lambert_sphere.mc.phase_sampling import unbounded_reason  # JAX, only when a scene is checked

    return unbounded_reason(walk, c)


def _effects(ck, eff) -> tuple:
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
    return tuple(e for e in effects if e in EFFECTS)


def _materials(ck, raw) -> list:
    """(label, "c" or "kd", value) of each valid material."""
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
    return materials


def _directions(ck, inc, out, effects) -> tuple:
    """(mu_i, mu_edges, orders, phi_edges)."""
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
        ck.fail(
            ("incident", "mu_i"),
            "missing: the effects "
            + ", ".join(e for e in effects if e not in ("spherical_albedo",))
            + " need incident directions",
        )
    mu_edges = ck.edges(out["mu_o"], ("outgoing", "mu_o"), 1.0, "mu_o") if "mu_o" in out else ()
    orders = ()
    if "fourier" in out:
        v = out["fourier"]
        if (
            not isinstance(v, list)
            or not v
            or any(isinstance(m, bool) or not isinstance(m, int) or not 0 <= m <= 16 for m in v)
        ):
            ck.fail(("outgoing", "fourier"), f"expected a list of Fourier orders m in 0..16, got {v!r}")
        elif len(set(v)) != len(v):
            ck.fail(("outgoing", "fourier"), "an order is listed twice")
        else:
            orders = tuple(v)
    phi_edges = ck.edges(out["phi"], ("outgoing", "phi"), math.pi, "phi") if "phi" in out else ()
    for e in ("single", "multiple", "phase_difference"):
        if e in effects:
            if not mu_edges and "mu_o" not in out:
                ck.fail(("outgoing", "mu_o"), f"missing: effect {e!r} needs mu_o bins")
            elif not (orders or phi_edges) and "fourier" not in out and "phi" not in out:
                ck.fail(("outgoing",), f"effect {e!r} needs fourier = [orders] or phi = bins")
    if (orders or phi_edges) and not mu_edges and "mu_o" not in out:
        ck.fail(("outgoing", "mu_o"), "fourier/phi tallies need mu_o bins")
    return mu_i, mu_edges, orders, phi_edges


def _targets(ck, prec, effects) -> dict:
    # a table needs no target for single scattering, which is computed, not simulated
    return ck.per_key(
        prec,
        ("precision", "target_se"),
        tuple(EFFECTS),
        [e for e in effects if e != "single"],
        "effect",
        "the standard error at which each tally stops",
        every=effects,
    )


class SceneSchema:
    """The Lambert sphere's scene files (a :class:`fitlab.scenes.SceneSchema`)."""

    family = "lambert_sphere"
    noun = "scene"
    suffixes = (".toml", ".json")
    limits = LIMITS

    def target_keys(self, scene: Scene):
        return scene.effects

    def parse(self, raw: dict, ck: scenes.Checker, resolve_kd: bool = True) -> Scene:
        ck.non_finite()
        ck.raise_errors()  # NaN/inf anywhere: refused before any other check reads the value
        ck.unknown(raw, (), _KNOWN[()])
        sc, inc, out, eff, prec = (
            ck.table(raw, (k,), _KNOWN[(k,)]) for k in ("scene", "incident", "outgoing", "effects", "precision")
        )
        name = ck.name(sc, ("scene", "name"))
        description = sc.get("description", "")
        if not isinstance(description, str):
            ck.fail(("scene", "description"), "expected a string")
        seed = ck.number(sc, ("scene", "seed"), *LIMITS["seed"], default=0, integer=True)
        phase = ck.choice(sc, ("scene", "phase"), PHASES, "three_term")
        sampler = ck.choice(sc, ("scene", "sampler"), SAMPLERS, "exact")

        effects = _effects(ck, eff)
        coll = ck.number(eff, ("effects", "collision_orders"), 2, 1000, default=6, integer=True)
        if "collision_orders" in eff and "collisions" not in effects:
            ck.fail(("effects", "collision_orders"), "given, but 'collisions' is not among the effects")
        if sampler == "approx" and phase != "true":
            ck.fail(("scene", "sampler"), "eq. 6 ('approx') samples the true phase function: set phase = \"true\"")
        if sampler == "approx" and "phase_difference" in effects:
            ck.fail(("scene", "sampler"), "phase_difference weighs paths by p/q and needs the exact sampler (eq. 5)")
        materials = _materials(ck, raw)
        mu_i, mu_edges, orders, phi_edges = _directions(ck, inc, out, effects)
        target = _targets(ck, prec, effects)
        num = {
            key: ck.number(prec, ("precision", key), *LIMITS[key], default=default, integer=True)
            for key, default in (
                ("max_paths", 2_000_000),
                ("batch", 100_000),
                ("max_collisions", 100_000),
                ("slots", 0),
            )
        }
        walk_float = ck.choice(prec, ("precision", "float"), PRECISIONS, "float32")
        if num["slots"] is not None and 0 < num["slots"] < 64:
            ck.fail(("precision", "slots"), f"photon slots per device: 0 (automatic) or >= 64, got {num['slots']}")
        ck.raise_errors()

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
        ck.raise_errors()
        return Scene(
            path=ck.path,
            name=name,
            description=description,
            seed=int(seed),
            phase=phase,
            sampler=sampler,
            materials=tuple(mats),
            mu_i=mu_i,
            mu_edges=mu_edges,
            orders=orders,
            phi_edges=phi_edges,
            effects=effects,
            collision_orders=int(coll),
            target_se=target,
            max_paths=int(num["max_paths"]),
            batch=int(num["batch"]),
            max_collisions=int(num["max_collisions"]),
            slots=int(num["slots"]),
            walk_precision=walk_float,
        )


SCHEMA = SceneSchema()


def check_option(name: str, value) -> int | float:
    """A command-line override (``seed``, ``max_paths`` or ``target_se``), by the
    scene file's own rule; a string is parsed first.  Raises a one-line SceneError."""
    return scenes.check_option(name, value, LIMITS)


def with_overrides(scene: Scene, target_se=None, max_paths=None, seed=None) -> Scene:
    """The scene with command-line overrides (None: keep), each checked by :func:`check_option`."""
    return scenes.scene_with_overrides(SCHEMA, scene, target_se=target_se, max_paths=max_paths, seed=seed)


def parse_scene(text: str, path: str = "<scene>", fmt: str | None = None, resolve_kd: bool = True) -> Scene:
    """Parse and validate scene text (format from ``fmt`` or the file suffix: toml or json).

    Materials given by kd get their c from the exact engine (``resolve_kd``;
    without it their c is NaN: enough to validate a scene, not to run it).
    """
    return scenes.parse_scene(SCHEMA, text, path, fmt, resolve_kd=resolve_kd)


def load_scene(path, resolve_kd: bool = True) -> Scene:
    """Read and validate a scene file (.toml or .json); see :func:`parse_scene`."""
    return scenes.load_scene(SCHEMA, path, resolve_kd=resolve_kd)
