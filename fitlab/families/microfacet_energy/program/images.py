r"""The family's tables as engines load them (its images for ``fitlab export``; docs/tables.md).

* ``dfg_karis``: the split-sum DFG table of height-correlated GGX (:func:`..exact.split_sum`), channels
  R = A (scale of F0), G = B (bias), E_F = F0 R + F90 G under Schlick's F (Karis 2013, "Real Shading in
  Unreal Engine 4", whose table has the same two channels; its Smith term was Schlick's separable
  approximation, here it is the exact height-correlated G2 of RTR4 eq. 9.31).
* ``dfg_filament``: the same integrals in the channels of Filament's multiple-scattering DFG table, R = B,
  G = A + B = E (the albedo with F = 1), read as E_F = mix(R, G, F0) (F90 = 1), and G gives the energy
  compensation 1 + F0 (1 / G - 1).
* ``E_ggx_sep``, ``E_ggx_cor``, ``E_on``: per model, R = E(mu, alpha), G = 1 - E (stored apart because 1 - E
  computed from a stored E keeps only the absolute precision of E, where Kulla-Conti's lobe needs its relative
  precision as E -> 1), B = E_avg(alpha) of the row (Kulla-Conti's normalisation, 2 int_0^1 E mu dmu).

Axes, texel centres (the addressing of a texture read with normalised coordinates and the GPU's filtering):
column i (x) holds mu_o = (i + 1/2) / width; row j (y, row 0 first) holds, for the DFG tables, the perceptual
roughness r = (j + 1/2) / height with alpha = r^2 (Karis's and Filament's convention), and for the E tables
alpha = (j + 1/2) / height itself (the family's targets' axis).  Square tables, ``size`` texels a side.
"""

from __future__ import annotations

import numpy as np

from fitlab.export import Image, ImageSpec, texel_centres
from fitlab.families.microfacet_energy.exact import average_albedo, directional_albedo, split_sum
from fitlab.families.microfacet_energy.targets import MODEL_SUFFIX

__all__ = ["IMAGES", "SIZES", "DEFAULT_SIZE", "DFG_MODEL", "dfg", "albedo_table"]

#: texels a side the tables can have
SIZES = tuple(range(4, 1025))
#: the size ``fitlab export`` writes unless told
DEFAULT_SIZE = 64
#: the BRDF of the DFG tables
DFG_MODEL = "ggx_correlated"
_MU_AXIS = "x (columns): mu_o = cos theta_o = (i + 0.5) / width, texel centres"
_ROUGHNESS_AXIS = (
    "y (rows): perceptual roughness r = (j + 0.5) / height, texel centres; GGX alpha = r^2; "
    "GGX with height-correlated Smith G2"
)
_ALPHA_AXIS = "y (rows): alpha = (j + 0.5) / height, texel centres (the GGX alpha, or Oren-Nayar's sigma = alpha pi/2)"


def _rows(size: int, tick) -> tuple[np.ndarray, np.ndarray]:
    """(A, B), each (size, size), rows of perceptual roughness, columns of mu."""
    mu, roughness = texel_centres(size), texel_centres(size)
    scale, bias = np.empty((size, size)), np.empty((size, size))
    for j, r in enumerate(roughness):
        scale[j], bias[j] = split_sum(mu, r * r, DFG_MODEL)
        tick()
    return scale, bias


def dfg(size: int, convention: str, tick=lambda: None) -> Image:
    """The split-sum table ``dfg_karis`` (convention "karis") or ``dfg_filament`` ("filament")."""
    scale, bias = _rows(size, tick)
    if convention == "karis":
        data, channels = (
            (scale, bias),
            ("A, the scale of F0: E_F = F0 R + F90 G under Schlick's F", "B, the bias (the weight of F90)"),
        )
        lead = "split-sum DFG (Karis): E_F(mu, alpha) = F0 A + F90 B, F = F0 + (F90 - F0)(1 - w_o.h)^5"
    elif convention == "filament":
        data, channels = (
            (bias, scale + bias),
            (
                "B, int (f/F) Fc mu_i dw_i: E_F = mix(R, G, F0) with F90 = 1",
                "E = A + B, the albedo with F = 1: compensation 1 + F0 (1/G - 1)",
            ),
        )
        lead = "split-sum DFG, Filament's multiple-scattering convention: E_F = (1 - F0) B + F0 (A + B)"
    else:
        raise ValueError(f"convention must be karis or filament, not {convention!r}")
    return Image(f"dfg_{convention}", np.stack(data, axis=2), channels, (lead, _MU_AXIS, _ROUGHNESS_AXIS))


def albedo_table(model: str, size: int, tick=lambda: None) -> Image:
    """``E_<suffix>`` of ``model``: E, 1 - E and E_avg of the row (module docstring)."""
    mu, alpha = texel_centres(size), texel_centres(size)
    e = np.empty((size, size))
    for j, a in enumerate(alpha):
        e[j] = directional_albedo(mu, a, model)
        tick()
    e_avg = average_albedo(alpha, model)
    tick()
    data = np.stack((e, 1.0 - e, np.broadcast_to(e_avg[:, None], e.shape)), axis=2)
    channels = (
        "E(mu_o, alpha), the directional albedo with F = 1",
        "1 - E, the energy Kulla-Conti's lobe restores",
        "E_avg(alpha) = 2 int_0^1 E mu dmu, constant along the row",
    )
    return Image(f"E_{MODEL_SUFFIX[model]}", data, channels, (f"directional albedo of {model}", _MU_AXIS, _ALPHA_AXIS))


def _dfg_spec(convention: str, description: str) -> ImageSpec:
    return ImageSpec(
        description,
        lambda size, tick=lambda: None: dfg(size, convention, tick),
        SIZES,
        DEFAULT_SIZE,
        steps=lambda size: size,
    )


def _albedo_spec(model: str) -> ImageSpec:
    # Oren-Nayar as the blog writes it gains energy at small roughness (E up to 1.015), so 1 - E < 0 there:
    # no format limited to [0, 1]
    oren_nayar = model.startswith("oren_nayar")
    formats = ("exr", "exr-half", "ktx2", "ktx2-half", *(() if oren_nayar else ("png",)), "c", "glsl")
    return ImageSpec(
        f"E, 1 - E and E_avg of {model} on (mu_o, alpha)",
        lambda size, tick=lambda: None: albedo_table(model, size, tick),
        SIZES,
        DEFAULT_SIZE,
        steps=lambda size: size + 1,
        value_range=(-0.02, 1.02) if oren_nayar else (0.0, 1.0),
        formats=formats,
    )


#: the tables ``fitlab export`` writes for this family
IMAGES = {
    "dfg_karis": _dfg_spec("karis", "split-sum DFG of height-correlated GGX, Karis's channels (scale, bias of F0)"),
    "dfg_filament": _dfg_spec(
        "filament", "split-sum DFG of height-correlated GGX, Filament's multiple-scattering channels (B, E)"
    ),
    **{f"E_{suffix}": _albedo_spec(model) for model, suffix in MODEL_SUFFIX.items()},
}
