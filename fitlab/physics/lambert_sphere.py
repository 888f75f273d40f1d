r"""The phase function of a Lambertian sphere (d'Eon, EGSR 2021) and its three-term truncation.

p(u) = 2 (sqrt(1 - u^2) - u acos(u)) / (3 pi^2) (the paper's eq. 1), u the cosine of the scattering angle,
normalised to 1 over the sphere; its Legendre coefficients A_k (eq. 4) and the three-term model (1/4pi)(A_0 + A_1
P_1 + A_2 P_2) (eq. 8).  p is written in the variable a caller holds, each form exact in it: u, the angle theta of
u = -cos(theta), and v = (1 - u) / 2, which keeps forward scattering's digits (docs/model.md, "Phase function").
"""

from __future__ import annotations

from math import factorial
from typing import Any

from fitlab.physics._namespace import namespace

__all__ = [
    "LEGENDRE_A",
    "phase_function",
    "phase_function_of_angle",
    "phase_function_forward",
    "three_term_phase_function",
]

#: Legendre coefficients A_0..A_6 of p (eq. 4): p = (1/4pi) sum_k A_k P_k(u)
LEGENDRE_A = (1.0, -4.0 / 3.0, 5.0 / 16.0, 0.0, 1.0 / 64.0, 0.0, 13.0 / 4096.0)
#: the series of sin x - x cos x is used below v = 1/16 (x < 2 asin(1/4) = 0.505), where its first term left out is
#: 1e-17 of the sum and the direct difference would keep eps / x^2 of its digits
_SERIES_BELOW = (1, 16)
_SERIES_TERMS = 7


def phase_function(u: Any) -> Any:
    """p(u) = 2 (sqrt(1 - u^2) - u acos(u)) / (3 pi^2), u in [-1, 1]; 1/sr."""
    xp = namespace(u)
    return 2 * (xp.sin_of(u) - u * xp.arccos(u)) / (3 * xp.pi**2)


def phase_function_of_angle(theta: Any) -> Any:
    """p at u = -cos(theta), theta in [0, pi] the angle from the backward direction: 2 (sin(theta) + cos(theta) (pi -
    theta)) / (3 pi^2), with no arccos."""
    xp = namespace(theta)
    return 2 * (xp.sin(theta) + xp.cos(theta) * (xp.pi - theta)) / (3 * xp.pi**2)


def _sin_less_x_cos(x: Any, xp: Any) -> Any:
    """sin x - x cos x = sum_k (-1)^(k+1) 2k x^(2k+1) / (2k+1)!, k = 1 .. 7, Horner in x^2."""
    y, out = x**2, None
    for k in range(_SERIES_TERMS, 0, -1):
        term = (-1) ** (k + 1) * xp.rational(2 * k, factorial(2 * k + 1))
        out = term if out is None else term + y * out
    return x**3 * out


def phase_function_forward(v: Any) -> Any:
    """p as a function of v = (1 - u) / 2 in [0, 1]: with x = acos(u) from one asin (2 asin(sqrt(v)) for v < 1/2, pi -
    2 asin(sqrt(1 - v)) above), sqrt(1 - u^2) - u acos(u) = sin x - x cos x = 2 sqrt(v (1 - v)) - (1 - 2v) x, by
    its series below v = 1/16 (forward scattering, where the difference cancels)."""
    xp = namespace(v)
    half = 2 * xp.arcsin(xp.sqrt(xp.minimum(v, 1 - v)))
    x = xp.where(v < xp.rational(1, 2), half, xp.pi - half)
    direct = 2 * xp.sqrt(v * (1 - v)) - (1 - 2 * v) * x
    inner = xp.where(v < xp.rational(*_SERIES_BELOW), _sin_less_x_cos(half, xp), direct)
    return 2 * inner / (3 * xp.pi**2)


def three_term_phase_function(u: Any) -> Any:
    """(1/4pi)(1 - (4/3) u + (5/16) P_2(u)), the truncation of p to A_0..A_2; negative for u > 0.95029."""
    xp = namespace(u)
    return (1 - xp.rational(4, 3) * u + xp.rational(5, 32) * (3 * u * u - 1)) / (4 * xp.pi)
