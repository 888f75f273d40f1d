r"""Characteristic functions Psi_m and the Krein/Fock functions K_m.

The three-term Lambert-sphere phase function (docs/model.md, "H-functions";
paper eqs. 13-15) gives,
for Fourier order m, an even polynomial characteristic function

    Psi_m(u) = sum_k p_k(c) u^(2k),   u in [0, 1],

and the function of Krein's formula (paper eq. 17, rewritten with v = 1/s)

    K_m(t) = 1 - 2 \int_0^1 Psi_m(v) / (1 + t^2 v^2) dv,   t >= 0.

The closed forms printed in the paper (eqs. 18-20) divide by t^5 and lose every
digit for small t.  Here K is evaluated as

    K(t) = K(0) + t^2 J(t),   J(t) = 2 \int_0^1 Psi(v) v^2 / (1 + t^2 v^2) dv,

with K(0) = 1 - 2 \int Psi in factored form (exactly 0 at c = 1 for m = 0, and
accurate to full relative precision as c -> 1) and J from the integrals
I_k(t) = \int_0^1 v^(2k)/(1 + t^2 v^2) dv: Gauss-Legendre for t <= 2 (no
cancellation), the stable upward recurrence I_k = (1/(2k-1) - I_{k-1}) / t^2 from
I_0 = atan(t)/t for t > 2.  Both are accurate to a few ulp for every t >= 0.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from fitlab.families.lambert_sphere.exact._quadrature import gauss_legendre

__all__ = [
    "Characteristic",
    "lambert_sphere_characteristic",
    "isotropic_characteristic",
    "psi",
    "k_function",
    "check_order",
    "check_albedo",
]

ORDERS = (0, 1, 2)


@dataclass(frozen=True)
class Characteristic:
    """An even polynomial characteristic function and its K(0).

    coefficients: p_0..p_K with Psi(u) = sum p_k u^(2k).
    k0: K(0) = 1 - 2 int_0^1 Psi, supplied in a form accurate near 0.
    """

    coefficients: tuple[float, ...]
    k0: float

    def __call__(self, u):
        u2 = np.asarray(u, dtype=float) ** 2
        return np.polynomial.polynomial.polyval(u2, self.coefficients)

    @property
    def is_zero(self) -> bool:
        return all(p == 0.0 for p in self.coefficients)

    @property
    def conservative(self) -> bool:
        return self.k0 == 0.0

    def k(self, t):
        """K(t) for t >= 0 (t = inf allowed), without cancellation."""
        t = np.asarray(t, dtype=float)
        return self.k0 + self.t2j(t)

    def t2j(self, t):
        """t^2 J(t) = K(t) - K(0), computed directly."""
        t = np.asarray(t, dtype=float)
        out = np.empty(t.shape)
        small = t <= 2.0
        if np.any(small):
            ts = t[small]
            x, w = gauss_legendre(40)
            frac = 1.0 / (1.0 + np.multiply.outer(ts * ts, x * x))
            j = np.zeros(ts.shape)
            for k, p in enumerate(self.coefficients):
                j += 2.0 * p * (frac * x ** (2 * k + 2)) @ w
            out[small] = ts * ts * j
        large = ~small
        if np.any(large):
            tl = t[large]
            with np.errstate(divide="ignore", invalid="ignore"):
                ik = np.where(np.isinf(tl), 0.0, np.arctan(tl) / tl)
            acc = np.zeros(tl.shape)
            # t^2 I_{k+1} = 1/(2k+1) - I_k
            for k, p in enumerate(self.coefficients):
                acc += 2.0 * p * (1.0 / (2 * k + 1) - ik)
                with np.errstate(divide="ignore", invalid="ignore"):
                    ik = np.where(np.isinf(tl), 0.0, (1.0 / (2 * k + 1) - ik) / (tl * tl))
            out[large] = acc
        return out

    def log_k(self, t):
        """log K(t); -inf at t = 0 in the conservative case."""
        with np.errstate(divide="ignore"):
            return np.log(self.k(t))


def check_order(order) -> int:
    if isinstance(order, (bool, np.bool_)) or int(order) != order or int(order) not in ORDERS:
        raise ValueError(f"order must be 0, 1 or 2 (the Fourier order m), got {order!r}")
    return int(order)


def check_albedo(c, name: str = "c") -> np.ndarray:
    c = np.asarray(c, dtype=float)
    if np.any(np.isnan(c)):
        raise ValueError(f"{name} contains NaN; the particle albedo must lie in [0, 1]")
    if np.any((c < 0.0) | (c > 1.0)):
        bad = c[(c < 0.0) | (c > 1.0)].ravel()[0]
        raise ValueError(f"{name} must lie in [0, 1] (particle albedo), got {bad!r}")
    return c


def _k0_order0(c: float) -> float:
    # 1 - 2 int Psi_0, factored (paper eq. 32): exact zero at c = 1.
    return (16.0 - c) * (1.0 - c) * (4.0 * c + 9.0) / 144.0


_COEFFICIENTS: dict[int, Callable[[float], tuple[float, ...]]] = {
    0: lambda c: (
        207.0 * c / 384.0,
        c * (c * (20.0 * c + 281.0) - 346.0) / 384.0,
        15.0 * c * (1.0 - c) * (4.0 * c + 9.0) / 384.0,
    ),
    1: lambda c: (-c / 3.0, c * (20.0 * c + 109.0) / 192.0, -c * (20.0 * c + 45.0) / 192.0),
    2: lambda c: (15.0 * c / 256.0, -30.0 * c / 256.0, 15.0 * c / 256.0),
}

# K_m(0) = 1 - 2 int_0^1 Psi_m; the tests check each against the coefficients.
_K0 = {
    0: _k0_order0,
    1: lambda c: 1.0 + c * (55.0 - 4.0 * c) / 144.0,
    2: lambda c: 1.0 - c / 16.0,
}


def lambert_sphere_characteristic(order: int, c: float) -> Characteristic:
    """Psi_m of the three-term Lambert-sphere half space (paper eqs. 13-15)."""
    order = check_order(order)
    c = float(c)
    return Characteristic(tuple(_COEFFICIENTS[order](c)), float(_K0[order](c)))


def isotropic_characteristic(c: float) -> Characteristic:
    """Psi = c/2: Chandrasekhar's isotropic-scattering H-function."""
    c = float(c)
    return Characteristic((0.5 * c,), 1.0 - c)


def psi(order, mu, c):
    """Characteristic function Psi_m(mu) of Fourier order m = 0, 1, 2.

    Paper eqs. 13-15; mu in [0, 1] (the polynomial is evaluated for any real mu),
    c in [0, 1].  Broadcasts mu and c.
    """
    order = check_order(order)
    mu = np.asarray(mu, dtype=float)
    c = check_albedo(c)
    mu, c = np.broadcast_arrays(mu, c)
    u2 = mu * mu
    p = _COEFFICIENTS[order](c)
    return p[0] + u2 * (p[1] + u2 * p[2])


def k_function(order, t, c):
    """K_m(t) of Krein's formula (paper eqs. 17-20), stable for every t >= 0.

    K_m(t) = 1 - 2 int_0^1 Psi_m(v)/(1 + t^2 v^2) dv; t = inf gives 1.
    At c = 1, K_0(0) = 0 exactly.  Broadcasts t and c.
    """
    order = check_order(order)
    t = np.asarray(t, dtype=float)
    if np.any(np.isnan(t)) or np.any(t < 0):
        raise ValueError("t must be >= 0 (t = inf allowed)")
    c = check_albedo(c)
    t, c = np.broadcast_arrays(t, c)
    out = np.empty(t.shape)
    for cv in np.unique(c):
        sel = c == cv
        out[sel] = lambert_sphere_characteristic(order, cv).k(t[sel])
    return out
