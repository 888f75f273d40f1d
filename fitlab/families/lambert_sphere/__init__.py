r"""The Lambert-sphere BRDF (d'Eon, EGSR 2021): fitlab's first family.

Registers, in one place, everything the family contributes: its targets
(:mod:`.targets`: H0, H1, H2, l, m, B, C, D, F, kd_of_c, c_of_kd, fm1, fast_brdf,
sample_weight, sample_exponent; with their data sets, grids and exact tables),
their forms, published presets and the libraries of ``fitlab discover``
(:mod:`.forms`), the exact engine (:mod:`.exact`) behind their training,
validation and residual sets, the runtime models and the generated program
(:mod:`.program`), and as hooks its Monte Carlo (:mod:`.mc`), tables, report
methods and audit (:mod:`.report`), render (:mod:`.mitsuba`) and benchmarks
(:mod:`.bench`); the studies that write docs/ are in :mod:`.studies`.
docs/model.md states the model.
"""

from fitlab.core import Family, manifest_hooks, register_family
from fitlab.families.lambert_sphere.forms import FORMS
from fitlab.families.lambert_sphere.program.spec import PROGRAM
from fitlab.families.lambert_sphere.targets import TARGETS

__all__ = ["FAMILY", "MANIFEST"]

#: what the registry knows of the family before importing it (a literal, read from this file without running it:
#: fitlab.core._registry): its targets in order, its hooks (each the module that holds it, relative to this
#: package: "module", "module:NAME" or "module:NAME()", fitlab.core.manifest_hooks), its program; registering
#: checks the family against it
MANIFEST = {
    "targets": ("H0", "H1", "H2", "l", "m", "B", "C", "D", "F", "kd_of_c", "c_of_kd", "fm1", "fast_brdf",
                "sample_weight", "sample_exponent"),
    "hooks": {
        "brdf_grid": "targets.grids:brdf_grid()",
        "report": "report.methods",
        "tables": "targets.tabulate",  # write_tables, check_tables, TABLE_FILES
        "audit": "report.audit",  # audit
        "render": "mitsuba.render",  # check_generated, llvm_problem, render_comparison, RenderError
        "simulate": "mc.simulate:SIMULATE",  # a fitlab.scenes.SimulateHook: the scene schema and the walk
        "bench": "bench",  # bench_exact, bench_codegen, bench_mc, bench_render
        "table_export": "program.table_export",  # generate, LANGUAGES, NODES, DEFAULT_NODES, DEFAULT_LOOKUP, ...
        "images": "program.images",  # IMAGES: the texture as fitlab export writes it
    },
    "program": True,
    "default_program": True,  # fitlab codegen without --family prints this program
}


def _libraries():
    from fitlab.families.lambert_sphere.forms.libraries import LIBRARIES

    return LIBRARIES


FAMILY = register_family(
    Family(
        name="lambert_sphere",
        description="Lambert-sphere BRDF (d'Eon, EGSR 2021)",
        targets=tuple(TARGETS.values()),
        forms=FORMS,
        libraries=_libraries,
        codegen=PROGRAM,
        default_program=MANIFEST["default_program"],
        # each imports its module only when a command asks for it (JAX, Mitsuba, scipy's heavier parts stay
        # unloaded until then)
        hooks=manifest_hooks(__name__, MANIFEST["hooks"]),
    )
)
