"""fitlab: curve fitting and symbolic regression for analytic BRDFs.

First of all the Lambert-sphere BRDF (d'Eon, EGSR 2021).  Data flow:
exact -> forms -> fit -> codegen, with mc and report beside them.

fitlab's JAX computations run in float64 (each entry point switches x64 on for
its own call, :func:`fitlab.core.float64`); importing fitlab leaves JAX's global
configuration as it was, and imports no JAX.
"""

__version__ = "0.1.0"
