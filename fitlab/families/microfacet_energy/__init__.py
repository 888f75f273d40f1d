r"""The microfacet_energy family: Kulla-Conti energy compensation of single-scattering BRDFs (GGX with
separable or height-correlated Smith masking-shadowing, Oren-Nayar), after the blog article on
multiple-scattering BRDFs ("Energy Compensation") and Kulla and Conti (2017).

:class:`MicrofacetEnergy` declares it: its targets (:mod:`.targets`: E, 1 - E and E_avg of each model, named
E_ggx_sep, one_minus_E_ggx_sep, E_avg_ggx_sep, E_ggx_cor, ..., E_on, one_minus_E_on, E_avg_on, and the lobe
parameters of :mod:`.targets.lobes`; each target's generated routine has its name), their forms and the
published presets (:mod:`.forms`), and the libraries of ``fitlab discover`` (:mod:`.forms.libraries`).  The
exact engine is :mod:`.exact` (directional albedo E(mu, alpha), its average E_avg(alpha), the compensation lobe
f_ms, with F = 1); :mod:`.targets.tabulate` writes its tables and :mod:`.targets.datasets` reads them; :mod:`.mc`
is the Monte Carlo random walk on Smith microsurfaces (``fitlab simulate``), :mod:`.lobes` simulates the lobes by
order and fits them; the studies that write docs/ are in ``studies.microfacet_energy``, outside the package.  Its
program (:data:`.program.spec.PROGRAM`, ``fitlab codegen --family microfacet_energy``) prints every fitted albedo
and lobe parameter as a routine, and the multiple-scattering lobes and Kulla-Conti's f_ms composed of them.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

from fitlab.codegen.program import HasProgram
from fitlab.core import Benchmarks, Family, HasBenchmarks, HasImages, HasMonteCarlo, HasTables, Tables
from fitlab.discover.library import HasLibraries

if TYPE_CHECKING:
    from fitlab.codegen.program import ProgramSpec
    from fitlab.core import Target
    from fitlab.discover.library import Library
    from fitlab.export import ImageSpec
    from fitlab.forms import Form
    from fitlab.scenes import Simulation

__all__ = ["MicrofacetEnergy"]


class MicrofacetEnergy(
    Family, HasProgram, HasLibraries, HasTables, HasMonteCarlo, HasImages, HasBenchmarks, name="microfacet_energy",
    description="Kulla-Conti energy compensation: albedos of GGX (separable and height-correlated Smith) and "
                "Oren-Nayar",
    target_names=(
        "E_ggx_sep", "one_minus_E_ggx_sep", "E_avg_ggx_sep", "E_ggx_cor", "one_minus_E_ggx_cor", "E_avg_ggx_cor",
        "E_on", "one_minus_E_on", "E_avg_on",
        "ms_blog_eta_diffuse", "ms_blog_flattening_diffuse", "ms_blog_scale_diffuse", "ms_tilt_sigma_diffuse",
        "ms_tilt_eta_diffuse", "ms_tilt_flattening_diffuse", "ms_tilt_b_diffuse", "ms_tilt_k_diffuse",
        "ms_blog_eta_conductor", "ms_blog_flattening_conductor", "ms_blog_scale_conductor",
        "ms_tilt_sigma_conductor", "ms_tilt_eta_conductor", "ms_tilt_flattening_conductor", "ms_tilt_b_conductor",
        "ms_tilt_k_conductor",
    ),
):  # fmt: skip
    # each method imports what it returns (JAX stays unloaded until a command needs it)

    def targets(self) -> Sequence[Target]:
        from fitlab.families.microfacet_energy.targets import TARGETS

        return tuple(TARGETS.values())

    def forms(self) -> Sequence[Form]:
        from fitlab.families.microfacet_energy.forms import FORMS

        return FORMS

    def program(self) -> ProgramSpec:
        from fitlab.families.microfacet_energy.program.spec import PROGRAM

        return PROGRAM

    def libraries(self) -> Mapping[str, tuple[Library, ...]]:
        from fitlab.families.microfacet_energy.forms.libraries import LIBRARIES

        return LIBRARIES

    def tables(self) -> Tables:
        from fitlab.families.microfacet_energy.targets import tabulate

        return tabulate

    def simulation(self) -> Simulation:
        from fitlab.families.microfacet_energy.mc.simulate import SIMULATE

        return SIMULATE

    def images(self) -> Mapping[str, ImageSpec]:
        from fitlab.families.microfacet_energy.program.images import IMAGES

        return IMAGES

    def benchmarks(self) -> Benchmarks:
        from fitlab.families.microfacet_energy.mc.bench import bench_mc

        return Benchmarks(mc=bench_mc)  # the microsurface walk's throughput
