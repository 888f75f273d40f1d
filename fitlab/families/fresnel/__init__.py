r"""The Fresnel family: the reflectance of real materials (measured conductors, dielectrics) per channel of
linear sRGB, and the approximations engines use for it (RTR4 section 9.5).

:class:`Fresnel` declares it: its targets (:mod:`.targets`: ``F_<material>_<channel>``, F_c(mu) for mu = cos theta
in [0, 1]), their forms (:mod:`.forms`: Schlick, the generalised Schlick, Lazanyi-Schlick, Hoffman's F82-tint,
Gulbrandsen's), the exact engine (:mod:`.exact`: complex Fresnel per wavelength, colour-matching weights from
colour-science) and its table (:mod:`.targets.tabulate`, ``fitlab tabulate``); :mod:`.program.images` is its
preset table for ``fitlab export`` and the measured materials' F0 and F_avg other families read.  The study
that writes docs/fresnel.md is ``studies.fresnel.fresnel_study``, outside the package.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

from fitlab.core import Family, HasImages, HasMaterials, HasTables, MeasuredMaterial, Tables

if TYPE_CHECKING:
    from fitlab.core import Target
    from fitlab.export import ImageSpec
    from fitlab.forms import Form

__all__ = ["Fresnel"]

#: the measured materials, in the order of the targets (each has a target per linear sRGB channel)
MATERIAL_KEYS = ("ag", "al", "au", "cr", "cu", "ni", "w", "mo", "glass", "water", "diamond", "bk7")


class Fresnel(
    Family, HasTables, HasImages, HasMaterials, name="fresnel",
    description="Fresnel reflectance of real materials per sRGB channel, and Schlick, F82-tint, Gulbrandsen",
    target_names=tuple(f"F_{m}_{c}" for m in MATERIAL_KEYS for c in ("r", "g", "b")),
):  # fmt: skip
    def targets(self) -> Sequence[Target]:
        from fitlab.families.fresnel.targets import TARGETS

        return tuple(TARGETS.values())

    def forms(self) -> Sequence[Form]:
        from fitlab.families.fresnel.forms import FORMS

        return FORMS

    def tables(self) -> Tables:
        from fitlab.families.fresnel.targets import tabulate

        return tabulate

    def images(self) -> Mapping[str, ImageSpec]:
        from fitlab.families.fresnel.program.images import IMAGES

        return IMAGES

    def materials(self) -> Mapping[str, MeasuredMaterial]:
        from fitlab.families.fresnel.program.images import material_averages

        return material_averages()
