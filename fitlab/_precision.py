r"""fitlab's JAX computations run in float64 without touching the global JAX configuration.

``import fitlab`` leaves ``jax_enable_x64`` as the user set it (a user's
``jnp.ones(1).dtype`` stays float32 by default).  Every public entry point where
fitlab traces or runs JAX code is wrapped in :func:`float64`, which switches x64
on for the duration of the call only (``jax.enable_x64``, a thread-local config
context) and restores the previous setting on return or on an exception.

A function traced under x64 must also be called under x64 (the arguments'
dtypes, and JAX's jit caches, depend on the setting): wrap the entry point that
both traces and runs, not an inner helper.  JAX is imported on first use, so
importing this module (and ``fitlab.core``, ``fitlab._montecarlo``) imports no JAX.
"""

from __future__ import annotations

import contextlib

__all__ = ["float64"]


@contextlib.contextmanager
def _x64():
    import jax

    with jax.enable_x64(True):
        yield


def float64(fn=None):
    """Run JAX in float64 within a call or a block; the global setting is left as it was.

    ``@float64`` (or ``@float64()``) on a function: every call of it runs with ``jax_enable_x64`` on.
    ``with float64(): ...``: the same for a block.  Nested and re-entrant uses are fine.
    """
    if fn is None:
        return _x64()
    return _x64()(fn)
