r"""The materials: their complex index per wavelength, and their reflectance per colour channel.

Conductors: measured optical constants n(lambda), k(lambda) from the luxpop.com database (Palik's handbook
for nickel) as Mitsuba 3 ships them, copied into fitlab/data/fresnel/KEY.csv (each file's header names its
source), interpolated linearly in wavelength.  Iron and zinc, two of RTR4 Figure 9.22's metals, are not
among them, so they are left out rather than taken from an unnamed source.

Dielectrics: glass (1.5), water (1.333) and diamond (2.42), constant over wavelength, and the dispersive
Schott N-BK7 by its published Sellmeier formula (SCHOTT optical glass data sheet):
n^2 = 1 + sum_i B_i lambda^2 / (lambda^2 - C_i), lambda in micrometres.

Reflectance per channel: F_c(mu) = sum_lambda W_c(lambda) F(lambda, mu) with the weights of
:mod:`.colour` (the CIE 1931 2-degree observer under D65, into linear sRGB or ACEScg, each channel's
weights summing to 1, so that a spectrally constant F gives that constant in every channel).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache, lru_cache

import numpy as np

from fitlab.families.fresnel.exact.colour import SPACES, channel_weights
from fitlab.families.fresnel.exact.optics import fresnel_reflectance
from fitlab.numerics import choice, gauss_legendre, real_array
from fitlab.resources import packaged_tables
from fitlab.store import read_table

__all__ = [
    "Material",
    "MATERIALS",
    "CHANNELS",
    "get_material",
    "reflectance",
    "average_reflectance",
    "AVERAGE_ROUTES",
    "cosine_average",
]

#: the channels of both colour spaces, in order
CHANNELS = ("r", "g", "b")
#: the two independent quadratures of :func:`average_reflectance`
AVERAGE_ROUTES = ("mu", "theta")

#: Schott N-BK7: (B1, B2, B3), (C1, C2, C3) in micrometres^2 (SCHOTT optical glass data sheet, N-BK7)
BK7_SELLMEIER = ((1.03961212, 0.231792344, 1.01046945), (0.00600069867, 0.0200179144, 103.560653))


@dataclass(frozen=True)
class Material:
    """One material: key (as in target names), name, kind ("conductor" or "dielectric"), the source of its
    index, and either a file of optical constants (conductors), a constant index, or a Sellmeier formula."""

    key: str
    name: str
    kind: str
    source: str
    file: str | None = None
    constant: float | None = None
    sellmeier: tuple | None = None

    def index(self, wavelength_nm) -> np.ndarray:
        """The complex index n + i k at the wavelengths (nm)."""
        lam = np.asarray(wavelength_nm, dtype=float)
        if self.file is not None:
            table = _constants(self.file)
            if lam.min() < table[0, 0] or lam.max() > table[-1, 0]:
                raise ValueError(f"{self.name}: optical constants cover {table[0, 0]:g} to {table[-1, 0]:g} nm")
            return np.interp(lam, table[:, 0], table[:, 1]) + 1j * np.interp(lam, table[:, 0], table[:, 2])
        if self.sellmeier is not None:
            x2 = (lam / 1000.0) ** 2
            b, c = self.sellmeier
            return np.sqrt(1.0 + sum(bi * x2 / (x2 - ci) for bi, ci in zip(b, c))) + 0j
        return np.full(lam.shape, float(self.constant)) + 0j


_LUXPOP = "luxpop.com database, as shipped in Mitsuba 3 (fitlab/data/fresnel/{0}.csv)"
MATERIALS = {
    m.key: m
    for m in (
        Material("ag", "silver", "conductor", _LUXPOP.format("ag"), file="ag.csv"),
        Material("al", "aluminium", "conductor", _LUXPOP.format("al"), file="al.csv"),
        Material("au", "gold", "conductor", _LUXPOP.format("au"), file="au.csv"),
        Material("cr", "chromium", "conductor", _LUXPOP.format("cr"), file="cr.csv"),
        Material("cu", "copper", "conductor", _LUXPOP.format("cu"), file="cu.csv"),
        Material(
            "ni",
            "nickel",
            "conductor",
            "Palik (1985) via luxpop.com, as shipped in Mitsuba 3 (fitlab/data/fresnel/ni.csv)",
            file="ni.csv",
        ),
        Material("w", "tungsten", "conductor", _LUXPOP.format("w"), file="w.csv"),
        Material("mo", "molybdenum", "conductor", _LUXPOP.format("mo"), file="mo.csv"),
        Material("glass", "glass (n = 1.5)", "dielectric", "a constant index of 1.5 (RTR4 section 9.5)", constant=1.5),
        Material("water", "water (n = 1.333)", "dielectric", "a constant index of 1.333", constant=1.333),
        Material("diamond", "diamond (n = 2.42)", "dielectric", "a constant index of 2.42", constant=2.42),
        Material(
            "bk7",
            "N-BK7 glass (dispersive)",
            "dielectric",
            "Sellmeier formula of the SCHOTT N-BK7 data sheet",
            sellmeier=BK7_SELLMEIER,
        ),
    )
}


@cache
def _constants(file: str) -> np.ndarray:
    _, data = read_table(packaged_tables("fresnel") / file, ("wavelength_nm", "n", "k"))
    data.setflags(write=False)
    return data


def get_material(key: str) -> Material:
    return MATERIALS[choice(key, "material", tuple(MATERIALS))]


@lru_cache(maxsize=64)
def _spectral_index(key: str, space: str):
    lam, weights = channel_weights(space)
    eta = get_material(key).index(lam)
    eta.setflags(write=False)
    return eta, weights


_CHUNK = 2048  # cosines per block: a block holds CHUNK x 421 complex values (14 MB) and 3 x that many products


def reflectance(material: str, mu, space: str = "srgb") -> np.ndarray:
    """F_c(mu) per channel (module docstring): an array of shape mu.shape + (3,), channels r, g, b of
    ``space`` ("srgb" or "acescg", linear).  mu in [0, 1]."""
    space = choice(space, "space", SPACES)
    mu = real_array(mu, "mu", 0.0, 1.0, domain="[0, 1] (cos theta)")
    eta, weights = _spectral_index(get_material(material).key, space)
    flat = mu.ravel()
    out = np.empty((flat.size, 3))
    for start in range(0, flat.size, _CHUNK):
        part = flat[start : start + _CHUNK]
        # numpy's pairwise sum per (cosine, channel), not a BLAS product: its order of summation, and so the last
        # bits, would depend on the BLAS build and on how many cosines share the call
        spectral = fresnel_reflectance(part[:, None], eta[None, :])
        out[start : start + _CHUNK] = np.sum(spectral[:, None, :] * weights[None, :, :], axis=-1)
    return out.reshape(*mu.shape, 3)


_PANELS = 8  # equal panels of the average's quadratures
_NODES = 32  # Gauss-Legendre nodes per panel


def cosine_average(values, route: str = "mu") -> np.ndarray:
    """2 int_0^1 v(mu) mu dmu of a function ``values`` (an array of cosines in, an array of shape (cosines, ...)
    out), by composite Gauss-Legendre (8 panels of 32 nodes) in mu (route "mu") or in theta = arccos mu, where
    the integrand is v(cos theta) 2 cos theta sin theta (route "theta")."""
    route = choice(route, "route", AVERAGE_ROUTES)
    x, w = gauss_legendre(_NODES)
    edges = np.linspace(0.0, 1.0 if route == "mu" else np.pi / 2, _PANELS + 1)
    h = np.diff(edges)
    t = (edges[:-1, None] + h[:, None] * x[None, :]).ravel()
    wt = (h[:, None] * w[None, :]).ravel()
    if route == "mu":
        mu, jac = t, 2.0 * t
    else:
        mu, jac = np.cos(t), 2.0 * np.cos(t) * np.sin(t)
    return np.tensordot(wt * jac, np.asarray(values(np.clip(mu, 0.0, 1.0))), axes=1)


def average_reflectance(material: str, space: str = "srgb", route: str = "mu") -> np.ndarray:
    """F_avg = 2 int_0^1 F_c(mu) mu dmu per channel (Kulla and Conti's cosine-weighted average) by
    :func:`cosine_average`.  F is analytic in mu on [0, 1] for every material here, so both routes converge
    geometrically; the tests ask them to agree to 1e-10."""
    space = choice(space, "space", SPACES)
    return cosine_average(lambda mu: reflectance(material, mu, space), route)
