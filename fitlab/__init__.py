"""fitlab: curve fitting and symbolic regression for analytic BRDFs.

First of all the Lambert-sphere BRDF (d'Eon, EGSR 2021).  Data flow:
exact -> forms -> fit -> codegen, with mc and report beside them.
"""

import jax

# fitlab works in float64 everywhere; set once, on import.
jax.config.update("jax_enable_x64", True)

__version__ = "0.1.0"
