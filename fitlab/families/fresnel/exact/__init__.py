r"""The exact engine of the Fresnel family: the reflectance of real materials per wavelength and per colour
channel, and its cosine-weighted average.

* :func:`fresnel_reflectance` (:mod:`.optics`): unpolarised F(mu) for a complex index n + i k
  (:func:`fitlab.physics.fresnel.fresnel_conductor`); :func:`normal_reflectance`; Gulbrandsen's map between (r, g)
  and (n, k).
* :data:`MATERIALS` (:mod:`.materials`): measured conductors and dielectrics, with the source of each
  index; :func:`reflectance` F_c(mu) per channel of linear sRGB or ACEScg, :func:`average_reflectance`.
* :func:`channel_weights` (:mod:`.colour`): the CIE 1931 observer under D65 as weights per channel, from
  the packaged table that colour-science computes (:func:`compute_channel_weights`).

docs/fresnel.md states the conventions and what each approximation costs in accuracy.
"""

from pathlib import Path

from fitlab import physics
from fitlab.families.fresnel.exact.colour import (
    SPACES,
    WAVELENGTHS,
    WEIGHTS_COLUMNS,
    WEIGHTS_FILE,
    WEIGHTS_GRID,
    channel_wavelength,
    channel_weights,
    compute_channel_weights,
    read_weights,
)
from fitlab.families.fresnel.exact.materials import (
    AVERAGE_ROUTES,
    BK7_SELLMEIER,
    CHANNELS,
    MATERIALS,
    Material,
    average_reflectance,
    cosine_average,
    get_material,
    reflectance,
)
from fitlab.families.fresnel.exact.optics import (
    fresnel_reflectance,
    gulbrandsen_index,
    gulbrandsen_parameters,
    normal_reflectance,
)

#: the engine's source files, part of the key of anything cached from it
SOURCES = (*sorted(Path(__file__).resolve().parent.glob("*.py")), *physics.sources("fresnel"))

__all__ = [
    "AVERAGE_ROUTES",
    "BK7_SELLMEIER",
    "CHANNELS",
    "MATERIALS",
    "Material",
    "SOURCES",
    "SPACES",
    "WAVELENGTHS",
    "WEIGHTS_COLUMNS",
    "WEIGHTS_FILE",
    "WEIGHTS_GRID",
    "average_reflectance",
    "channel_wavelength",
    "channel_weights",
    "compute_channel_weights",
    "cosine_average",
    "fresnel_reflectance",
    "get_material",
    "gulbrandsen_index",
    "gulbrandsen_parameters",
    "normal_reflectance",
    "read_weights",
    "reflectance",
]
