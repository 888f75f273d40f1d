r"""Forms for the albedo maps between the particle albedo c and kd.

kd is the spherical (Bond) albedo of the material.  fitlab's refit targets use
kd of :func:`fitlab.families.lambert_sphere.exact.brdf` (true phase function in single scattering), the
albedo a renderer using the runtime model actually shows; see docs/errata.md.
"""

from __future__ import annotations

import sympy as sp

from fitlab.forms.form import Form
from fitlab.forms.symbolic import safe_pow, symbols

kd, c = symbols(("kd", "c"))
s = sp.sqrt(1 - c)


def _c_of_kd() -> Form:
    a, p, b, q = symbols(("a", "p", "b", "q"))
    return Form(
        target="c_of_kd",
        name="rational_power",
        inputs=("kd",),
        params=("a", "p", "b", "q"),
        expr=(1 - a * safe_pow(1 - kd, p)) / (1 - b * safe_pow(1 - kd, q)),
        presets={
            "paper": dict(a=1.00425, p=2.67103, b=0.219924, q=2.44559),
            "renderer": dict(a=1.0, p=2.73556, b=0.184096, q=2.48423),
        },
        fixed={"a": 1.0},
        description=(
            "c = (1 - a (1-kd)^p)/(1 - b (1-kd)^q) (eq. 39; the renderer has a = 1). "
            "Refits hold a = 1, which makes c(0) = 0 exact; c(1) = 1 for every parameter value."
        ),
    )


def _kd_of_c_printed() -> Form:
    a, b, d = symbols(("a", "b", "d"))
    return Form(
        target="kd_of_c",
        name="printed",
        inputs=("c",),
        params=("a", "b", "d"),
        expr=(1 - a * (1 - c) - b * s) / (1 + d * s),
        presets={"paper": dict(a=0.453029, b=0.544162, d=1.42931)},
        description="kd = (1 - a (1-c) - b s)/(1 + d s) as printed (eq. 40); kd(0) = (1-a-b)/(1+d), not 0.",
        refit_by_default=False,
    )


def _kd_of_c_zero() -> Form:
    b, d = symbols(("b", "d"))
    return Form(
        target="kd_of_c",
        name="printed_c0",
        inputs=("c",),
        params=("b", "d"),
        # eq. 40 with a = 1 - b, factored: kd(0) = 0 exactly, kd(1) = 1
        expr=(1 - s) * (1 + (1 - b) * s) / (1 + d * s),
        start=dict(b=0.544162, d=1.42931),
        description="kd = (1 - s)(1 + (1-b) s)/(1 + d s): eq. 40 with a = 1 - b, so that kd(0) = 0 and kd(1) = 1.",
    )


def _kd_of_c_rational() -> Form:
    a1, a2, b1, b2 = symbols(("a1", "a2", "b1", "b2"))
    return Form(
        target="kd_of_c",
        name="rational_2_2",
        inputs=("c",),
        params=("a1", "a2", "b1", "b2"),
        expr=(1 - s) * (1 + a1 * s + a2 * s**2) / (1 + b1 * s + b2 * s**2),
        start=dict(a1=0.455838, a2=0.0, b1=1.42931, b2=0.0),
        description="kd = (1 - s)(1 + a1 s + a2 s^2)/(1 + b1 s + b2 s^2): kd(0) = 0 and kd(1) = 1 exactly.",
    )


FORMS = (_c_of_kd(), _kd_of_c_printed(), _kd_of_c_zero(), _kd_of_c_rational())
