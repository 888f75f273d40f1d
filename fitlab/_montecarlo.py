"""Rules every family's Monte Carlo (``fitlab simulate``) shares: the path budget of one job, the warning
when a job's budget cannot reach its standard-error target within :data:`SLOW_JOB_SECONDS`, the
counter-based hash both random walks draw their numbers from (:func:`threefry_2x32`), the uniforms they make
of its words in either precision (:func:`uniforms`), the azimuth's sine and cosine (:func:`sincos_2pi`), the
tallies' bins and sums (:func:`azimuth_cosine`, :func:`bin_index`, :func:`add_with_squares`), and one JAX CPU
device per core (:func:`use_every_core`).

No JAX at import: the command line reads :data:`MAX_PATHS` for its help (the JAX functions import it when
they are traced).
"""

from __future__ import annotations

import math
import os
import sys

from fitlab._precision import float64

__all__ = [
    "MAX_PATHS",
    "MIN_PATHS_BUDGET",
    "SLOW_JOB_SECONDS",
    "THREEFRY_ROTATIONS",
    "THREEFRY_C",
    "duration",
    "slow_job_warning",
    "threefry_2x32",
    "HOST_DEVICES_FLAG",
    "use_every_core",
    "PRECISIONS",
    "FLOAT32_UNIFORM_BITS",
    "uniforms",
    "sincos_2pi",
    "threefry_blocks",
    "block_words",
    "azimuth_cosine",
    "bin_index",
    "add_with_squares",
    "ChunkedRound",
    "device_local",
    "device_stacked",
]

#: the largest path budget of one job (``max_paths`` in a scene file, ``--max-paths``): one rule for every
#: family and the command line (the microsurface walk numbers a job's paths with 32-bit ids)
MAX_PATHS = 2**32
#: the smallest path budget of one job
MIN_PATHS_BUDGET = 1000
#: a job whose projected time to its stop (its target, or its budget when the target is out of reach)
#: exceeds this, at the rate its first rounds measured, is named in one warning line on stderr
SLOW_JOB_SECONDS = 3600.0


#: the XLA flag that splits the host CPU into that many JAX devices
HOST_DEVICES_FLAG = "--xla_force_host_platform_device_count"


def use_every_core(environ=None, cores: int | None = None) -> bool:
    """Ask JAX, before it starts, for one CPU device per core, so that the walks' meshes (one lane pool per
    device, ``shard_map``) keep every core busy: XLA runs a program on one thread per device, and a walk's
    small per-event kernels gain nothing from its threads within a kernel.  Adds :data:`HOST_DEVICES_FLAG`
    to ``XLA_FLAGS`` in ``environ`` (default ``os.environ``); returns whether it did.  It does nothing when
    JAX is already imported (its devices are fixed by then), when ``XLA_FLAGS`` already sets the count (the
    user's choice), or on a single core.  Accelerators are unaffected: the flag splits only the host."""
    environ = os.environ if environ is None else environ
    if cores is None:
        cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    flags = environ.get("XLA_FLAGS", "")
    if "jax" in sys.modules or HOST_DEVICES_FLAG in flags or cores < 2:
        return False
    environ["XLA_FLAGS"] = f"{flags} {HOST_DEVICES_FLAG}={cores}".strip()
    return True


def duration(seconds: float) -> str:
    """``seconds`` as a person reads it: 45 s, 12 min, 3.4 h, 38 days."""
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 3600:
        return f"{seconds / 60:.0f} min"
    if seconds < 2 * 86400:
        return f"{seconds / 3600:.2g} h"
    return f"{seconds / 86400:.0f} days"


def slow_job_warning(
    paths: int, seconds: float, se_ratio: float, max_paths: int, bound: float = SLOW_JOB_SECONDS
) -> str | None:
    """The warning for a job that has run ``paths`` paths in ``seconds`` (walk time) with its worst standard
    error ``se_ratio`` times its target, or None when its stop is projected within ``bound`` seconds.

    The standard error falls as 1/sqrt(N): the target needs about N se_ratio^2 paths; the job stops there or at
    ``max_paths``, whichever comes first, and the remaining paths take (stop - N) / rate at the measured rate
    N / seconds.  While a row has no error estimate (se_ratio infinite: an empty bin whose rule-of-three bound
    is above the target) only the budget bounds the stop.  None before a first measurement, or for a NaN."""
    if paths <= 0 or not seconds > 0 or math.isnan(se_ratio) or paths >= max_paths:
        return None
    rate = paths / seconds
    if math.isinf(se_ratio):
        left = (max_paths - paths) / rate
        if left <= bound:
            return None
        return (
            f"after {paths} paths a bin is still empty (no error estimate): the job may run to max_paths = "
            f"{max_paths}, {duration(left)} more at {rate:.3g} paths/s (over the {duration(bound)} bound)"
        )
    needed = paths * max(se_ratio, 1.0) ** 2
    stop = min(needed, max_paths)
    left = (stop - paths) / rate
    if left <= bound:
        return None
    head = f"standard error {se_ratio:.3g} x its target after {paths} paths; the target needs about {needed:.2g} paths"
    if needed > max_paths:
        return (
            f"{head}, more than max_paths = {max_paths}: the job will stop above its target after "
            f"{duration(left)} more at {rate:.3g} paths/s (over the {duration(bound)} bound; lower --max-paths "
            "or raise --target-se)"
        )
    return f"{head}: {duration(left)} more at {rate:.3g} paths/s (over the {duration(bound)} bound)"


#: Threefry-2x32's rotations, the first set for rounds 1-4, 9-12, 17-20, the second for the others
THREEFRY_ROTATIONS = ((13, 15, 26, 6), (17, 29, 16, 24))


def threefry_2x32(key_data, x0, x1):
    """Threefry-2x32 with 20 rounds (Salmon et al. 2011), the hash of ``jax.extend.random.threefry_2x32`` bit
    for bit (tests/test_microsurface_sampling.py), written out round by round: on a CPU JAX lowers its own
    to a loop of 5 steps whose dispatch costs more than the rest of a walk event.  key_data uint32[2]; x0, x1
    uint32 arrays of one shape (the two words of each counter block); returns the two output words."""
    import jax.numpy as jnp

    k0, k1 = key_data[0], key_data[1]
    ks = (k0, k1, k0 ^ k1 ^ jnp.uint32(0x1BD11BDA))
    x0, x1 = x0 + ks[0], x1 + ks[1]
    for i in range(5):
        for r in THREEFRY_ROTATIONS[i % 2]:
            x0 = x0 + x1
            x1 = (x1 << jnp.uint32(r)) | (x1 >> jnp.uint32(32 - r))
            x1 = x0 ^ x1
        x0 = x0 + ks[(i + 1) % 3]
        x1 = x1 + ks[(i + 2) % 3] + jnp.uint32(i + 1)
    return x0, x1


#: :func:`threefry_2x32` in C99 (``static void threefry(k0, k1, x0, x1, &o0, &o1)``) and ``TWO32`` = 2^-32, for the
#: C reference walks of ``fitlab bench mc``, which draw the same words as the JAX walks
THREEFRY_C = r"""#include <stdint.h>

static const double TWO32 = 2.3283064365386962890625e-10; /* 2^-32 */

static uint32_t rotl(uint32_t x, int r) { return (x << r) | (x >> (32 - r)); }

/* Threefry-2x32, 20 rounds (Salmon et al. 2011), as jax.random's threefry_2x32 */
static void threefry(uint32_t k0, uint32_t k1, uint32_t x0, uint32_t x1, uint32_t *o0, uint32_t *o1)
{
    static const int rot[8] = {13, 15, 26, 6, 17, 29, 16, 24};
    const uint32_t ks[3] = {k0, k1, k0 ^ k1 ^ 0x1BD11BDAu};
    x0 += ks[0];
    x1 += ks[1];
    for (int i = 0; i < 5; ++i) {
        const int *r = rot + 4 * (i & 1);
        for (int j = 0; j < 4; ++j) {
            x0 += x1;
            x1 = rotl(x1, r[j]);
            x1 ^= x0;
        }
        x0 += ks[(i + 1) % 3];
        x1 += ks[(i + 2) % 3] + (uint32_t)(i + 1);
    }
    *o0 = x0;
    *o1 = x1;
}
"""


#: the walks' path-state precisions (tallies add up in float64 in both)
PRECISIONS = ("float32", "float64")


#: the bits of a word a float32 uniform keeps (:func:`uniforms`)
FLOAT32_UNIFORM_BITS = 23


def uniforms(words, dtype):
    """Uniforms in (0, 1) of uint32 ``words``, each the midpoint of one of 2^b equal cells of [0, 1], exactly:
    float64 (word + 1/2) 2^-32 (b = 32), float32 (word >> 9 + 1/2) 2^-23 (the top b = 23 bits,
    :data:`FLOAT32_UNIFORM_BITS`: k + 1/2 < 2^23 needs 24 significant bits, all a float32 has; with 24 bits
    the cells' midpoints above 1/2 would round, the last to 1).  So u and 1 - u are at least 2^-33 in
    float64, 2^-24 in float32: a sampled tail is cut at those probabilities."""
    import jax.numpy as jnp

    if dtype == jnp.float32:
        shift = jnp.uint32(32 - FLOAT32_UNIFORM_BITS)
        return ((words >> shift).astype(jnp.float32) + jnp.float32(0.5)) * jnp.float32(2.0**-FLOAT32_UNIFORM_BITS)
    return (words.astype(jnp.float64) + 0.5) * 2.0**-32


def sincos_2pi(x):
    """(sin 2 pi x, cos 2 pi x) for x in [0, 1]: the azimuth of a uniform x.

    float64: ``jnp.sin`` and ``jnp.cos`` of 2 pi x (the C reference walk's libm values, path for path).
    float32: x is reduced to t = x - round(x) in [-1/2, 1/2] (exact), a = pi t, sin a and cos a by their Taylor
    series to a^11 and a^12 (truncation below 1e-9 on [-pi/2, pi/2]), and the double-angle formulas; within
    1e-6 of the float64 values (the float32 rounding of pi t, carried through the double angle; float32's
    own 2 pi x is 4e-7 off).  XLA's CPU backend calls the scalar libm for a float32 sin, 20 times the cost
    of these multiply-adds, which vectorise on every device.
    """
    import jax.numpy as jnp

    if x.dtype != jnp.float32:
        return jnp.sin(2.0 * jnp.pi * x), jnp.cos(2.0 * jnp.pi * x)
    a = (x - jnp.round(x)) * jnp.float32(math.pi)
    a2 = a * a
    sin_a = a * (1.0 + a2 * (-1 / 6 + a2 * (1 / 120 + a2 * (-1 / 5040 + a2 * (1 / 362880 + a2 * (-1 / 39916800))))))
    cos_a = 1.0 + a2 * (
        -1 / 2 + a2 * (1 / 24 + a2 * (-1 / 720 + a2 * (1 / 40320 + a2 * (-1 / 3628800 + a2 * (1 / 479001600)))))
    )
    return 2.0 * sin_a * cos_a, 1.0 - 2.0 * sin_a * sin_a


def threefry_blocks(key_data, pid, base, pairs: int):
    """:func:`threefry_2x32` of the counters (pid, base + j), j < pairs, for each lane: a (pairs, lanes) uint64
    array, block j's first word in the high half and its second in the low half (:func:`block_words`).

    One array, because of how XLA's CPU backend fuses: a walk that hashes where it uses the words gets the
    hash copied into each consumer's kernel (up to 6 times the work), and one that materialises them by a
    concatenation gets a hash that does not vectorise.  The walks hash at the end of a step, for each lane's
    next event, and carry the array to the next step."""
    import jax.numpy as jnp

    x1 = base.astype(jnp.uint32)[None, :] + jnp.arange(pairs, dtype=jnp.uint32)[:, None]
    first, second = threefry_2x32(key_data, jnp.broadcast_to(pid.astype(jnp.uint32)[None, :], x1.shape), x1)
    return (first.astype(jnp.uint64) << jnp.uint64(32)) | second.astype(jnp.uint64)


def block_words(blocks):
    """The words of :func:`threefry_blocks`: (first, second), each a list over blocks of per-lane uint32."""
    import jax.numpy as jnp

    first = [(b >> jnp.uint64(32)).astype(jnp.uint32) for b in blocks]
    second = [(b & jnp.uint64(0xFFFFFFFF)).astype(jnp.uint32) for b in blocks]
    return first, second


def azimuth_cosine(x, y):
    """cos |phi| = x / sqrt(x^2 + y^2) of a direction's horizontal part (x, y), clipped to [-1, 1]; 1 (phi = 0)
    straight up or down.  The walks bin and expand |phi| by its cosine: no arctangent or arccosine."""
    import jax.numpy as jnp

    rho = jnp.sqrt(x * x + y * y)
    return jnp.where(rho > 0.0, jnp.clip(x / jnp.where(rho > 0.0, rho, 1.0), -1.0, 1.0), 1.0)


def bin_index(value, edges, decreasing: bool = False):
    """Index of the bin [e_i, e_i+1) holding value (the last bin closed), len(edges) - 1 outside.

    ``decreasing``: ``value`` is g(x) of a decreasing g (the cosine of an angle) and ``edges`` are g of the
    x edges, so that the bin of x is found without inverting g.  Up to 32 edges by counting the interior
    edges passed (a few compares per lane; on a CPU ``searchsorted`` is a loop), beyond that by a binary
    search."""
    import jax.numpy as jnp
    import numpy as np

    e = np.asarray(edges, dtype=float)
    n = len(e)
    if decreasing:  # x >= x_j  <=>  g(x) <= g(x_j)
        value, e = -value, -e
    if n <= 32:
        i = sum((value >= x).astype(jnp.int32) for x in e[1:-1]) if n > 2 else jnp.zeros(value.shape, jnp.int32)
    else:
        i = jnp.searchsorted(jnp.asarray(e), value, side="right") - 1
        i = jnp.where(value == e[-1], n - 2, i)
    outside = (value < e[0]) | (value > e[-1])
    return jnp.where(outside, n - 1, i)


def add_with_squares(tallies: dict, name: str, index: tuple, v) -> None:
    """tallies[name] and tallies[name + "_sq"] at ``index`` (one index per leading axis) plus v and v^2, in one
    scatter: XLA's CPU scatter costs per index, not per value added.  v: one value per lane (and any trailing
    axes of the tally)."""
    import jax.numpy as jnp

    axis = len(index)
    pair = jnp.stack([tallies[name], tallies[name + "_sq"]], axis=axis)
    pair = pair.at[index].add(jnp.stack([v, v * v], axis=1))
    tallies[name], tallies[name + "_sq"] = jnp.take(pair, 0, axis=axis), jnp.take(pair, 1, axis=axis)


class ChunkedRound:
    """One round of a walk, run in chunks of at most ``steps`` iterations of its loop on every device
    (:meth:`advance`), so that the caller regains control between chunks (Ctrl-C, a progress bar) however long
    the round.  The chunks change nothing: every device applies the same compiled loop body to its own state in
    the same order whatever their sizes, so the tallies are those of the round run at once, bit for bit.

    ``runs[L](state, steps) -> (state, status)`` runs level L (a walk that gathers its last paths into fewer
    lanes has one level per lane count); ``status`` is an int array (devices, 3): whether the device has ended
    the level, the paths it has started and its lanes alive.  ``compacts[L - 1](state)`` moves every device to
    level L once all have ended level L - 1; ``finish(state)`` gives the tallies summed over the devices."""

    def __init__(self, state, runs, compacts, finish, result=None):
        self.state, self.runs, self.compacts, self._finish = state, runs, compacts, finish
        self._result = result or (lambda tallies: tallies)
        self.level, self.done, self.started, self.alive = 0, False, 0, 0

    @property
    def finished(self) -> int:
        """Paths ended so far (escaped, capped or failed)."""
        return self.started - self.alive

    def advance(self, steps: int) -> bool:
        """Run at most ``steps`` loop iterations on each device (waiting for them); returns whether the round is
        done."""
        import numpy as np

        if self.done:
            return True
        with float64():
            self.state, status = self.runs[self.level](self.state, int(steps))
            status = np.asarray(status)
        self.started, self.alive = int(status[:, 1].sum()), int(status[:, 2].sum())
        if status[:, 0].all():
            if self.level + 1 < len(self.runs):
                self.level += 1
                with float64():
                    self.state = self.compacts[self.level - 1](self.state)
            else:
                self.done = True
        return self.done

    def tallies(self) -> dict:
        """The round's tallies (once :meth:`advance` has returned True), as the walk's ``run_round`` gives them."""
        if not self.done:
            raise RuntimeError("the round is not done")
        with float64():
            return self._result(self._finish(self.state))

    def run(self) -> dict:
        """Run the round to its end at once; its tallies."""
        while not self.advance(2**62):
            pass
        return self.tallies()


def device_local(tree):
    """A sharded state's leaves as one device sees them under ``shard_map`` (the leading axis of 1 removed)."""
    import jax

    return jax.tree_util.tree_map(lambda a: a[0], tree)


def device_stacked(tree):
    """The inverse of :func:`device_local`: a leading axis of 1, to be stacked over the mesh's devices."""
    import jax

    return jax.tree_util.tree_map(lambda a: a[None], tree)
