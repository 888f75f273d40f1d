r"""The jitted random walk in the half space, and its tallies.

Model (docs/model.md, "Monte Carlo model"): the half space z < 0 of unit
extinction.  A photon enters at
the origin along -w_i, w_i = (sqrt(1 - mu_i^2), 0, mu_i), flies an exponential
free path, and at every collision carries its weight times c (no absorption
by killing) and scatters by the phase function.  It escapes when a free path
crosses z = 0; its direction is then w_o = (S_o cos phi, S_o sin phi, mu_o):
phi = 0 is back-scattering (docs/model.md, "Conventions").

What is simulated is multiple scattering only.  Single scattering has the
closed form (docs/model.md, "Single scattering"), so the flight after the
first collision is forced to
stay inside: it is drawn from the exponential truncated at the distance L to
the surface and the weight is multiplied by P(s < L) = 1 - exp(-L).  Every
tally therefore starts at the 2nd collision, and no path is spent on single
scattering.

Details: docs/montecarlo.md, section ``fitlab.families.lambert_sphere.mc.transport``."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from functools import partial
from typing import NamedTuple

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
from fitlab.families.lambert_sphere.mc.phase_sampling import (
    THREE_TERM_NORM,
    mixture_density,
    p_three_term,
    p_true,
    sample_mixture,
    sample_three_term,
    sample_true_approx,
    sample_true_exact,
    turn,
    unbounded_reason,
)

__all__ = ["WalkConfig", "compile_walk", "run_round", "start_round", "round_key", "default_mesh", "default_slots"]

PHASES = ("true", "three_term", "both")
SAMPLERS = ("exact", "approx")
INCIDENCES = ("fixed", "cosine")
AXIS = "photons"


@dataclass(frozen=True)
class WalkConfig:
    """Static description of a walk: what to sample and which tallies to keep.

    An empty ``mu_edges`` means no per-direction tally; ``orders`` and
    ``phi_edges`` need ``mu_edges``.  ``collision_orders`` = N >= 2 keeps the
    escapes after 2..N collisions and the rest (0: not kept).  ``precision`` is
    the path state's float type (docs/montecarlo.md, "Precision").
    """

    phase: str = "three_term"
    sampler: str = "exact"
    incidence: str = "fixed"
    mu_edges: tuple = ()
    orders: tuple = ()
    phi_edges: tuple = ()
    collision_orders: int = 0
    max_collisions: int = 100_000
    slots: int = 0  # photon slots per device; 0: 512 on a CPU, 65536 on an accelerator
    rr_weight: float = 0.125
    precision: str = "float32"

    def __post_init__(self):
        if self.phase not in PHASES:
            raise ValueError(f"phase must be one of {PHASES}, got {self.phase!r}")
        if self.sampler not in SAMPLERS:
            raise ValueError(f"sampler must be one of {SAMPLERS}, got {self.sampler!r}")
        if self.sampler == "approx" and self.phase != "true":
            raise ValueError("sampler='approx' (eq. 6) samples the true phase function only: use phase='true'")
        if self.incidence not in INCIDENCES:
            raise ValueError(f"incidence must be one of {INCIDENCES}, got {self.incidence!r}")
        e = np.asarray(self.mu_edges, dtype=float)
        if e.size and (e.size < 2 or np.any(np.diff(e) <= 0) or e[0] < 0 or e[-1] > 1):
            raise ValueError("mu_edges must increase strictly within [0, 1]")
        if (self.orders or self.phi_edges) and not e.size:
            raise ValueError("orders and phi_edges need mu_edges")
        if any((not isinstance(m, int)) or m < 0 for m in self.orders):
            raise ValueError("orders must be non-negative integers")
        p = np.asarray(self.phi_edges, dtype=float)
        if p.size and (p.size < 2 or np.any(np.diff(p) <= 0) or p[0] < 0 or p[-1] > np.pi + 1e-12):
            raise ValueError("phi_edges must increase strictly within [0, pi]")
        if self.collision_orders != 0 and self.collision_orders < 2:
            raise ValueError("collision_orders must be 0 (off) or >= 2")
        if not 2 <= self.max_collisions < 2**31:
            raise ValueError("max_collisions must lie in [2, 2^31)")
        if self.slots != 0 and self.slots < 8:
            raise ValueError("slots must be 0 (automatic) or >= 8")
        if not 0.0 < self.rr_weight < 1.0:
            raise ValueError("rr_weight must lie in (0, 1)")
        if self.precision not in PRECISIONS:
            raise ValueError(f"precision must be one of {PRECISIONS}, got {self.precision!r}")

    @property
    def tracks(self) -> int:
        """Number of tallied weights: 1, or 3 for phase='both' (true, three-term, difference)."""
        return 3 if self.phase == "both" else 1

    @property
    def words(self) -> int:
        """Threefry pairs per photon per collision (2 uniforms each)."""
        return {"true": 2 if self.sampler == "approx" else 3, "three_term": 2, "both": 4}[self.phase]


class _Slots(NamedTuple):
    alive: jax.Array  # bool
    pid: jax.Array  # uint32 photon id
    n: jax.Array  # int32: collisions so far (0: not yet entered)
    z: jax.Array  # position, <= 0
    dx: jax.Array
    dy: jax.Array
    dz: jax.Array
    w: jax.Array  # (slots, 1 or 2) weights
    blocks: jax.Array  # (pairs, slots) uint64: the Threefry blocks of each slot's event n (_refill hashes them)


def _tally_shapes(cfg: WalkConfig) -> dict:
    t = cfg.tracks
    nb = max(len(cfg.mu_edges) - 1, 0)
    shapes = {"escape": (t,), "capped": (t,)}
    if cfg.orders:
        shapes["fourier"] = (nb + 1, t, len(cfg.orders))  # last row: dump
    if cfg.phi_edges:
        shapes["bins"] = (nb + 1, t, len(cfg.phi_edges) - 1)
    if cfg.collision_orders:
        buckets = cfg.collision_orders  # n = 2..N (N - 1 buckets) and the rest; + 1 dump row
        shapes["coll"] = (buckets + 1, t)
        if nb:
            shapes["coll_f0"] = (buckets + 1, nb + 1, t)
    return shapes


def _zero_tallies(cfg: WalkConfig) -> dict:
    out = {}
    for name, shape in _tally_shapes(cfg).items():
        out[name] = jnp.zeros(shape)
        out[name + "_sq"] = jnp.zeros(shape)
    out["photons"] = jnp.zeros((), jnp.int64)
    out["collisions"] = jnp.zeros((), jnp.int64)
    out["n_capped"] = jnp.zeros((), jnp.int64)
    out["steps"] = jnp.zeros((), jnp.int64)
    return out


def _uniforms(blocks, dtype):
    """The 2*pairs uniforms of a slot's event from its Threefry blocks (:func:`fitlab._montecarlo.threefry_blocks`
    of the counters (pid, n*pairs + j)): item j < pairs from block j's first word, item pairs + j from its
    second (the layout of ``jax.extend.random.threefry_2x32`` of the counters concatenated)."""
    first, second = block_words(blocks)
    return tuple(uniforms(w, dtype) for w in first + second)


def _chebyshev(cos_phi, orders):
    """cos(m phi) for m in orders, from cos(phi) by the Chebyshev recursion."""
    top = max(orders)
    t = [jnp.ones_like(cos_phi), cos_phi]
    for _ in range(2, top + 1):
        t.append(2.0 * cos_phi * t[-1] - t[-2])
    return jnp.stack([t[m] for m in orders], axis=-1)


def _scatter(s: _Slots, u01, c, cfg: WalkConfig):
    """One collision: weight times c, new direction; returns (dx, dy, dz, w)."""
    if cfg.phase == "true":
        u = sample_true_exact(u01[0], u01[1], u01[2]) if cfg.sampler == "exact" else sample_true_approx(u01[0])
        factor = jnp.ones_like(u)[:, None]
    elif cfg.phase == "three_term":
        u, sign = sample_three_term(u01[0])
        factor = (sign * THREE_TERM_NORM)[:, None]
    else:
        u = sample_mixture(u01[0], u01[1], u01[2], u01[3], u01[4])
        q = mixture_density(u)
        factor = jnp.stack([p_true(u) / q, p_three_term(u) / q], axis=-1)
    sin_psi, cos_psi = sincos_2pi(u01[-3])
    dx, dy, dz = turn(s.dx, s.dy, s.dz, u, cos_psi, sin_psi)
    return dx, dy, dz, s.w * c * factor


def _tally(tallies, cfg: WalkConfig, escaped, n, w, dx, dy, dz, capped):
    """Add this step's escapes (and capped photons) to the tallies."""
    t = cfg.tracks
    w = w.astype(jnp.float64)
    if t == 3:
        w = jnp.stack([w[:, 0], w[:, 1], w[:, 0] - w[:, 1]], axis=-1)
    esc_w = jnp.where(escaped[:, None], w, 0.0)
    cap_w = jnp.where(capped[:, None], w, 0.0)
    out = dict(tallies)
    out["escape"] = out["escape"] + esc_w.sum(0)
    out["escape_sq"] = out["escape_sq"] + (esc_w * esc_w).sum(0)
    out["capped"] = out["capped"] + cap_w.sum(0)
    out["capped_sq"] = out["capped_sq"] + (cap_w * cap_w).sum(0)
    nb = max(len(cfg.mu_edges) - 1, 0)
    if nb:
        mbin = jnp.where(escaped, bin_index(dz, cfg.mu_edges), nb)  # nb: outside every bin, or not escaped
        cos_phi = azimuth_cosine(dx, dy)
    if "fourier" in out:
        v = esc_w[:, :, None] * _chebyshev(cos_phi, cfg.orders)[:, None, :]
        add_with_squares(out, "fourier", (mbin,), v)
    if "bins" in out:
        nphi = len(cfg.phi_edges) - 1
        pbin = bin_index(cos_phi, [math.cos(e) for e in cfg.phi_edges], decreasing=True)  # nphi: outside
        onehot = (pbin[:, None] == jnp.arange(nphi)[None, :]).astype(jnp.float64)
        add_with_squares(out, "bins", (mbin,), esc_w[:, :, None] * onehot[:, None, :])
    if "coll" in out:
        top = cfg.collision_orders
        cbin = jnp.where(escaped, jnp.minimum(n, top + 1) - 2, top)  # rest: top - 1; dump: top
        add_with_squares(out, "coll", (cbin,), esc_w)
        if "coll_f0" in out:
            add_with_squares(out, "coll_f0", (cbin, mbin), esc_w)
    return out


def _refill(carry, key_pair, hi, cfg: WalkConfig):
    """Give empty slots the next photon ids (in slot order, by a prefix sum), then hash every slot's Threefry
    blocks for its next event (carried to the next step: :func:`fitlab._montecarlo.threefry_blocks`)."""
    s, tallies, nxt = carry
    need = ~s.alive
    rank = jnp.cumsum(need.astype(jnp.int64)) - 1
    new_id = nxt + rank
    take = need & (new_id < hi)
    pid = jnp.where(take, new_id.astype(jnp.uint32), s.pid)
    n = jnp.where(take, 0, s.n)
    w = jnp.where(take[:, None], jnp.ones_like(s.w), s.w)
    blocks = threefry_blocks(key_pair, pid, n.astype(jnp.uint32) * jnp.uint32(cfg.words), cfg.words)
    s = s._replace(alive=s.alive | take, pid=pid, n=n, w=w, blocks=blocks)
    tallies = dict(tallies)
    tallies["photons"] = tallies["photons"] + take.sum()
    return s, tallies, jnp.minimum(nxt + need.sum(), hi)


def _step(carry, key_pair, c, mu_i, hi, cap, cfg: WalkConfig):
    """One flight (+ collision) for each live slot, then :func:`_refill`."""
    s, tallies, nxt = carry
    size = s.alive.shape[0]
    u01 = _uniforms(s.blocks, s.z.dtype)
    entering = s.n == 0
    # entry: direction -w_i (mu_i fixed, or cosine-distributed: mu = sqrt(x))
    mu = jnp.sqrt(u01[0]) if cfg.incidence == "cosine" else jnp.broadcast_to(mu_i, (size,))
    ex, ey, ez = -jnp.sqrt(jnp.maximum(0.0, 1.0 - mu * mu)), jnp.zeros(size, mu.dtype), -mu
    # collision n >= 1
    cx, cy, cz, cw = _scatter(s, u01, c, cfg)
    dx = jnp.where(entering, ex, cx)
    dy = jnp.where(entering, ey, cy)
    dz = jnp.where(entering, ez, cz)
    w = jnp.where(entering[:, None], s.w, cw)
    # Russian roulette on the largest |weight|, before the flight: a killed
    # photon contributes nothing, a survivor carries w * rr_weight / |w|max
    big = jnp.max(jnp.abs(w), axis=1)
    low = (big < cfg.rr_weight) & ~entering
    survive = u01[-1] * cfg.rr_weight < big
    w = jnp.where((low & survive)[:, None], w * (cfg.rr_weight / jnp.where(low, big, 1.0))[:, None], w)
    live = s.alive & ~(low & ~survive)
    # flight: L = path length to the surface (inf when heading down)
    up = dz > 0.0
    dist = jnp.where(up, -s.z / jnp.where(up, dz, 1.0), jnp.inf)
    x_f = u01[-2]
    forced = s.n == 1
    e_l = jnp.expm1(-dist)  # -(1 - exp(-L)); -1 when L = inf
    flight = jnp.where(forced, -jnp.log1p(x_f * e_l), -jnp.log(x_f))
    w = jnp.where(forced[:, None], w * (-e_l)[:, None], w)
    escaped = live & (s.n >= 2) & up & (flight > dist)
    z = s.z + flight * dz
    n_next = s.n + 1
    capped = live & ~escaped & (n_next > cap)
    alive = live & ~escaped & ~capped
    tallies = _tally(tallies, cfg, escaped, s.n, w, dx, dy, dz, capped)
    tallies["collisions"] = tallies["collisions"] + (s.alive & ~entering).sum()
    tallies["n_capped"] = tallies["n_capped"] + capped.sum()
    tallies["steps"] = tallies["steps"] + 1
    s = _Slots(alive, s.pid, n_next, jnp.where(alive, z, 0.0), dx, dy, dz, w, s.blocks)
    return _refill((s, tallies, nxt), key_pair, hi, cfg)


def _compact(s: _Slots, size: int) -> _Slots:
    """The live slots, gathered into ``size`` slots (the caller ensures enough room)."""
    count = s.alive.sum()
    idx = jnp.nonzero(s.alive, size=size, fill_value=0)[0]
    g = jax.tree_util.tree_map(lambda a: a[idx], s._replace(blocks=s.blocks.T))
    return g._replace(alive=jnp.arange(size) < count, blocks=g.blocks.T)


def default_slots(platform: str) -> int:
    """Photon slots per device: 1024 on a CPU, 65536 on an accelerator.  On this machine's 2 cores (one device
    each, best of 5 interleaved rounds of 1e5 photons, true phase function) 1024 slots ran 1.29e7 and 2.18e7
    collisions/s at c = 0.5 and 0.99, against 1.21e7 and 2.08e7 with 512, 1.27e7 and 2.0e7 with 256, 1.36e7
    and 2.06e7 with 2048."""
    return 1024 if platform == "cpu" else 65536


def _sizes(cfg: WalkConfig, platform: str) -> list:
    """The slots of each level of a device's walk: the round's, then 1/8 as many, twice (not below 64)."""
    sizes = [cfg.slots or default_slots(platform)]
    while sizes[-1] // 8 >= 64:
        sizes.append(sizes[-1] // 8)
        if len(sizes) == 3:
            break
    return sizes


def _start(key_pair, lo, hi, cfg: WalkConfig, platform: str):
    """One device's walk of photon ids [lo, hi) before its first step: empty slots, refilled."""
    nw = 2 if cfg.phase == "both" else 1
    p = _sizes(cfg, platform)[0]
    dt = jnp.dtype(cfg.precision)
    s = _Slots(
        jnp.zeros(p, bool),
        jnp.zeros(p, jnp.uint32),
        jnp.zeros(p, jnp.int32),
        jnp.zeros(p, dt),
        jnp.zeros(p, dt),
        jnp.zeros(p, dt),
        jnp.zeros(p, dt),
        jnp.ones((p, nw), dt),
        jnp.zeros((cfg.words, p), jnp.uint64),
    )
    return _refill((s, _zero_tallies(cfg), jnp.asarray(lo, jnp.int64)), key_pair, hi, cfg)


def _run_level(carry, key_pair, c, mu_i, hi, cap, steps, room: int, cfg: WalkConfig):
    """At most ``steps`` steps of one device's walk at a level whose slots take up to ``room`` photons at the
    next level (0: the last); returns the carry and the status (level ended, photons started, slots alive)."""
    dt = carry[0].z.dtype
    body = partial(_step, key_pair=key_pair, c=c.astype(dt), mu_i=mu_i.astype(dt), hi=hi, cap=cap, cfg=cfg)

    def going(cr):
        return (cr[2] < hi) | (cr[0].alive.sum() > room)

    _, carry = jax.lax.while_loop(
        lambda st: (st[0] < steps) & going(st[1]),
        lambda st: (st[0] + 1, body(st[1])),
        (jnp.zeros((), jnp.int64), carry),
    )
    status = jnp.stack([(~going(carry)).astype(jnp.int64), carry[1]["photons"], carry[0].alive.sum(dtype=jnp.int64)])
    return carry, status


def default_mesh() -> Mesh:
    """A 1-D mesh over all devices (one device: sharding is a no-op)."""
    return Mesh(np.array(jax.devices()), (AXIS,))


_COMPILED: dict = {}


def _programs(cfg: WalkConfig, mesh: Mesh) -> dict:
    """The walk's programs on ``mesh``, each a jitted ``shard_map`` (docs/montecarlo.md, "Layout"): ``start`` (the
    photon ids split into one contiguous range per device), ``runs[L]`` and ``compacts`` (the levels,
    :class:`fitlab._montecarlo.ChunkedRound`) and ``finish`` (the tallies summed over the devices).  A device's
    state carries its slots, tallies, next id and the end of its range."""
    ndev, platform = mesh.size, mesh.devices.flat[0].platform
    sizes = _sizes(cfg, platform)
    rep, dev = PartitionSpec(), PartitionSpec(AXIS)

    def start(key_pair, n_photons):
        d = jax.lax.axis_index(AXIS).astype(jnp.int64)
        per = (n_photons + ndev - 1) // ndev
        lo = jnp.minimum(d * per, n_photons)
        hi = jnp.minimum(lo + per, n_photons)
        return device_stacked((_start(key_pair, lo, hi, cfg, platform), hi))

    def run(level: int):
        room = sizes[level + 1] if level + 1 < len(sizes) else 0

        def per_device(state, key_pair, c, mu_i, cap, steps):
            carry, hi = device_local(state)
            carry, status = _run_level(carry, key_pair, c, mu_i, hi, cap, steps, room, cfg)
            return device_stacked((carry, hi)), status[None]

        return jax.jit(
            jax.shard_map(per_device, mesh=mesh, in_specs=(dev,) + (rep,) * 5, out_specs=(dev, dev), check_vma=False)
        )

    def compact(size: int):
        def per_device(state):
            (s, tallies, nxt), hi = device_local(state)
            return device_stacked(((_compact(s, size), tallies, nxt), hi))

        return jax.jit(jax.shard_map(per_device, mesh=mesh, in_specs=(dev,), out_specs=dev, check_vma=False))

    def finish(state):
        (_, tallies, _), _ = device_local(state)
        return jax.tree_util.tree_map(lambda a: jax.lax.psum(a, AXIS), tallies)

    def sharded(f, in_specs, out_specs):
        return jax.jit(jax.shard_map(f, mesh=mesh, in_specs=in_specs, out_specs=out_specs, check_vma=False))

    return {
        "start": sharded(start, (rep,) * 2, dev),
        "runs": [run(level) for level in range(len(sizes))],
        "compacts": [compact(size) for size in sizes[1:]],
        "finish": sharded(finish, (dev,), rep),
    }


def _static(cfg: WalkConfig) -> WalkConfig:
    """The compiled part of a config: the cap is a run-time argument."""
    return replace(cfg, max_collisions=2)


@float64
def compile_walk(cfg: WalkConfig, mesh: Mesh | None = None) -> float:
    """Compile the walk's programs for ``cfg`` on ``mesh`` (once; cached), by running a round of one photon
    through every level.  Returns the seconds it took (0 if cached)."""
    mesh = mesh or default_mesh()
    key = (_static(cfg), mesh)
    if key in _COMPILED:
        return 0.0
    t0 = time.perf_counter()
    programs = _programs(key[0], mesh)
    _COMPILED[key] = programs
    _round(programs, key[0], jnp.zeros(2, jnp.uint32), 0.5, 0.5, 1, 2).run()
    return time.perf_counter() - t0


def _round(programs: dict, cfg: WalkConfig, key_pair, c: float, mu_i: float, n_photons: int, cap: int) -> ChunkedRound:
    args = (jnp.asarray(key_pair, jnp.uint32), jnp.float64(c), jnp.float64(mu_i))
    state = programs["start"](args[0], jnp.int64(n_photons))
    runs = [partial(lambda f, st, steps: f(st, *args, jnp.int64(cap), jnp.int64(steps)), f) for f in programs["runs"]]
    return ChunkedRound(state, runs, programs["compacts"], programs["finish"], partial(_numpy_tallies, cfg))


def _numpy_tallies(cfg: WalkConfig, out: dict) -> dict:
    """The tallies as numpy arrays, the dump rows of the per-bin tallies removed."""
    res = {k: np.asarray(v) for k, v in out.items()}
    for name in ("fourier", "bins"):
        for suffix in ("", "_sq"):
            if name + suffix in res:
                res[name + suffix] = res[name + suffix][:-1]
    for suffix in ("", "_sq"):
        if "coll" + suffix in res:
            res["coll" + suffix] = res["coll" + suffix][:-1]
        if "coll_f0" + suffix in res:
            res["coll_f0" + suffix] = res["coll_f0" + suffix][:-1, :-1]
    return res


@float64
def round_key(seed: int, *stream: int) -> jax.Array:
    """Threefry key pair (uint32[2]) for ``seed`` and a stream path, e.g. (job, round)."""
    key = jax.random.key(seed)
    for s in stream:
        key = jax.random.fold_in(key, s)
    return jax.random.key_data(key)


@float64
def start_round(
    cfg: WalkConfig,
    seed: int,
    stream: tuple,
    c: float,
    mu_i: float,
    n_photons: int,
    mesh: Mesh | None = None,
    unbounded_ok: bool = False,
) -> ChunkedRound:
    """:func:`run_round` as a :class:`fitlab._montecarlo.ChunkedRound`, to be run in chunks of steps; the same
    checks, before any work."""
    if not 0.0 <= c <= 1.0:
        raise ValueError(f"c must lie in [0, 1], got {c}")
    why = unbounded_reason(cfg.phase, c)
    if why and not unbounded_ok:
        raise ValueError(why)
    if not 0.0 <= mu_i <= 1.0:
        raise ValueError(f"mu_i must lie in [0, 1], got {mu_i}")
    if n_photons < 1 or n_photons >= 2**32:
        raise ValueError("n_photons must lie in [1, 2^32)")
    mesh = mesh or default_mesh()
    compile_walk(cfg, mesh)
    return _round(
        _COMPILED[(_static(cfg), mesh)], cfg, round_key(seed, *stream), c, mu_i, n_photons, cfg.max_collisions
    )


@float64
def run_round(
    cfg: WalkConfig,
    seed: int,
    stream: tuple,
    c: float,
    mu_i: float,
    n_photons: int,
    mesh: Mesh | None = None,
    unbounded_ok: bool = False,
) -> dict:
    """Simulate ``n_photons`` photons (ids 0..n-1 of one round); tallies as numpy arrays.

    ``stream`` is a tuple of non-negative ints (e.g. (job, round)) folded into
    the key of ``seed``.  c in [0, 1]; mu_i in [0, 1] (ignored for cosine
    incidence).  Dump rows of the per-bin tallies are removed.  Deterministic
    in (cfg, seed, stream, c, mu_i, n_photons) whatever the mesh, up to the
    order of summation, and whatever the chunks :func:`start_round`'s round is run in.

    A c at which the walk's estimator has infinite variance (c > 1/N for the
    three-term walk, :data:`~fitlab.families.lambert_sphere.mc.phase_sampling.C_LIMIT`)
    is refused unless ``unbounded_ok`` (then only the collision cap bounds the
    weights: for identities that hold path by path, never for estimates).
    """
    return start_round(cfg, seed, stream, c, mu_i, n_photons, mesh, unbounded_ok).run()
