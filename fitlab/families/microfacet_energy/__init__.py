r"""The microfacet_energy family: Kulla-Conti energy compensation of single-scattering BRDFs (GGX with
separable or height-correlated Smith masking-shadowing, Oren-Nayar), after the blog article on
multiple-scattering BRDFs ("Energy Compensation") and Kulla and Conti (2017).

Registers its targets (:mod:`.targets`: E, 1 - E and E_avg of each model, named E_ggx_sep,
one_minus_E_ggx_sep, E_avg_ggx_sep, E_ggx_cor, ..., E_on, one_minus_E_on, E_avg_on; each target's
generated routine has its name), their forms and the published presets (:mod:`.forms`), and the
libraries of ``fitlab discover`` (:mod:`.libraries`).  The exact engine is :mod:`.exact` (directional
albedo E(mu, alpha), its average E_avg(alpha), the compensation lobe f_ms, with F = 1); :mod:`.tabulate`
writes its tables and :mod:`.datasets` reads them; :mod:`.microsurface` is the Monte Carlo random walk
on Smith microsurfaces (``fitlab simulate``), :mod:`.study` the energy-compensation study.  Its program
(``codegen``: :data:`.lobes.program.PROGRAM`, ``fitlab codegen --family microfacet_energy``) prints every
fitted albedo and lobe parameter as a routine, and the multiple-scattering lobes and Kulla-Conti's f_ms
composed of them.
"""

import importlib

from fitlab.core import Family, register_family
from fitlab.families.microfacet_energy.forms import FORMS
from fitlab.families.microfacet_energy.lobes.program import PROGRAM
from fitlab.families.microfacet_energy.targets import TARGETS

__all__ = ["FAMILY"]


def _lazy(module: str):
    """A hook that imports ``module`` of this family only when a command asks for it (JAX stays unloaded)."""
    return lambda: importlib.import_module(f"{__name__}.{module}")


def _libraries():
    from fitlab.families.microfacet_energy.libraries import LIBRARIES

    return LIBRARIES


def _simulate():
    from fitlab.families.microfacet_energy.microsurface.simulate import SIMULATE

    return SIMULATE


FAMILY = register_family(
    Family(
        name="microfacet_energy",
        description="Kulla-Conti energy compensation: albedos of GGX (separable and height-correlated Smith) and "
                    "Oren-Nayar",
        targets=tuple(TARGETS.values()),
        forms=FORMS,
        libraries=_libraries,
        codegen=PROGRAM,
        hooks={
            "tables": _lazy("tabulate"),  # write_tables, check_tables, TABLE_FILES, FAMILY_NAME
            "simulate": _simulate,  # a fitlab.scenes.SimulateHook: the scene schema and the walk
            "bench": _lazy("microsurface.bench"),  # bench_mc: the microsurface walk's throughput
        },
    )
)
