r"""The microfacet_energy libraries of ``fitlab discover``.

* E of GGX (both Smith forms), ``rational_v_alpha``: E = (1 + sum a_k m_k)/(1 + sum b_k m_k), m_k the
  monomials v^i alpha^j, 1 <= i + j <= 3, v = alpha/(mu + alpha) the grazing-layer variable
  (:mod:`..forms.common`): every m_k vanishes on the mirror line alpha = 0 (v = 0), so E = 1 there
  exactly, and the layer next to grazing, where E depends on mu/alpha, is a function of v (the
  ``rational_v_alpha_4`` form is the quartic member of the same family).
* E_avg of GGX, ``log_rational_alpha``: E_avg = 1 - alpha^2 (sum a_k f_k)/(1 + sum b_k alpha^k), f in
  {1, L, alpha, alpha L, alpha^2, alpha^2 L, alpha^3}, L = log(alpha) (floored), k = 1..3: E_avg = 1 at
  alpha = 0, with the alpha^2 log(alpha) term of the grazing layer (:mod:`..forms.average`).
"""

from __future__ import annotations

import sympy as sp

from fitlab.discover import Library
from fitlab.families.microfacet_energy.forms.common import alpha, monomials, safe_log, v
from fitlab.families.microfacet_energy.targets import target_name

__all__ = ["LIBRARIES"]


def _albedo_library(target: str) -> Library:
    terms = {f"v^{k[0]} a^{k[1]}": t for k, t in monomials({"v": v, "alpha": alpha}, 3, constant=False).items()}
    return Library(
        name="rational_v_alpha",
        target=target,
        inputs=("mu", "alpha"),
        numerator=terms,
        denominator=terms,
        n0=sp.S.One,
        description=(
            "E = (1 + sum a_k m_k)/(1 + sum b_k m_k), m = v^i alpha^j, 1 <= i + j <= 3, v = alpha/(mu + alpha): E = 1 "
            "at alpha = 0"
        ),
    )


def _average_library(target: str) -> Library:
    log_a = safe_log(alpha)
    numerator = {"1": sp.S.One, "L": log_a, "a": alpha, "a L": alpha * log_a, "a2": alpha**2, "a2 L": alpha**2 * log_a,
                 "a3": alpha**3}  # fmt: skip
    return Library(
        name="log_rational_alpha",
        target=target,
        inputs=("alpha",),
        numerator=numerator,
        denominator={"a": alpha, "a2": alpha**2, "a3": alpha**3},
        offset=sp.S.One,
        factor=-(alpha**2),
        description=(
            "E_avg = 1 - alpha^2 (sum a_k f_k)/(1 + sum b_k alpha^k), f in {1, L, alpha, alpha L, alpha^2, alpha^2 L, "
            "alpha^3}, L = log(alpha), k = 1..3: E_avg = 1 at alpha = 0"
        ),
    )


#: the libraries of each target; the first is its primary library
LIBRARIES: dict[str, tuple[Library, ...]] = {
    **{target_name("E", m): (_albedo_library(target_name("E", m)),) for m in ("ggx_separable", "ggx_correlated")},
    **{
        target_name("E_avg", m): (_average_library(target_name("E_avg", m)),)
        for m in ("ggx_separable", "ggx_correlated")
    },
}
