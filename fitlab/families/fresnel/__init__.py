r"""The Fresnel family: the reflectance of real materials (measured conductors, dielectrics) per channel of
linear sRGB, and the approximations engines use for it (RTR4 section 9.5).

Registers its targets (:mod:`.targets`: ``F_<material>_<channel>``, F_c(mu) for mu = cos theta in [0, 1]),
their forms (:mod:`.forms`: Schlick, the generalised Schlick, Lazanyi-Schlick, Hoffman's F82-tint,
Gulbrandsen's), the exact engine (:mod:`.exact`: complex Fresnel per wavelength, colour-matching weights
from colour-science) and its table (:mod:`.targets.tabulate`, the ``tables`` hook); :mod:`.program.images` is its preset table for
``fitlab export`` (the ``images`` hook).  The study
:mod:`.studies.fresnel_study` writes docs/fresnel.md.
"""

from fitlab.core import Family, manifest_hooks, register_family
from fitlab.families.fresnel.forms import FORMS
from fitlab.families.fresnel.targets import TARGETS

__all__ = ["FAMILY", "MANIFEST"]

#: what the registry knows of the family before importing it (a literal, read without running this file:
#: fitlab.core._registry)
MANIFEST = {
    "targets": (
        "F_ag_r", "F_ag_g", "F_ag_b", "F_al_r", "F_al_g", "F_al_b", "F_au_r", "F_au_g", "F_au_b",
        "F_cr_r", "F_cr_g", "F_cr_b", "F_cu_r", "F_cu_g", "F_cu_b", "F_ni_r", "F_ni_g", "F_ni_b",
        "F_w_r", "F_w_g", "F_w_b", "F_mo_r", "F_mo_g", "F_mo_b",
        "F_glass_r", "F_glass_g", "F_glass_b", "F_water_r", "F_water_g", "F_water_b",
        "F_diamond_r", "F_diamond_g", "F_diamond_b", "F_bk7_r", "F_bk7_g", "F_bk7_b",
    ),
    "hooks": {
        "tables": "targets.tabulate",  # write_tables, check_tables, TABLE_FILES, FAMILY_NAME
        "images": "program.images",  # IMAGES: the preset table of fitlab export
    },
    "program": False,
    "default_program": False,
}

FAMILY = register_family(
    Family(
        name="fresnel",
        description="Fresnel reflectance of real materials per sRGB channel, and Schlick, F82-tint, Gulbrandsen",
        targets=tuple(TARGETS.values()),
        forms=FORMS,
        hooks=manifest_hooks(__name__, MANIFEST["hooks"]),
    )
)
