r"""The jitted microsurface random walk (Heitz et al. 2016, section 4) and its tallies.

One path: light arrives from w_i = (sqrt(1 - mu_i^2), 0, mu_i), so the ray starts at the top of the
microsurface (h = 1, C1 = 1) travelling along -w_i with weight 1.  Repeat:

1. next height: h <- ``sample_height``(w, h, U) (:mod:`.microsurface`); if the ray escapes, it leaves
   with direction w after n scattering events (its order n >= 1: a falling ray always meets the
   surface) and is tallied;
2. else scatter (n <- n + 1): m from the visible normals of w_i' = -w (``sample_vndf``), then
   * conductor: w <- reflect(-w, m), weight *= F(w_i'.m) (:mod:`..mc.walk_fresnel`);
   * diffuse facets: w <- a cosine-distributed direction about m (Lambertian facet), weight *= albedo
     (the new w may point below the macro surface: step 1 takes it down);
   * dielectric: with probability F(w_i'.m) (the exact dielectric Fresnel of the relative index of the
     side the ray is on, 1 under total internal reflection) w <- reflect(-w, m), else w <- the direction
     refracted through m and the ray changes side; the weight stays 1.

Details: docs/microsurface.md, section ``fitlab.families.microfacet_energy.mc.walk``."""

from __future__ import annotations

import time
from dataclasses import dataclass
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, PartitionSpec

from fitlab._montecarlo import (
    PRECISIONS,
    ChunkedRound,
    add_with_squares,
    azimuth_cosine,
    bin_index,
    block_words,
    device_local,
    device_stacked,
    sincos_2pi,
    threefry_blocks,
    uniforms,
)
from fitlab.core import float64
from fitlab.families.microfacet_energy.mc.microsurface import (
    DISTRIBUTIONS,
    ESCAPED,
    reflect,
    refract,
    sample_c1,
    sample_height,
    sample_vndf,
)
from fitlab.families.microfacet_energy.mc.walk_fresnel import FRESNEL, dielectric, fresnel_factor

__all__ = [
    "WalkConfig",
    "MaterialParams",
    "KINDS",
    "run_round",
    "start_round",
    "compile_walk",
    "job_key",
    "default_mesh",
    "default_slots",
    "TALLY_NAMES",
]

KINDS = ("conductor", "diffuse", "dielectric")
TALLY_NAMES = ("lobe", "lobe_transmission", "albedo", "transmission", "capped", "failed")
AXIS = "paths"
#: uniforms per event: the free path, the visible normal (2), then the kind's own (diffuse: a cosine
#: direction; dielectric: reflect or refract)
_UNIFORMS = {"conductor": 3, "diffuse": 5, "dielectric": 4}
_WORD_PAIRS = 3  # Threefry-2x32 blocks per event in the counter layout: room for 6 words


@dataclass(frozen=True)
class WalkConfig:
    """What is compiled: the slope distribution, the material kind and Fresnel form (conductors), the number
    of orders tallied one by one, the bin edges, the lanes per device (0: :func:`default_slots` of the
    platform), and whether the transmitted lobe is tallied (dielectrics)."""

    distribution: str = "ggx"
    kind: str = "conductor"
    fresnel: str = "one"
    orders: int = 4
    mu_edges: tuple = (0.0, 0.5, 1.0)
    phi_edges: tuple = (0.0, np.pi)
    slots: int = 1024
    transmission_lobe: bool = False
    precision: str = "float32"

    def __post_init__(self):
        if self.distribution not in DISTRIBUTIONS:
            raise ValueError(f"distribution must be one of {DISTRIBUTIONS}, got {self.distribution!r}")
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {KINDS}, got {self.kind!r}")
        if self.fresnel not in FRESNEL:
            raise ValueError(f"fresnel must be one of {FRESNEL}, got {self.fresnel!r}")
        if not (self.slots == 0 or self.slots >= 1):
            raise ValueError(f"slots must be 0 (automatic) or positive, got {self.slots}")
        if self.precision not in PRECISIONS:
            raise ValueError(f"precision must be one of {PRECISIONS}, got {self.precision!r}")
        if self.transmission_lobe and self.kind != "dielectric":
            raise ValueError("only a dielectric transmits: transmission_lobe needs kind='dielectric'")
        for name, edges in (("mu_edges", self.mu_edges), ("phi_edges", self.phi_edges)):
            e = np.asarray(edges, dtype=float)
            if e.size < 2 or np.any(np.diff(e) <= 0):
                raise ValueError(f"{name} must hold at least 2 strictly increasing edges")


@dataclass(frozen=True)
class MaterialParams:
    """Run-time parameters: alpha_x, alpha_y > 0; f0 (schlick); eta, k (conductor: eta + i k; dielectric:
    eta = n_lower / n_upper > 0); albedo (diffuse)."""

    alpha_x: float
    alpha_y: float
    f0: float = 1.0
    eta: float = 1.0
    k: float = 0.0
    albedo: float = 1.0


def _zero_tallies(cfg: WalkConfig) -> dict:
    nk = cfg.orders + 1
    sides = 2 if cfg.transmission_lobe else 1
    shape = (sides, nk, len(cfg.mu_edges), len(cfg.phi_edges))  # one extra row/column: outside every bin
    z = {
        "lobe": jnp.zeros(shape),
        "lobe_sq": jnp.zeros(shape),
        # [0]: escapes upwards (reflection), [1]: downwards (transmission), by order
        "exits": jnp.zeros((2, nk)),
        "exits_sq": jnp.zeros((2, nk)),
        "capped": jnp.zeros(()),
        "capped_sq": jnp.zeros(()),
    }
    z["paths"], z["bounces"], z["failed"] = (jnp.zeros((), jnp.int64) for _ in range(3))
    return z


def _phi_bin(x, y, edges):
    """The bin of |phi| = |atan2(y, x)| in [0, pi] among ``edges``, by cos |phi| = x / sqrt(x^2 + y^2)
    (no arctangent; cos = 1, phi = 0, straight up or down)."""
    return bin_index(azimuth_cosine(x, y), np.cos(np.asarray(edges, dtype=float)), decreasing=True)


def _cosine_about(mx, my, mz, u1, u2):
    """A direction with density cos/pi about the unit normal m (Malley: a uniform disk point lifted)."""
    r = jnp.sqrt(u1)
    sin_ang, cos_ang = sincos_2pi(u2)
    a, b = r * cos_ang, r * sin_ang
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


def _uniforms(blocks, count: int, dtype):
    """The first ``count`` uniforms in (0, 1) of a lane's event from its Threefry blocks
    (:func:`fitlab._montecarlo.threefry_blocks` of the counters (id, 3 n + j); docs/microsurface.md): numbers 2 j
    and 2 j + 1 are block j's two words.  A kind drawing fewer numbers hashes fewer blocks."""
    first, second = block_words(blocks)
    words = [w for pair in zip(first, second) for w in pair]
    return tuple(uniforms(w, dtype) for w in words[:count])


def _refill(lanes, t, next_id, key, mu_i, hi, cfg: WalkConfig):
    """Dead lanes take the next ids in lane order (a prefix sum) and start at the top along -w_i; then every
    lane's Threefry blocks for its next event are hashed, to be carried to the next step."""
    alive, pid, order, h, wx, wy, wz, weight, inside, _ = lanes
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
    inside = inside & ~start
    alive = alive | start
    pairs = (_UNIFORMS[cfg.kind] + 1) // 2
    blocks = threefry_blocks(key, pid, order.astype(jnp.uint32) * jnp.uint32(_WORD_PAIRS), pairs)
    t = dict(t)
    t["paths"] = t["paths"] + n_started
    return (alive, pid, order, h, wx, wy, wz, weight, inside, blocks), t, next_id + n_started


def _step(carry, key, params, mu_i, hi, cap, cfg: WalkConfig):
    # (h, w) are in the frame of the side the ray is on (docs/microsurface.md, "Dielectrics"); inside: below.
    # h is the height in float64, its C1 in float32 (docs/microsurface.md, "Heights"): 1 at the top in both
    (alive, pid, order, h, wx, wy, wz, weight, inside, blocks), tallies, next_id = carry
    u = _uniforms(blocks, _UNIFORMS[cfg.kind], h.dtype)
    ax, ay = params.alpha_x, params.alpha_y
    by_c1 = cfg.precision == "float32"
    h_next = (sample_c1 if by_c1 else sample_height)(wx, wy, wz, h, u[0], ax, ay, cfg.distribution)
    state_ok = ~jnp.isnan(h_next) & jnp.isfinite(wx) & jnp.isfinite(wy) & jnp.isfinite(wz) & jnp.isfinite(weight)
    failed = alive & ~state_ok  # ended, apart from capped paths, and never tallied as light
    escaped = alive & state_ok & (h_next == ESCAPED)
    capped = alive & state_ok & ~escaped & (order >= cap)
    scatters = alive & state_ok & ~escaped & ~capped

    # tallies of the paths that end here; an escape is always upwards in the frame of its side
    k = jnp.minimum(order, cfg.orders + 1) - 1  # order 1..K -> 0..K-1, above K -> K
    k = jnp.where(escaped, k, 0)
    side = inside.astype(jnp.int32)
    w_out = jnp.where(escaped, weight, 0.0).astype(jnp.float64)  # tallies add up in float64
    bi = bin_index(wz, cfg.mu_edges)  # |mu_o|
    if cfg.kind == "dielectric":  # physical azimuth: the inside frame is the point reflection of the outside
        bj = _phi_bin(jnp.where(inside, -wx, wx), wy, cfg.phi_edges)  # |phi| does not see the sign of y
    else:
        bj = _phi_bin(wx, wy, cfg.phi_edges)
    t = dict(tallies)
    if cfg.transmission_lobe:
        add_with_squares(t, "lobe", (side, k, bi, bj), w_out)
    else:
        add_with_squares(t, "lobe", (0, k, bi, bj), jnp.where(inside, 0.0, w_out))
    add_with_squares(t, "exits", (side, k), w_out)
    w_cap = jnp.where(capped, weight, 0.0).astype(jnp.float64)
    t["capped"] = t["capped"] + jnp.sum(w_cap)
    t["capped_sq"] = t["capped_sq"] + jnp.sum(w_cap * w_cap)
    t["bounces"] = t["bounces"] + jnp.sum(scatters.astype(jnp.int64))
    t["failed"] = t["failed"] + jnp.sum(failed.astype(jnp.int64))

    # scattering from the facet met at h_next
    vx, vy, vz = -wx, -wy, -wz
    mx, my, mz = sample_vndf(vx, vy, vz, u[1], u[2], ax, ay, cfg.distribution)
    h_out = h_next
    if cfg.kind == "conductor":
        ox, oy, oz = reflect(vx, vy, vz, mx, my, mz)
        cos_d = jnp.clip(vx * mx + vy * my + vz * mz, 0.0, 1.0)
        weight = jnp.where(
            scatters, weight * fresnel_factor(cfg.fresnel, cos_d, params.f0, params.eta, params.k), weight
        )
    elif cfg.kind == "diffuse":
        ox, oy, oz = _cosine_about(mx, my, mz, u[3], u[4])
        weight = jnp.where(scatters, weight * params.albedo, weight)
    else:  # dielectric: reflect with probability F, else refract and change side; the weight stays 1
        eta = jnp.where(inside, 1.0 / params.eta, params.eta)
        cos_d = jnp.clip(vx * mx + vy * my + vz * mz, 0.0, 1.0)
        reflects = u[3] < dielectric(cos_d, eta)
        rx, ry, rz = reflect(vx, vy, vz, mx, my, mz)
        tx, ty, tz = refract(vx, vy, vz, mx, my, mz, eta)
        ox, oy, oz = jnp.where(reflects, rx, -tx), jnp.where(reflects, ry, -ty), jnp.where(reflects, rz, -tz)
        h_out = jnp.where(reflects, h_next, (1.0 - h_next) if by_c1 else -h_next)
        inside = jnp.where(scatters, inside ^ ~reflects, inside)
    wx, wy, wz = jnp.where(scatters, ox, wx), jnp.where(scatters, oy, wy), jnp.where(scatters, oz, wz)
    h = jnp.where(scatters, h_out, h)
    order = jnp.where(scatters, order + 1, order)
    lanes = (scatters, pid, order, h, wx, wy, wz, weight, inside, blocks)
    return _refill(lanes, t, next_id, key, mu_i, hi, cfg)


def default_slots(platform: str) -> int:
    """Lanes per device when a configuration says 0: 1024 on a CPU (16384 ran 1.3x faster here on rounds of
    2e5 paths, 256 alike; fewer lanes drain sooner at the end of a round and keep scenes' small rounds
    busy), 65536 on an accelerator (whose thousands of threads want lanes to spare)."""
    return 1024 if platform == "cpu" else 65536


def _start(key_data, mu_i, lo, hi, cfg: WalkConfig, platform: str):
    """One device's walk of path ids [lo, hi) before its first step: every lane refilled."""
    key = jnp.asarray(key_data, jnp.uint32)
    p = cfg.slots or default_slots(platform)
    dt = jnp.dtype(cfg.precision)
    lanes = (
        jnp.zeros(p, bool),
        jnp.zeros(p, jnp.int64),
        jnp.zeros(p, jnp.int64),
        jnp.ones(p, dt),
        jnp.zeros(p, dt),
        jnp.zeros(p, dt),
        jnp.zeros(p, dt),
        jnp.ones(p, dt),
        jnp.zeros(p, bool),
        None,
    )
    return _refill(lanes, _zero_tallies(cfg), lo, key, mu_i.astype(dt), hi, cfg)


def _run(carry, key_data, params, mu_i, hi, cap, steps, cfg: WalkConfig):
    """At most ``steps`` steps of one device's walk; returns the carry and the status (all its paths ended, paths
    started, lanes alive)."""
    key = jnp.asarray(key_data, jnp.uint32)
    dt = jnp.dtype(cfg.precision)
    params = jax.tree_util.tree_map(lambda v: v.astype(dt), params)
    body = partial(_step, key=key, params=params, mu_i=mu_i.astype(dt), hi=hi, cap=cap, cfg=cfg)

    def going(c):
        return (c[2] < hi) | jnp.any(c[0][0])

    _, carry = jax.lax.while_loop(
        lambda st: (st[0] < steps) & going(st[1]),
        lambda st: (st[0] + 1, body(st[1])),
        (jnp.zeros((), jnp.int64), carry),
    )
    status = jnp.stack([(~going(carry)).astype(jnp.int64), carry[1]["paths"], jnp.sum(carry[0][0], dtype=jnp.int64)])
    return carry, status


def _programs(cfg: WalkConfig, mesh: Mesh) -> dict:
    """The walk's programs on ``mesh`` (jitted ``shard_map`` s; :class:`fitlab._montecarlo.ChunkedRound`): ``start``
    (device d takes the d-th contiguous slice of the ids), ``runs`` (one level) and ``finish`` (the tallies summed
    over the devices, ``psum``).  A device's state carries its lanes, tallies, next id and the end of its slice."""
    ndev, platform = mesh.size, mesh.devices.flat[0].platform
    rep, dev = PartitionSpec(), PartitionSpec(AXIS)

    def start(key_data, mu_i, lo, hi):
        d = jax.lax.axis_index(AXIS).astype(jnp.int64)
        per = (hi - lo + ndev - 1) // ndev
        a = jnp.minimum(lo + d * per, hi)
        b = jnp.minimum(a + per, hi)
        return device_stacked((_start(key_data, mu_i, a, b, cfg, platform), b))

    def run(state, key_data, params, mu_i, cap, steps):
        carry, b = device_local(state)
        carry, status = _run(carry, key_data, params, mu_i, b, cap, steps, cfg)
        return device_stacked((carry, b)), status[None]

    def finish(state):
        (_, tallies, _), _ = device_local(state)
        return jax.tree_util.tree_map(lambda x: jax.lax.psum(x, AXIS), tallies)

    def sharded(f, in_specs, out_specs):
        return jax.jit(jax.shard_map(f, mesh=mesh, in_specs=in_specs, out_specs=out_specs, check_vma=False))

    return {
        "start": sharded(start, (rep,) * 4, dev),
        "run": sharded(run, (dev,) + (rep,) * 5, (dev, dev)),
        "finish": sharded(finish, (dev,), rep),
    }


jax.tree_util.register_pytree_node(
    MaterialParams,
    lambda m: ((m.alpha_x, m.alpha_y, m.f0, m.eta, m.k, m.albedo), None),
    lambda _, c: MaterialParams(*c),
)


def default_mesh() -> Mesh:
    """A 1-D mesh over every device JAX sees (one device: sharding changes nothing)."""
    return Mesh(np.array(jax.devices()), (AXIS,))


_COMPILED: dict = {}


@float64
def compile_walk(cfg: WalkConfig, mesh: Mesh | None = None) -> float:
    """Compile the walk of ``cfg`` on ``mesh`` (default: :func:`default_mesh`) once (cached), by running a round of
    one path; returns the seconds it took (0 when cached)."""
    mesh = mesh or default_mesh()
    if (cfg, mesh) in _COMPILED:
        return 0.0
    t0 = time.perf_counter()
    _COMPILED[(cfg, mesh)] = _programs(cfg, mesh)
    _round(cfg, mesh, np.zeros(2, np.uint32), MaterialParams(0.5, 0.5, eta=1.5), 0.5, 0, 1, 2).run()
    return time.perf_counter() - t0


def _round(
    cfg: WalkConfig,
    mesh: Mesh,
    key_data,
    params: MaterialParams,
    mu_i: float,
    first_id: int,
    n_paths: int,
    max_bounces: int,
) -> ChunkedRound:
    programs = _COMPILED[(cfg, mesh)]
    key = jnp.asarray(key_data, jnp.uint32)
    p = MaterialParams(
        *(jnp.float64(v) for v in (params.alpha_x, params.alpha_y, params.f0, params.eta, params.k, params.albedo))
    )
    state = programs["start"](key, jnp.float64(mu_i), jnp.int64(first_id), jnp.int64(first_id + n_paths))

    def run(st, steps):
        return programs["run"](st, key, p, jnp.float64(mu_i), jnp.int64(max_bounces), jnp.int64(steps))

    return ChunkedRound(state, [run], [], programs["finish"], partial(_numpy_tallies, cfg))


def _numpy_tallies(cfg: WalkConfig, out: dict) -> dict:
    """The tallies as numpy, the outside-every-bin row and column of the lobes removed."""
    out = {k: np.asarray(v) for k, v in out.items()}
    res = {}
    for suffix in ("", "_sq"):
        lobe = out["lobe" + suffix][:, :, :-1, :-1]
        res["lobe" + suffix] = lobe[0]
        if cfg.transmission_lobe:
            res["lobe_transmission" + suffix] = lobe[1]
        res["albedo" + suffix], res["transmission" + suffix] = out["exits" + suffix][0], out["exits" + suffix][1]
        res["capped" + suffix] = out["capped" + suffix]
    res["paths"], res["bounces"], res["failed"] = out["paths"], out["bounces"], out["failed"]
    return res


@float64
def job_key(seed: int, material: int, incident: int) -> np.ndarray:
    """The Threefry key data (uint32[2]) of job (material, incident) under ``seed`` (0 <= seed < 2^63)."""
    key = jax.random.fold_in(jax.random.fold_in(jax.random.key(seed), material), incident)
    return np.asarray(jax.random.key_data(key))


@float64
def start_round(
    cfg: WalkConfig,
    key_data,
    params: MaterialParams,
    mu_i: float,
    first_id: int,
    n_paths: int,
    max_bounces: int = 1000,
    mesh: Mesh | None = None,
) -> ChunkedRound:
    """:func:`run_round` as a :class:`fitlab._montecarlo.ChunkedRound`, to be run in chunks of steps; the same
    checks, before any work."""
    if not 0.0 < mu_i <= 1.0:
        raise ValueError(f"mu_i must lie in (0, 1], got {mu_i}")
    if not (params.alpha_x > 0.0 and params.alpha_y > 0.0):
        raise ValueError("alpha_x and alpha_y must be positive")
    if cfg.kind == "dielectric" and not params.eta > 0.0:
        raise ValueError(f"a dielectric's eta must be positive, got {params.eta}")
    if first_id < 0 or n_paths < 1 or first_id + n_paths > 2**32:
        raise ValueError("path ids must lie in [0, 2^32)")
    if max_bounces < 1:
        raise ValueError("max_bounces must be >= 1")
    mesh = mesh or default_mesh()
    compile_walk(cfg, mesh)
    return _round(cfg, mesh, key_data, params, mu_i, first_id, n_paths, max_bounces)


@float64
def run_round(
    cfg: WalkConfig,
    key_data,
    params: MaterialParams,
    mu_i: float,
    first_id: int,
    n_paths: int,
    max_bounces: int = 1000,
    mesh: Mesh | None = None,
) -> dict:
    """Run paths first_id .. first_id + n_paths - 1 of the job whose key is ``key_data``; tallies as numpy.

    mu_i in (0, 1]; alpha_x, alpha_y > 0; a dielectric's eta > 0; ids below 2^32; max_bounces >= 1; mesh:
    the devices (default :func:`default_mesh`; the tallies do not depend on it beyond the order of
    summation, nor on the chunks :func:`start_round`'s round is run in).  The outside-every-bin row and column
    of the lobes are removed; ``lobe_transmission`` is there when ``cfg.transmission_lobe``."""
    return start_round(cfg, key_data, params, mu_i, first_id, n_paths, max_bounces, mesh).run()
