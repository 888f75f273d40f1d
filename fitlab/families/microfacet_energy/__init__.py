r"""The microfacet_energy family: Kulla-Conti energy compensation of single-scattering BRDFs (GGX with
separable or height-correlated Smith masking-shadowing, Oren-Nayar), after the blog article on
multiple-scattering BRDFs ("Energy Compensation") and Kulla and Conti (2017).

Registers its targets (:mod:`.targets`: E, 1 - E and E_avg of each model, named E_ggx_sep,
one_minus_E_ggx_sep, E_avg_ggx_sep, E_ggx_cor, ..., E_on, one_minus_E_on, E_avg_on; each target's
generated routine has its name), their forms and the published presets (:mod:`.forms`), and the
libraries of ``fitlab discover`` (:mod:`.forms.libraries`).  The exact engine is :mod:`.exact` (directional
albedo E(mu, alpha), its average E_avg(alpha), the compensation lobe f_ms, with F = 1); :mod:`.targets.tabulate`
writes its tables and :mod:`.targets.datasets` reads them; :mod:`.mc` is the Monte Carlo random walk
on Smith microsurfaces (``fitlab simulate``), :mod:`.lobes` simulates the lobes by order and fits them, and
:mod:`.studies` holds the studies that write docs/.  Its program
(``codegen``: :data:`.program.spec.PROGRAM`, ``fitlab codegen --family microfacet_energy``) prints every
fitted albedo and lobe parameter as a routine, and the multiple-scattering lobes and Kulla-Conti's f_ms
composed of them.
"""

from fitlab.core import Family, manifest_hooks, register_family
from fitlab.families.microfacet_energy.forms import FORMS
from fitlab.families.microfacet_energy.program.spec import PROGRAM
from fitlab.families.microfacet_energy.targets import TARGETS

__all__ = ["FAMILY", "MANIFEST"]

#: what the registry knows of the family before importing it (a literal, read from this file without running it:
#: fitlab.core._registry): its targets in order, its hooks (each the module that holds it, relative to this
#: package; fitlab.core.manifest_hooks), its program; registering checks the family against it
MANIFEST = {
    "targets": (
        "E_ggx_sep", "one_minus_E_ggx_sep", "E_avg_ggx_sep", "E_ggx_cor", "one_minus_E_ggx_cor", "E_avg_ggx_cor",
        "E_on", "one_minus_E_on", "E_avg_on",
        "ms_blog_eta_diffuse", "ms_blog_flattening_diffuse", "ms_blog_scale_diffuse", "ms_tilt_sigma_diffuse",
        "ms_tilt_eta_diffuse", "ms_tilt_flattening_diffuse", "ms_tilt_b_diffuse", "ms_tilt_k_diffuse",
        "ms_blog_eta_conductor", "ms_blog_flattening_conductor", "ms_blog_scale_conductor",
        "ms_tilt_sigma_conductor", "ms_tilt_eta_conductor", "ms_tilt_flattening_conductor", "ms_tilt_b_conductor",
        "ms_tilt_k_conductor",
    ),
    "hooks": {
        "tables": "targets.tabulate",  # write_tables, check_tables, TABLE_FILES, FAMILY_NAME
        "simulate": "mc.simulate:SIMULATE",  # a fitlab.scenes.SimulateHook: the scene schema and the walk
        "bench": "bench",  # bench_mc: the microsurface walk's throughput
        "images": "program.images",  # IMAGES: the DFG and albedo tables of fitlab export
    },
    "program": True,
    "default_program": False,
}


def _libraries():
    from fitlab.families.microfacet_energy.forms.libraries import LIBRARIES

    return LIBRARIES


FAMILY = register_family(
    Family(
        name="microfacet_energy",
        description="Kulla-Conti energy compensation: albedos of GGX (separable and height-correlated Smith) and "
                    "Oren-Nayar",
        targets=tuple(TARGETS.values()),
        forms=FORMS,
        libraries=_libraries,
        codegen=PROGRAM,
        # each imports its module only when a command asks for it (JAX stays unloaded until then)
        hooks=manifest_hooks(__name__, MANIFEST["hooks"]),
    )
)
