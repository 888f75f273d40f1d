r"""The Lambert-sphere libraries of ``fitlab discover``.

The libraries of :data:`LIBRARIES` are products of a few "shape" factors per
input, chosen for what these functions are known to do:

* powers of s = sqrt(1 - c): the H-functions and constants are smooth in s,
  not in c (their expansions about c = 1 are in powers of s);
* L(mu) = mu log(1 + 1/mu): the first iterate of the H-equation is
  1 + (c/2) mu log((1 + mu)/mu) for isotropic scattering, so H - 1 has a
  mu log mu singularity at grazing that no power of mu reproduces (the
  published mu^d shape is why the paper's H0 is worst at small mu);
* sqrt(mu), and for the BRDF the pole 1/(mu_i + mu_o), the azimuthal factor
  S cos(phi), and log(mu_i + mu_o) (the exact f_r grows like log(1/mu) as
  mu_i = mu_o -> 0 at phi = pi, where single scattering vanishes; eq. 41's
  shapes cannot follow that).
"""

from __future__ import annotations

import sympy as sp

from fitlab.discover import Library, products
from fitlab.families.lambert_sphere.forms.brdf import SINGLE
from fitlab.families.lambert_sphere.forms.h_functions import LOG_FLOOR
from fitlab.forms.symbolic import symbols

__all__ = ["LIBRARIES", "LOG_FLOOR"]

mu, c, kd, mu_i, mu_o, phi = symbols(("mu", "c", "kd", "mu_i", "mu_o", "phi"))
s = sp.sqrt(1 - c)


#: floor of mu in mu log(1 + 1/mu) and of mu_i + mu_o in log(mu_i + mu_o): written directly, both are
#: 0 * inf = nan at 0 (their limits are 0 and a finite floor); 1e-30 is a normal float, so the float C
#: back end keeps the floor too.  The same floor as the log_exp H forms (defined there once).


def _mu_log(x):
    return x * sp.log(1 + 1 / sp.Max(x, LOG_FLOOR))


_S_POWERS = {"1": sp.S.One, "s": s, "s2": s**2}
_MU_SHAPES = {"mu": mu, "mu2": mu**2, "sqrt(mu)": sp.sqrt(mu), "L": _mu_log(mu), "mu L": mu * _mu_log(mu)}


def _h_library(target: str) -> Library:
    # every term carries the factor c, so that H = 1 at c = 0 exactly; every one vanishes at mu = 0 (H(0) = 1)
    terms = products({"c": c}, _MU_SHAPES, _S_POWERS)
    return Library(
        name="rational_mu_s",
        target=target,
        inputs=("mu", "c"),
        numerator=terms,
        denominator=terms,
        n0=sp.S.One,
        description=(
            f"{target} = (1 + c sum a_k m_k(mu) s^j)/(1 + c sum b_k m_k(mu) s^j), m in {{mu, mu^2, sqrt(mu), "
            "L = mu log(1 + 1/mu), mu L}, j in {0, 1, 2}: exact at mu = 0 and at c = 0"
        ),
    )


def _kd_of_c() -> Library:
    # kd = (1 - s) R(s), R(0) = 1: kd(0) = 0 and kd(1) = 1 exactly, as in the refitted eq. 40
    powers = {"s": s, "s2": s**2, "s3": s**3, "s4": s**4}
    return Library(
        name="rational_s",
        target="kd_of_c",
        inputs=("c",),
        numerator=powers,
        denominator=powers,
        factor=1 - s,
        n0=sp.S.One,
        description="kd = (1 - s)(1 + sum a_k s^k)/(1 + sum b_k s^k), k = 1..4: kd(0) = 0, kd(1) = 1",
    )


def _c_of_kd() -> Library:
    # c = kd R(kd): c(0) = 0 exactly; near kd = 1, 1 - c ~ (1 - kd)^2, which a rational in kd can follow
    t = 1 - kd
    shapes = {"kd": kd, "kd2": kd**2, "kd3": kd**3, "sqrt(1-kd)": sp.sqrt(t), "(1-kd)^(3/2)": t * sp.sqrt(t)}
    return Library(
        name="rational_kd",
        target="c_of_kd",
        inputs=("kd",),
        numerator={"1": sp.S.One, **shapes},
        denominator=shapes,
        factor=kd,
        description=(
            "c = kd (a_0 + sum a_k t_k)/(1 + sum b_k t_k), t in {kd, kd^2, kd^3, sqrt(1-kd), (1-kd)^(3/2)}: c(0) = 0"
        ),
    )


def _c_of_kd_ratio() -> Library:
    # c = kd N/(kd + sum b t^q), t = 1 - kd, every t^q and N - 1 vanishing at kd = 1: c(0) = 0 and
    # c(1) = 1 exactly. The denominator's fixed term is kd, not 1, so that kd/(kd + b t^2), one
    # parameter and five operations, is a single term (rational_kd needs three terms for it)
    t = 1 - kd
    powers = {"t^(1/2)": sp.sqrt(t), "t": t, "t^(3/2)": t * sp.sqrt(t), "t^2": t**2, "t^(5/2)": t**2 * sp.sqrt(t),
              "t^3": t**3}  # fmt: skip
    return Library(
        name="ratio_kd",
        target="c_of_kd",
        inputs=("kd",),
        numerator=powers,
        denominator=powers,
        factor=kd,
        n0=sp.S.One,
        d0=kd,
        description=(
            "c = kd (1 + sum a_k t^q_k)/(kd + sum b_k t^q_k), t = 1 - kd, q in {1/2, 1, 3/2, 2, 5/2, 3}: "
            "c(0) = 0, c(1) = 1"
        ),
    )


def _fast_brdf() -> Library:
    # f_r = f_1 (exact single scattering) + a linear model of the multiple scattering fm0 + fm1 cos phi
    sum_ = mu_i + mu_o
    S = sp.sqrt((1 - mu_i**2) * (1 - mu_o**2))
    albedo = {"c2": c**2, "c3": c**3, "kd": kd, "kd2": kd**2}
    angular = {
        "1": sp.S.One,
        "m": sum_,
        "p": mu_i * mu_o,
        "1/m": 1 / sum_,
        "p/m": mu_i * mu_o / sum_,
        "log m": sp.log(sp.Max(sum_, LOG_FLOOR)),
        "Scos": S * sp.cos(phi),
        "Scos/m": S * sp.cos(phi) / sum_,
        "Scos log m": S * sp.cos(phi) * sp.log(sp.Max(sum_, LOG_FLOOR)),
    }
    return Library(
        name="linear_ms",
        target="fast_brdf",
        inputs=("mu_i", "mu_o", "phi", "c", "kd"),
        numerator=products(albedo, angular),
        offset=SINGLE,
        nonnegative=True,
        description=(
            "f_r = f_1 + sum a_k g_k(c, kd) h_k(mu_i, mu_o, phi): f_1 exact single scattering (true phase function), "
            "g in {c^2, c^3, kd, kd^2}, h in {1, m, p, 1/m, p/m, log m, S cos phi, S cos phi/m, S cos phi log m}, "
            "m = mu_i + mu_o, p = mu_i mu_o"
        ),
    )


#: the libraries of each target; the first is its primary library (its forms' names carry no library tag)
LIBRARIES: dict[str, tuple[Library, ...]] = {
    "H0": (_h_library("H0"),),
    "H1": (_h_library("H1"),),
    "kd_of_c": (_kd_of_c(),),
    "c_of_kd": (_c_of_kd(), _c_of_kd_ratio()),
    "fast_brdf": (_fast_brdf(),),
}
