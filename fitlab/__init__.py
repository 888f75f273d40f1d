"""fitlab: curve fitting and symbolic regression for analytic BRDFs.

First of all the Lambert-sphere BRDF (d'Eon, EGSR 2021).  Data flow:
exact -> forms -> fit -> codegen, with mc and report beside them.

fitlab's JAX computations run in float64 (each entry point switches x64 on for
its own call, :func:`fitlab.core.float64`); importing fitlab leaves JAX's global
configuration as it was, and imports no JAX.

``fitlab.fit_table(inputs, values, form)`` and ``fitlab.fit_function(f, domain, form)`` fit a form of one's
own to a table of one's own (:mod:`fitlab.fit.user`; docs/your_own_data.md); they are imported on first use.
"""

__version__ = "0.1.0"

#: the functions ``fitlab.NAME`` gives, imported on first use (so that ``import fitlab`` imports no JAX or sympy)
_LAZY = {
    "fit_table": "fitlab.fit.user",
    "fit_function": "fitlab.fit.user",
    "read_csv_table": "fitlab.fit.user",
    "UserFit": "fitlab.fit.user",
    "UserDataError": "fitlab.fit.user",
}


def __getattr__(name):
    """``fitlab.fit_table``, ``fitlab.fit_function`` (fits of a table of one's own, :mod:`fitlab.fit.user`) and
    their types, imported on first use."""
    if name in _LAZY:
        import importlib

        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'fitlab' has no attribute {name!r}")


def __dir__():
    return sorted([*globals(), *_LAZY])
