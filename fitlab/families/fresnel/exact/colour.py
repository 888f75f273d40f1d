r"""Colour-matching weights: how a reflectance spectrum F(lambda) becomes one value per RGB channel.

For a reflectance lit by D65 and seen by the CIE 1931 2-degree standard observer,

    XYZ = sum_lambda F(lambda) D65(lambda) (xbar, ybar, zbar)(lambda),    RGB = M XYZ,

with M the XYZ-to-linear-RGB matrix of the colour space (sRGB, whose white is D65; ACEScg, reached from
D65 by the CAT02 chromatic adaptation).  Each channel is then divided by its value for F = 1, so that a
spectrally constant reflectance gives that constant in every channel; the weights W_c(lambda) of a channel
sum to 1 (some are negative: the sRGB matching functions have negative lobes).  Wavelengths 360 to 780 nm
in steps of 1 nm (D65 as tabulated ends at 780 nm; the observer beyond carries about 1e-4 of Y).

The observer, the illuminant and the matrices come from colour-science (:func:`compute_channel_weights`,
the only function here that needs it); fitlab ships the weights it computes as a table
(fitlab/data/fresnel/colour_weights.csv, written and checked by ``fitlab tabulate``), which is what
:func:`channel_weights` reads, so that the exact reflectances need colour-science only to rebuild it.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np

from fitlab.numerics import choice
from fitlab.resources import tables_folder
from fitlab.store import read_table

__all__ = [
    "SPACES",
    "WAVELENGTHS",
    "WEIGHTS_FILE",
    "WEIGHTS_COLUMNS",
    "WEIGHTS_GRID",
    "compute_channel_weights",
    "read_weights",
    "channel_weights",
    "channel_wavelength",
]

#: the linear colour spaces, each with channels r, g, b
SPACES = ("srgb", "acescg")
#: the wavelengths (nm) of the weights
WAVELENGTHS = np.arange(360.0, 781.0)
WAVELENGTHS.setflags(write=False)
WEIGHTS_FILE = "colour_weights.csv"
WEIGHTS_COLUMNS = ("wavelength_nm", *(f"{s}_{c}" for s in SPACES for c in "rgb"))
#: the grid the table's header states
WEIGHTS_GRID = "wavelength_nm = 360..780 in steps of 1"


def compute_channel_weights() -> dict[str, np.ndarray]:
    """{space: W of shape (3, wavelengths)} from colour-science (module docstring)."""
    try:
        import colour
    except ImportError:
        raise ImportError(
            "the Fresnel family's colour weights need colour-science: pip install 'fitlab-brdf[fresnel]'"
        ) from None
    shape = colour.SpectralShape(float(WAVELENGTHS[0]), float(WAVELENGTHS[-1]), 1.0)
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(shape)
    d65 = colour.SDS_ILLUMINANTS["D65"].copy().align(shape)
    xyz = cmfs.values * d65.values[:, None]
    white = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    out = {}
    for space, name in (("srgb", "sRGB"), ("acescg", "ACEScg")):
        rgb = colour.XYZ_to_RGB(
            xyz, name, illuminant=white, chromatic_adaptation_transform="CAT02", apply_cctf_encoding=False
        )
        out[space] = (rgb / rgb.sum(axis=0)).T
    return out


def read_weights(folder) -> dict[str, np.ndarray]:
    """{space: W of shape (3, wavelengths)} of the table in ``folder``, its header, grid line and wavelength
    column checked (:class:`fitlab.store.TableError`)."""
    _, data = read_table(
        Path(folder) / WEIGHTS_FILE, WEIGHTS_COLUMNS, grid=WEIGHTS_GRID, points={"wavelength_nm": WAVELENGTHS}
    )
    out = {space: np.ascontiguousarray(data[:, 1 + 3 * i : 4 + 3 * i].T) for i, space in enumerate(SPACES)}
    for w in out.values():
        w.setflags(write=False)
    return out


@cache
def _packaged_weights() -> dict[str, np.ndarray]:
    return read_weights(tables_folder("fresnel", (WEIGHTS_FILE,)))


def channel_weights(space: str = "srgb") -> tuple[np.ndarray, np.ndarray]:
    """(wavelengths in nm, W of shape (3, wavelengths)) of ``space``, from the packaged table."""
    return WAVELENGTHS, _packaged_weights()[choice(space, "space", SPACES)]


def channel_wavelength(space: str, channel: int) -> float:
    """The mean wavelength of a channel's positive weights, sum lambda W+ / sum W+ (nm): the one wavelength
    where a method that takes n and k per channel (Gulbrandsen's map) reads them."""
    lam, w = channel_weights(space)
    positive = np.maximum(w[channel], 0.0)
    return float(lam @ positive / positive.sum())
