r"""A Fresnel factor F(cos theta_d) together with the cosines where it is not smooth.

The quadratures of :mod:`.albedo` (and :func:`.fresnel.visible_fresnel`, :func:`.fresnel.average_fresnel`)
converge fast for a smooth F.  A dielectric seen from its denser side (relative index eta < 1) is not: F = 1
for cos theta_d <= c_k = sqrt(1 - eta^2) (total internal reflection) and F = 1 - O(sqrt(cos theta_d - c_k))
above, a square-root edge that a rule unaware of it integrates with an error of a few 1e-3 (E at alpha 0.6,
mu 0.5, eta 1/1.5: 0.35938 and 0.35654 by the two routes of :mod:`.albedo` for 0.35801).  A conductor
bends as sharply where t0 = eta^2 - k^2 - (1 - c^2) = 0 when k is small.  The engine is fed functions,
which cannot say where they bend; :class:`FresnelFactor` carries those cosines (``kinks``) with the
function, and the quadratures put panel edges on them (on the curves w_o . h = c_k of their variables).
A plain function is taken as smooth.
"""

from __future__ import annotations

import numbers
from collections.abc import Callable
from dataclasses import dataclass

__all__ = ["FresnelFactor", "kinks_of"]


@dataclass(frozen=True)
class FresnelFactor:
    """F(cos theta_d) (``function``: arrays of cosines in [0, 1] in, arrays of their shape out) and the
    cosines in (0, 1) where F or its derivative is not smooth (``kinks``, e.g. the critical angle's
    sqrt(1 - eta^2) of a dielectric with eta < 1).  Called like the function."""

    function: Callable
    kinks: tuple = ()

    def __post_init__(self):
        if not callable(self.function):
            raise TypeError(
                f"FresnelFactor.function must be a function of cos(theta_d), got {type(self.function).__name__}"
            )
        object.__setattr__(self, "kinks", _checked_kinks(self.kinks))

    def __call__(self, cos):
        return self.function(cos)


def _checked_kinks(kinks) -> tuple[float, ...]:
    try:
        values = tuple(kinks)
    except TypeError:
        raise TypeError(f"kinks must be a sequence of cosines in [0, 1], got {type(kinks).__name__}") from None
    for k in values:
        if isinstance(k, bool) or not isinstance(k, numbers.Real) or not 0.0 <= float(k) <= 1.0:
            raise ValueError(f"kinks must be cosines in [0, 1], got {k!r:.40}")
    # a kink at 0 or 1 is an end of every rule already
    return tuple(sorted({float(k) for k in values if 0.0 < float(k) < 1.0}))


def kinks_of(fresnel) -> tuple[float, ...]:
    """The kinks of a Fresnel factor, sorted, inside (0, 1): those of a :class:`FresnelFactor`, none for a
    plain function (or None)."""
    return fresnel.kinks if isinstance(fresnel, FresnelFactor) else ()
