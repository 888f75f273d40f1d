r"""The Lambert-sphere BRDF (d'Eon, EGSR 2021): fitlab's first family.

:class:`LambertSphere` declares it: its targets (:mod:`.targets`: H0, H1, H2, l, m, B, C, D, F, kd_of_c, c_of_kd,
fm1, fast_brdf, sample_weight, sample_exponent; with their data sets, grids and exact tables), their forms,
published presets and the libraries of ``fitlab discover`` (:mod:`.forms`), the exact engine (:mod:`.exact`)
behind their training, validation and residual sets, the runtime models and the generated program
(:mod:`.program`), and, as capabilities, its Monte Carlo (:mod:`.mc`), tables, report methods and audit
(:mod:`.program.report`), render (:mod:`.mitsuba`) and benchmarks (:mod:`.program.bench`); the studies
that write docs/ are in ``studies.lambert_sphere``, outside the package.  docs/model.md states the model.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from fitlab.codegen.program import HasProgram
from fitlab.core import (
    Benchmarks,
    BrdfGrid,
    Family,
    HasAudit,
    HasBenchmarks,
    HasBrdfGrid,
    HasImages,
    HasMonteCarlo,
    HasRender,
    HasTableExport,
    HasTables,
    Outputs,
    Render,
    TableExport,
    Tables,
)
from fitlab.discover.library import HasLibraries
from fitlab.report.methods import BrdfReport, HasBrdfReport

if TYPE_CHECKING:
    from fitlab.codegen.program import ProgramSpec
    from fitlab.core import Target
    from fitlab.discover.library import Library
    from fitlab.export import ImageSpec
    from fitlab.forms import Form
    from fitlab.scenes import Simulation

__all__ = ["LambertSphere"]


class LambertSphere(
    Family, HasProgram, HasLibraries, HasTables, HasMonteCarlo, HasImages, HasBenchmarks, HasBrdfReport, HasAudit,
    HasBrdfGrid, HasTableExport, HasRender, name="lambert_sphere", description="Lambert-sphere BRDF (d'Eon, EGSR 2021)",
    target_names=("H0", "H1", "H2", "l", "m", "B", "C", "D", "F", "kd_of_c", "c_of_kd", "fm1", "fast_brdf",
                  "sample_weight", "sample_exponent"),
):  # fmt: skip
    # each method imports what it returns (JAX, Mitsuba, scipy's heavier parts stay unloaded until then)
    default_program = True  # fitlab codegen without --family prints this program

    def targets(self) -> Sequence[Target]:
        from fitlab.families.lambert_sphere.targets import TARGETS

        return tuple(TARGETS.values())

    def forms(self) -> Sequence[Form]:
        from fitlab.families.lambert_sphere.forms import FORMS

        return FORMS

    def program(self) -> ProgramSpec:
        from fitlab.families.lambert_sphere.program.spec import PROGRAM

        return PROGRAM

    def libraries(self) -> Mapping[str, tuple[Library, ...]]:
        from fitlab.families.lambert_sphere.forms.libraries import LIBRARIES

        return LIBRARIES

    def tables(self) -> Tables:
        from fitlab.families.lambert_sphere.targets import tabulate

        return tabulate

    def simulation(self) -> Simulation:
        from fitlab.families.lambert_sphere.mc.simulate import SIMULATE

        return SIMULATE

    def images(self) -> Mapping[str, ImageSpec]:
        from fitlab.families.lambert_sphere.program.images import IMAGES

        return IMAGES

    def benchmarks(self) -> Benchmarks:
        from fitlab.families.lambert_sphere.program import bench

        return Benchmarks(exact=bench.bench_exact, codegen=bench.bench_codegen, mc=bench.bench_mc,
                          render=bench.bench_render)  # fmt: skip

    def report(self) -> BrdfReport:
        from fitlab.families.lambert_sphere.program.report import methods

        return methods

    def audit(self, fits_dir: Path | None = None, *, show_progress: bool = False) -> Outputs:
        from fitlab.families.lambert_sphere.program.report.audit import audit

        return audit(fits_dir, show_progress=show_progress)

    def brdf_grid(self) -> BrdfGrid:
        from fitlab.families.lambert_sphere.targets.grids import brdf_grid

        return brdf_grid()

    def table_export(self) -> TableExport:
        from fitlab.families.lambert_sphere.program import table_export

        return table_export

    def render(self) -> Render:
        from fitlab.families.lambert_sphere.mitsuba import render

        return render
