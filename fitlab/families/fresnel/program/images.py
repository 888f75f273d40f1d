r"""The family's preset table as engines load it (its images for ``fitlab export``; docs/tables.md).

``fresnel_presets``: one row per material (:data:`..exact.MATERIALS`, in order), one column per quantity
(:data:`COLUMNS`), and the linear sRGB channels R, G, B of each: the published constructions' parameters
(Schlick's and F82-tint's F0 = F(mu = 1), F82-tint's tint = F(mu = 1/7) / Schlick(mu = 1/7), Gulbrandsen's r and g;
:func:`..forms.construction`), the exact F_avg = 2 int_0^1 F mu dmu (the Fresnel average of Kulla-Conti's
coloured compensation), and the max |F - F_exact| of each construction over the target's validation angles,
measured when the table is built.  A C header or GLSL array of it is the preset table an engine compiles in;
values are float32 there (gold's red F0 exceeds 1, out of sRGB's gamut, so no [0, 1] format).
"""

from __future__ import annotations

import numpy as np

from fitlab.core import MeasuredMaterial, get_form, get_target
from fitlab.export import Image, ImageSpec
from fitlab.families.fresnel.exact import CHANNELS, MATERIALS, average_reflectance, reflectance
from fitlab.families.fresnel.forms import construction
from fitlab.families.fresnel.targets import target_name

__all__ = ["IMAGES", "COLUMNS", "ERROR_FLOOR", "preset_table", "material_averages"]

#: the table's columns: (name, what it holds), each with the three channels R, G, B
COLUMNS = (
    ("F0", "F(mu = 1): Schlick's F0 and F82-tint's F0"),
    ("tint", "F82-tint's tint: F(mu = 1/7) / Schlick(F0, 1/7) of the exact F"),
    ("r", "Gulbrandsen's reflectivity r = min(F0, 0.999)"),
    ("g", "Gulbrandsen's edge tint g of the measured n, k at the channel's mean wavelength, in [0, 1]"),
    ("F_avg", "the exact cosine-weighted average 2 int_0^1 F mu dmu"),
    (
        "error_schlick",
        "max |F - F_exact| of Schlick with that F0 over the validation angles (at least 1e-12: a "
        "smaller max is rounding, stored as its bound 1e-12)",
    ),
    ("error_f82_tint", "max |F - F_exact| of F82-tint with that F0 and tint (at least 1e-12)"),
    ("error_gulbrandsen", "max |F - F_exact| of Gulbrandsen with that r and g (at least 1e-12)"),
)
#: the smallest error the table states: below it the difference is the rounding of two float64 evaluations, which
#: depends on the order of their sums (BLAS threads), so the table would not regenerate byte for byte
ERROR_FLOOR = 1e-12
_CONSTRUCTIONS = {
    "error_schlick": ("schlick", "normal"),
    "error_f82_tint": ("f82_tint", "f82"),
    "error_gulbrandsen": ("gulbrandsen", "gulbrandsen"),
}


def _error(material: str, channel: str, form_name: str, preset: str) -> float:
    target = get_target(target_name(material, channel))
    valid = target.validation()
    form = get_form(target.name, form_name)
    return max(float(np.max(np.abs(form(preset, valid.inputs["mu"]) - valid.y))), ERROR_FLOOR)


def preset_table(tick=lambda: None) -> Image:
    """The table (module docstring)."""
    data = np.empty((len(MATERIALS), len(COLUMNS), len(CHANNELS)))
    for i, material in enumerate(MATERIALS):
        data[i, 4] = average_reflectance(material)
        for c, channel in enumerate(CHANNELS):
            facts = construction(material, channel)
            data[i, :4, c] = facts["F0"], facts["tint"], facts["r"], facts["g"]
            for j, (column, _) in enumerate(COLUMNS[5:], start=5):
                data[i, j, c] = _error(material, channel, *_CONSTRUCTIONS[column])
        tick()
    rows = tuple(f"row {i}: {key} ({m.name})" for i, (key, m) in enumerate(MATERIALS.items()))
    columns = tuple(f"column {j}: {name}, {text}" for j, (name, text) in enumerate(COLUMNS))
    channels = tuple(f"linear sRGB {c} (D65, CIE 1931 2-degree observer)" for c in ("red", "green", "blue"))
    return Image(
        "fresnel_presets",
        data,
        channels,
        ("Fresnel presets of measured materials, per linear sRGB channel", *columns, *rows),
    )


def material_averages() -> dict[str, MeasuredMaterial]:
    """{material key: its F0 and exact F_avg as linear sRGB triples}: what another family's study takes through
    the registry (``fitlab.core.family_with(fitlab.core.HasMaterials)``), e.g. the microfacet family's coloured
    compensation."""
    return {key: MeasuredMaterial(name=m.name, kind=m.kind, F0=reflectance(key, 1.0), F_avg=average_reflectance(key))
            for key, m in MATERIALS.items()}  # fmt: skip


#: the tables ``fitlab export`` writes for this family
IMAGES = {
    "fresnel_presets": ImageSpec(
        "per material: F0, F82 tint, Gulbrandsen's r and g, exact F_avg, each construction's max error (RGB)",
        lambda size, tick=lambda: None: preset_table(tick),
        (len(MATERIALS),),
        len(MATERIALS),
        steps=lambda size: len(MATERIALS),
        value_range=(0.0, 2.0),
        formats=("exr", "ktx2", "c", "glsl"),
    ),
}
