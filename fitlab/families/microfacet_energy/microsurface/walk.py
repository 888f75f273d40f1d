r"""The jitted microsurface random walk (Heitz et al. 2016, section 4) and its tallies.

One path: light arrives from w_i = (sqrt(1 - mu_i^2), 0, mu_i), so the ray starts at the top of the
microsurface (h = 1, C1 = 1) travelling along -w_i with weight 1.  Repeat:

1. next height: h <- ``sample_height``(w, h, U) (:mod:`.microsurface`); if the ray escapes, it leaves
   with direction w after n scattering events (its order n >= 1: a falling ray always meets the
   surface) and is tallied;
2. else scatter (n <- n + 1): m from the visible normals of w_i' = -w (``sample_vndf``), then
   * conductor: w <- reflect(-w, m), weight *= F(w_i'.m) (:mod:`.fresnel`);
   * diffuse facets: w <- a cosine-distributed direction about m (Lambertian facet), weight *= albedo
     (the new w may point below the macro surface: step 1 takes it down).

The order-1 lobe is the single-scattering microfacet BRDF with the height-correlated Smith
masking-shadowing G2 = 1 / (1 + Lambda(w_i) + Lambda(w_o)) (paper, section 5; the tests check it).
A path still inside after ``max_bounces`` events is stopped and its weight tallied as ``capped``: the
cut tail is measured, never dropped.  With F = 1 every path's weight is 1, so the tallies of all
orders plus ``capped`` add up to the number of paths exactly (energy conservation, path by path).

Outgoing directions: mu_o = w_z, phi_o = |atan2(w_y, w_x)| in [0, pi] (phi = pi is the mirror
direction of w_i; the microsurface is symmetric under y -> -y, w_i lies in the xz-plane, so folding
the sign of phi loses nothing, for anisotropic alpha too).

Tallies (per round of paths; sums over paths of the weight w and of w^2, each path contributing once):

* ``lobe[k, i, j]`` (and ``lobe_sq``): escapes of order k + 1 (k = K: every order above K) in mu_o bin
  i and |phi_o| bin j; E[lobe / N] = int over the bin (both signs of phi) of f_k mu_o dw_o, so the
  bin average of f_k mu_o is lobe / (N Omega), Omega = 2 (mu_1 - mu_0)(phi_1 - phi_0).
* ``albedo[k]`` (``albedo_sq``): escapes of order k + 1 (k = K: above K) anywhere: the albedo by order.
* ``transmission[k]`` (``transmission_sq``): escapes through the bottom (none for the opaque
  materials here; kept for dielectrics).
* ``capped``, ``capped_sq``: weight of paths stopped at ``max_bounces``; ``paths``; ``bounces`` (the
  scattering events of all paths).

Random numbers are counter-based: the uniforms of path ``id`` at its event n are
``jax.random.uniform(fold_in(fold_in(job_key, id), n), (5,))``, job_key = fold_in(fold_in(key(seed),
material), incident).  A path depends only on (seed, material, incident, id), never on the slot, the
round or the batch that runs it, so any split of the ids into rounds gives the same paths (and tallies
equal up to the order of summation; exactly equal when the weights are 1).

Vectorisation: a pool of ``slots`` lanes runs one event per lane per loop iteration; a lane whose path
ended takes the next id at once, so lanes idle only at the end of a round.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from fitlab.core import float64
from fitlab.families.microfacet_energy.microsurface.fresnel import fresnel_factor
from fitlab.families.microfacet_energy.microsurface.microsurface import ESCAPED, reflect, sample_height, sample_vndf

__all__ = ["WalkConfig", "MaterialParams", "KINDS", "run_round", "compile_walk", "job_key", "TALLY_NAMES"]

KINDS = ("conductor", "diffuse")
TALLY_NAMES = ("lobe", "albedo", "transmission", "capped")
_UNIFORMS = 5


@dataclass(frozen=True)
class WalkConfig:
    """What is compiled: the slope distribution, the material kind and Fresnel form, the number of
    orders tallied one by one, the bin edges, and the lanes."""

    distribution: str = "ggx"
    kind: str = "conductor"
    fresnel: str = "one"
    orders: int = 4
    mu_edges: tuple = (0.0, 0.5, 1.0)
    phi_edges: tuple = (0.0, np.pi)
    slots: int = 1024


@dataclass(frozen=True)
class MaterialParams:
    """Run-time parameters: alpha_x, alpha_y > 0; f0 (schlick); eta, k (conductor); albedo (diffuse)."""

    alpha_x: float
    alpha_y: float
    f0: float = 1.0
    eta: float = 1.0
    k: float = 0.0
    albedo: float = 1.0


def _zero_tallies(cfg: WalkConfig) -> dict:
    nk = cfg.orders + 1
    shape = (nk, len(cfg.mu_edges), len(cfg.phi_edges))  # one extra row/column: outside every bin
    z = {}
    for name in ("lobe",):
        z[name], z[name + "_sq"] = jnp.zeros(shape), jnp.zeros(shape)
    for name in ("albedo", "transmission"):
        z[name], z[name + "_sq"] = jnp.zeros(nk), jnp.zeros(nk)
    z["capped"], z["capped_sq"] = jnp.zeros(()), jnp.zeros(())
    z["paths"], z["bounces"] = jnp.zeros((), jnp.int64), jnp.zeros((), jnp.int64)
    return z


def _bin(value, edges):
    """Index of the bin [e_i, e_i+1) holding value (the last bin closed), len(edges) - 1 outside."""
    e = jnp.asarray(edges)
    i = jnp.searchsorted(e, value, side="right") - 1
    i = jnp.where(value == e[-1], len(edges) - 2, i)
    outside = (value < e[0]) | (value > e[-1])
    return jnp.where(outside, len(edges) - 1, i)


def _cosine_about(mx, my, mz, u1, u2):
    """A direction with density cos/pi about the unit normal m (Malley: a uniform disk point lifted)."""
    r = jnp.sqrt(u1)
    ang = 2.0 * jnp.pi * u2
    a, b = r * jnp.cos(ang), r * jnp.sin(ang)
    c = jnp.sqrt(jnp.maximum(0.0, 1.0 - u1))
    # orthonormal basis about m (Duff et al. 2017, branchless)
    sign = jnp.where(mz >= 0.0, 1.0, -1.0)
    p = -1.0 / (sign + mz)
    q = mx * my * p
    t1 = (1.0 + sign * mx * mx * p, sign * q, -sign * mx)
    t2 = (q, sign + my * my * p, -my)
    x = a * t1[0] + b * t2[0] + c * mx
    y = a * t1[1] + b * t2[1] + c * my
    z = a * t1[2] + b * t2[2] + c * mz
    n = jnp.sqrt(x * x + y * y + z * z)
    return x / n, y / n, z / n


def _step(carry, key, params, mu_i, hi, cap, cfg: WalkConfig):
    (alive, pid, order, h, wx, wy, wz, weight), tallies, next_id = carry
    # refill: dead lanes take the next ids in lane order
    dead = ~alive
    rank = jnp.cumsum(dead.astype(jnp.int64)) - 1
    new_id = next_id + rank
    start = dead & (new_id < hi)
    n_started = jnp.sum(start.astype(jnp.int64))
    s_i = jnp.sqrt(jnp.maximum(0.0, 1.0 - mu_i * mu_i))
    pid = jnp.where(start, new_id, pid)
    order = jnp.where(start, 0, order)
    h = jnp.where(start, 1.0, h)
    wx, wy, wz = jnp.where(start, -s_i, wx), jnp.where(start, 0.0, wy), jnp.where(start, -mu_i, wz)
    weight = jnp.where(start, 1.0, weight)
    alive = alive | start

    u = jax.vmap(lambda i, n: jax.random.uniform(jax.random.fold_in(jax.random.fold_in(key, i), n), (_UNIFORMS,),
                                                 dtype=jnp.float64))(pid.astype(jnp.uint32), order.astype(jnp.uint32))
    # uniforms in (0, 1): jax's are in [0, 1); 0 would give log(0) in Beckmann's polar branch
    u = jnp.maximum(u, 2.0**-60)
    ax, ay = params.alpha_x, params.alpha_y
    h_next = sample_height(wx, wy, wz, h, u[:, 0], ax, ay, cfg.distribution)
    escaped = alive & (h_next == ESCAPED)
    capped = alive & ~escaped & (order >= cap)
    scatters = alive & ~escaped & ~capped

    # tallies of the paths that end here
    k = jnp.minimum(order, cfg.orders + 1) - 1  # order 1..K -> 0..K-1, above K -> K
    k = jnp.where(escaped, k, 0)
    w_up = jnp.where(escaped & (wz > 0.0), weight, 0.0)
    w_down = jnp.where(escaped & (wz <= 0.0), weight, 0.0)
    bi = _bin(wz, cfg.mu_edges)
    bj = _bin(jnp.abs(jnp.arctan2(wy, wx)), cfg.phi_edges)
    t = dict(tallies)
    t["lobe"] = t["lobe"].at[k, bi, bj].add(w_up)
    t["lobe_sq"] = t["lobe_sq"].at[k, bi, bj].add(w_up * w_up)
    t["albedo"] = t["albedo"].at[k].add(w_up)
    t["albedo_sq"] = t["albedo_sq"].at[k].add(w_up * w_up)
    t["transmission"] = t["transmission"].at[k].add(w_down)
    t["transmission_sq"] = t["transmission_sq"].at[k].add(w_down * w_down)
    w_cap = jnp.where(capped, weight, 0.0)
    t["capped"] = t["capped"] + jnp.sum(w_cap)
    t["capped_sq"] = t["capped_sq"] + jnp.sum(w_cap * w_cap)
    t["paths"] = t["paths"] + n_started
    t["bounces"] = t["bounces"] + jnp.sum(scatters.astype(jnp.int64))

    # scattering from the facet met at h_next
    vx, vy, vz = -wx, -wy, -wz
    mx, my, mz = sample_vndf(vx, vy, vz, u[:, 1], u[:, 2], ax, ay, cfg.distribution)
    if cfg.kind == "conductor":
        ox, oy, oz = reflect(vx, vy, vz, mx, my, mz)
        cos_d = jnp.clip(vx * mx + vy * my + vz * mz, 0.0, 1.0)
        factor = fresnel_factor(cfg.fresnel, cos_d, params.f0, params.eta, params.k)
    else:
        ox, oy, oz = _cosine_about(mx, my, mz, u[:, 3], u[:, 4])
        factor = params.albedo
    wx, wy, wz = jnp.where(scatters, ox, wx), jnp.where(scatters, oy, wy), jnp.where(scatters, oz, wz)
    weight = jnp.where(scatters, weight * factor, weight)
    h = jnp.where(scatters, h_next, h)
    order = jnp.where(scatters, order + 1, order)
    alive = scatters
    return (alive, pid, order, h, wx, wy, wz, weight), t, next_id + n_started


def _walk(key_data, params, mu_i, lo, hi, cap, cfg: WalkConfig):
    key = jax.random.wrap_key_data(key_data)
    p = cfg.slots
    lanes = (jnp.zeros(p, bool), jnp.zeros(p, jnp.int64), jnp.zeros(p, jnp.int64), jnp.ones(p), jnp.zeros(p),
             jnp.zeros(p), jnp.zeros(p), jnp.ones(p))
    carry = (lanes, _zero_tallies(cfg), lo)
    body = partial(_step, key=key, params=params, mu_i=mu_i, hi=hi, cap=cap, cfg=cfg)
    carry = jax.lax.while_loop(lambda c: (c[2] < hi) | jnp.any(c[0][0]), body, carry)
    return carry[1]


jax.tree_util.register_pytree_node(
    MaterialParams,
    lambda m: ((m.alpha_x, m.alpha_y, m.f0, m.eta, m.k, m.albedo), None),
    lambda _, c: MaterialParams(*c),
)

_COMPILED: dict = {}


@float64
def compile_walk(cfg: WalkConfig) -> float:
    """Compile the walk of ``cfg`` once (cached); returns the seconds it took (0 when cached)."""
    if cfg in _COMPILED:
        return 0.0
    t0 = time.perf_counter()
    f64 = jax.ShapeDtypeStruct((), jnp.float64)
    i64 = jax.ShapeDtypeStruct((), jnp.int64)
    params = MaterialParams(*(f64,) * 6)
    args = (jax.ShapeDtypeStruct((2,), jnp.uint32), params, f64, i64, i64, i64)
    _COMPILED[cfg] = jax.jit(partial(_walk, cfg=cfg)).lower(*args).compile()
    return time.perf_counter() - t0


@float64
def job_key(seed: int, material: int, incident: int) -> np.ndarray:
    """The Threefry key data (uint32[2]) of job (material, incident) under ``seed`` (0 <= seed < 2^63)."""
    key = jax.random.fold_in(jax.random.fold_in(jax.random.key(seed), material), incident)
    return np.asarray(jax.random.key_data(key))


@float64
def run_round(cfg: WalkConfig, key_data, params: MaterialParams, mu_i: float, first_id: int, n_paths: int,
              max_bounces: int = 1000) -> dict:
    """Run paths first_id .. first_id + n_paths - 1 of the job whose key is ``key_data``; tallies as numpy.

    mu_i in (0, 1]; alpha_x, alpha_y > 0; ids below 2^32; max_bounces >= 1.  The outside-every-bin
    row and column of ``lobe`` are removed."""
    if not 0.0 < mu_i <= 1.0:
        raise ValueError(f"mu_i must lie in (0, 1], got {mu_i}")
    if not (params.alpha_x > 0.0 and params.alpha_y > 0.0):
        raise ValueError("alpha_x and alpha_y must be positive")
    if first_id < 0 or n_paths < 1 or first_id + n_paths > 2**32:
        raise ValueError("path ids must lie in [0, 2^32)")
    if max_bounces < 1:
        raise ValueError("max_bounces must be >= 1")
    compile_walk(cfg)
    p = MaterialParams(*(jnp.float64(v) for v in (params.alpha_x, params.alpha_y, params.f0, params.eta, params.k,
                                                   params.albedo)))
    out = _COMPILED[cfg](jnp.asarray(key_data, jnp.uint32), p, jnp.float64(mu_i), jnp.int64(first_id),
                         jnp.int64(first_id + n_paths), jnp.int64(max_bounces))
    res = {k: np.asarray(v) for k, v in out.items()}
    for name in ("lobe", "lobe_sq"):
        res[name] = res[name][:, :-1, :-1]
    return res
