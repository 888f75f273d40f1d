r"""Cost of the Python paths: ns per evaluation of the numpy functions, throughput of the JAX path.

Both are timed on the same seeded random inputs as the C
(:func:`fitlab.report.programs.timing_inputs`), best of ``repeat`` rounds, each
round calling every method once in turn (:func:`fitlab.timing.interleaved_best`: a change of
machine load hits all methods alike).  The JAX path is ``jax.jit`` of the
method's sympy expression lambdified to jax.numpy
(:func:`fitlab.forms.symbolic.lambdify_jax`), float64, on the default device;
compilation (the first call) is excluded.
"""

from __future__ import annotations

from fitlab.core import float64
from fitlab.forms.symbolic import lambdify_jax, symbols
from fitlab.report.methods import brdf_inputs
from fitlab.timing import best_seconds, interleaved_best

__all__ = ["best_seconds", "interleaved_best", "numpy_costs", "jax_costs"]


def numpy_costs(methods, inputs: dict, repeat: int, tick=None) -> dict:
    """{method name: ns per evaluation} of ``method.evaluate`` vectorised over ``inputs``."""
    args = [inputs[n] for n in brdf_inputs()]
    fns = {m.name: (lambda m=m: m.evaluate(*args)) for m in methods}
    return {k: t / args[0].size * 1e9 for k, t in interleaved_best(fns, repeat, tick).items()}


@float64
def jax_costs(methods, inputs: dict, repeat: int, tick=None) -> dict:
    """{method name: evaluations per second} of jit(method.expr); every function is compiled first."""
    import jax
    import jax.numpy as jnp

    names = brdf_inputs()
    args = [jnp.asarray(inputs[n], dtype=jnp.float64) for n in names]
    fns = {}
    for m in methods:
        f = jax.jit(lambdify_jax(symbols(names), m.expr))
        jax.block_until_ready(f(*args))  # compile
        fns[m.name] = lambda f=f: jax.block_until_ready(f(*args))
        if tick:
            tick()
    return {k: args[0].size / t for k, t in interleaved_best(fns, repeat).items()}
