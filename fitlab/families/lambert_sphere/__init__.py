r"""The Lambert-sphere BRDF (d'Eon, EGSR 2021): fitlab's first family.

Registers, in one place, everything the family contributes: its targets
(:mod:`.targets`: H0, H1, H2, l, m, B, C, D, F, kd_of_c, c_of_kd, fm1, fast_brdf),
their forms and published presets (:mod:`.forms`), the exact engine
(:mod:`.exact`) behind their training, validation and residual sets, the
libraries of ``fitlab discover`` (:mod:`.libraries`), the generated program
(:mod:`.program`), and its runtime models, Monte Carlo, tables, audit, render
and report methods as hooks.  docs/model.md states the model.
"""

import importlib

from fitlab.core import Family, register_family
from fitlab.families.lambert_sphere.forms import FORMS
from fitlab.families.lambert_sphere.program import PROGRAM
from fitlab.families.lambert_sphere.targets import TARGETS

__all__ = ["FAMILY"]


def _lazy(module: str):
    """A hook that imports ``module`` of this family only when a command asks for it (JAX, Mitsuba, scipy's
    heavier parts stay unloaded until then)."""
    return lambda: importlib.import_module(f"{__name__}.{module}")


def _libraries():
    from fitlab.families.lambert_sphere.libraries import LIBRARIES

    return LIBRARIES


def _brdf_grid():
    from fitlab.families.lambert_sphere.grids import brdf_grid

    return brdf_grid()


def _simulate():
    from fitlab.families.lambert_sphere.mc.simulate import SIMULATE

    return SIMULATE


def _report():
    from fitlab.families.lambert_sphere import report_methods

    return report_methods


FAMILY = register_family(
    Family(
        name="lambert_sphere",
        description="Lambert-sphere BRDF (d'Eon, EGSR 2021)",
        targets=tuple(TARGETS.values()),
        forms=FORMS,
        libraries=_libraries,
        codegen=PROGRAM,
        default_program=True,  # fitlab codegen without --family prints this program
        hooks={
            "brdf_grid": _brdf_grid,
            "report": _report,
            "tables": _lazy("tabulate"),  # write_tables, check_tables, TABLE_FILES
            "audit": _lazy("audit"),  # run_audit
            "render": _lazy("render"),  # check_generated, llvm_problem, render_comparison, RenderError
            "simulate": _simulate,  # a fitlab.scenes.SimulateHook: the scene schema and the walk
            "bench": _lazy("bench"),  # bench_exact, bench_codegen, bench_mc, bench_render
            "table_export": _lazy("table_export"),  # generate, LANGUAGES, NODES, DEFAULT_NODES, DEFAULT_LOOKUP, ...
        },
    )
)
