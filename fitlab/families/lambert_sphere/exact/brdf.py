r"""The exact three-term half-space BRDF by Fourier order, and the reference
Lambert-sphere BRDF built on it.

All functions use fitlab's conventions (docs/model.md, "Conventions"):
mu_i, mu_o in [0, 1], phi the relative
azimuth with phi = 0 back-scattering, S = sqrt((1 - mu_i^2)(1 - mu_o^2)), and
f = f0 + f1 cos(phi) + f2 cos(2 phi) in 1/sr.  Every term has a pole
1/(mu_i + mu_o); internally each is computed as the "numerator" (mu_i + mu_o) f,
which is bounded, and divided at the end.  At mu_i = mu_o = 0 exactly the
result is +inf where the numerator is positive (the physical BRDF diverges
there), 0 where it is 0; the multiple-scattering parts diverge only
logarithmically, and are computed without cancellation through (H(mu) - 1)/mu
and the moment relations' r_l - P_l^m (:attr:`ModePolynomials.multiple
<fitlab.families.lambert_sphere.exact.constants.ModePolynomials>`): as c -> 0
they are O(c^2), differences of O(c) terms, and at grazing O(c^2 mu) in the
numerator, where a difference of the O(c) numerators kept eps c of rounding
(the BRDF was negative at c = 1e-12, forward grazing).
"""

from __future__ import annotations

import numpy as np

from fitlab.families.lambert_sphere.exact import _checks
from fitlab.families.lambert_sphere.exact.characteristic import check_albedo, lambert_sphere_characteristic
from fitlab.families.lambert_sphere.exact.constants import mode_polynomials
from fitlab.families.lambert_sphere.exact.hfunction import solve_h
from fitlab.families.lambert_sphere.exact.phase import phase_function, three_term_phase_function

__all__ = [
    "DEFAULT_PHASE",
    "PHASES",
    "check_phase",
    "brdf_modes",
    "single_scattering_modes",
    "multiple_scattering_modes",
    "brdf",
    "check_cosines",
]


#: Which physics the reference BRDF has (docs/model.md, "Which phase function"):
#: "true": the whole phase function in every collision (the material's BRDF; true_phase.py);
#: "three_term": the paper's three-term phase function in every collision, single scattering included;
#: "mixed": true single scattering plus three-term multiple scattering (fitlab's reference before the whole
#: phase function was solved; kept for the paper's comparisons and as what the runtime parts were fitted to).
PHASES = ("true", "three_term", "mixed")
#: The default of every ``phase=`` in the exact engine: the BRDF of the material itself.
DEFAULT_PHASE = "true"


def check_phase(phase, allowed=PHASES) -> str:
    """``phase`` as one of ``allowed`` (None: :data:`DEFAULT_PHASE`); one-line ValueError for an unknown
    name, TypeError for a non-string."""
    if phase is None:
        phase = DEFAULT_PHASE
    return _checks.choice(phase, "phase", allowed)


def check_cosines(*arrays, names=("mu_i", "mu_o")):
    out = []
    for a, name in zip(arrays, names):
        a = np.asarray(a, dtype=float)
        if np.any(np.isnan(a)) or np.any((a < 0.0) | (a > 1.0)):
            raise ValueError(f"{name} must lie in [0, 1] (cosine with the normal, pointing away from the surface)")
        out.append(a)
    return out


def _divide_pole(numerator, mu_i, mu_o):
    s = mu_i + mu_o
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.asarray(numerator / s)  # 0-d inputs give a numpy scalar, which takes no item assignment
    pole = s == 0.0
    if np.any(pole):
        n = np.broadcast_to(numerator, out.shape)[pole]
        out[pole] = np.where(n > 0, np.inf, np.where(n < 0, -np.inf, 0.0))
    return out


def _single_numerators(mu_i, mu_o, c):
    """(mu_i + mu_o) f_ss^m for the three-term phase function, m = 0, 1, 2."""
    p = mu_i * mu_o
    q = mu_i * mu_i + mu_o * mu_o
    s = np.sqrt((1.0 - mu_i * mu_i) * (1.0 - mu_o * mu_o))
    n0 = c * (207.0 + 256.0 * p - 45.0 * q + 135.0 * p * p) / (768.0 * np.pi)
    n1 = c * s * (64.0 + 45.0 * p) / (192.0 * np.pi)
    n2 = 15.0 * c * s * s / (256.0 * np.pi)
    return n0, n1, n2


def single_scattering_modes(mu_i, mu_o, c):
    """Fourier orders (f0, f1, f2) of single scattering, three-term phase function.

    f_ss = c p3(u) / (mu_i + mu_o) with p3 the three-term truncation; expanding:
      f0 = c (207 + 256 mu_i mu_o - 45 (mu_i^2 + mu_o^2) + 135 mu_i^2 mu_o^2) / (768 pi (mu_i + mu_o))
      f1 = c S (64 + 45 mu_i mu_o) / (192 pi (mu_i + mu_o))     [eq. 28 prints 384 pi]
      f2 = 15 c S^2 / (256 pi (mu_i + mu_o)).
    """
    mu_i = _checks.real_array(mu_i, "mu_i", 0.0, 1.0)
    mu_o = _checks.real_array(mu_o, "mu_o", 0.0, 1.0)
    c = _checks.real_array(c, "c", 0.0, 1.0, domain="[0, 1] (particle albedo)")
    mu_i, mu_o = check_cosines(mu_i, mu_o)
    c = check_albedo(c)
    mu_i, mu_o, c = np.broadcast_arrays(mu_i, mu_o, c)
    return tuple(_divide_pole(n, mu_i, mu_o) for n in _single_numerators(mu_i, mu_o, c))


def _h_parts(order, c, mu):
    """H(mu) and H(mu) - 1, the latter as mu (H - 1)/mu: no cancellation."""
    sol = solve_h(lambert_sphere_characteristic(order, c))
    with np.errstate(invalid="ignore"):
        h_minus_1 = np.where(mu == 0.0, 0.0, mu * sol.h_minus_one_over_u(mu))
    return sol(mu), h_minus_1, sol


def _mode_numerators(mu_i, mu_o, cv, multiple_only):
    """Per order m: (mu_i + mu_o) f^m, or for multiple scattering the pieces
    (H_i H_o - 1, (Q - Q_ss) g, Q g) of (mu_i + mu_o) fm^m = (H_i H_o - 1) Q g + (Q - Q_ss) g, with Q - Q_ss
    from :attr:`ModePolynomials.multiple <fitlab.families.lambert_sphere.exact.constants.ModePolynomials>` (not
    Q g less the single-scattering numerator: both are O(c) and their difference O(c^2 mu) at grazing)."""
    s2 = (1.0 - mu_i * mu_i) * (1.0 - mu_o * mu_o)
    out = []
    for m in range(3):
        modes = mode_polynomials(m, cv)
        deg = modes.matrix.shape[0]
        vi = np.stack([mu_i**j for j in range(deg)], axis=-1)
        vo = np.stack([mu_o**j for j in range(deg)], axis=-1)
        g = s2 ** (m / 2.0)
        gq = g * np.einsum("...j,jk,...k->...", vi, modes.matrix, vo)
        hi, hi1, sol = _h_parts(m, cv, mu_i)
        ho, ho1, _ = _h_parts(m, cv, mu_o)
        if not multiple_only:
            out.append(hi * ho * gq)
        else:
            dq = g * np.einsum("...j,jk,...k->...", vi, modes.multiple, vo)
            # H_i H_o - 1 = (H_i - 1) H_o + (H_o - 1)
            out.append((hi1 * ho + ho1, dq, gq, sol.char.coefficients[0]))
    return out


def _modes(mu_i, mu_o, c, multiple_only):
    mu_i, mu_o = check_cosines(mu_i, mu_o)
    c = check_albedo(c)
    mu_i, mu_o, c = np.broadcast_arrays(mu_i, mu_o, c)
    res = [np.empty(mu_i.shape) for _ in range(3)]
    for cv in np.unique(c):
        sel = c == cv
        mi, mo = mu_i[sel], mu_o[sel]
        parts = _mode_numerators(mi, mo, float(cv), multiple_only)
        for m in range(3):
            if not multiple_only:
                res[m][sel] = _divide_pole(parts[m], mi, mo)
                continue
            hh1, dq, gq, psi0 = parts[m]
            s = mi + mo
            pole = s == 0.0
            with np.errstate(divide="ignore", invalid="ignore"):
                val = (hh1 * gq + dq) / s
            # (H_i H_o - 1)/(mu_i + mu_o) ~ Psi_m(0) log(1/mu): a log pole at (0, 0)
            val[pole] = 0.0 if psi0 == 0.0 else np.sign(psi0) * np.inf
            res[m][sel] = val
    return tuple(res)


def brdf_modes(mu_i, mu_o, c, phase="three_term"):
    """Fourier orders (f0, f1, f2) of the exact three-term half-space BRDF.

    phase: only "three_term" has a finite Fourier series; "true" and "mixed" carry the true
    single scattering, whose series in cos(m phi) does not end (ValueError: use
    :func:`multiple_scattering_modes` plus the closed-form single scattering).

    All orders of scattering: f = f0 + f1 cos(phi) + f2 cos(2 phi) (eq. 9), from
    the exact H-functions and the constants of :func:`constants`:
      f0 = H0 H0 Q0(mu_i, mu_o) / (2 pi (mu_i + mu_o))  (eq. 30),
      f1 = c H1 H1 S (1 + l (mu_i+mu_o) + (l^2 + 45m/64) mu_i mu_o) / (3 pi (mu_i + mu_o)),
      f2 = 15 c H2 H2 S^2 / (256 pi (mu_i + mu_o)).
    mu_i, mu_o in [0, 1], c in [0, 1]; broadcast.  Reciprocal in (mu_i, mu_o).
    """
    if check_phase(phase) != "three_term":
        raise ValueError(
            f"phase {phase!r} has infinitely many Fourier orders (true single scattering): "
            "brdf_modes takes only 'three_term'"
        )
    mu_i = _checks.real_array(mu_i, "mu_i", 0.0, 1.0)
    mu_o = _checks.real_array(mu_o, "mu_o", 0.0, 1.0)
    c = _checks.real_array(c, "c", 0.0, 1.0, domain="[0, 1] (particle albedo)")
    return _modes(mu_i, mu_o, c, multiple_only=False)


def multiple_scattering_modes(mu_i, mu_o, c, phase=None):
    """brdf_modes minus single_scattering_modes, computed without cancellation.

    phase (default :data:`DEFAULT_PHASE`): "three_term" and "mixed" (whose multiple scattering is
    the three-term one) return the three orders (fm0, fm1, fm2) below; "true" returns the
    multiple scattering of the half space with the whole phase function, a tuple of
    :func:`true_phase.needed_orders <fitlab.families.lambert_sphere.exact.true_phase.needed_orders>`
    orders (fm_0, fm_1, ...; the number depends on c: for an array of several c values,
    each order is padded with zeros to the longest), from :mod:`true_phase`.

    fm0 and fm1 are the terms the paper's runtime model keeps (eqs. 28, 38);
    fm2 is the one it drops (eq. 21).  Each diverges like log(1/mu) as
    mu_i = mu_o -> 0 (inf exactly at mu_i = mu_o = 0, c > 0).

    Accuracy as c -> 0: each order is c^2 L(mu_i, mu_o) (1 + O(c)).  The coefficients of r_l - P_l^m that sit
    beside an O(1) coefficient of P_l^m are solved to eps absolute and enter with powers of mu, so the orders
    are good to about 1.5e-16/c relative at mu_i = mu_o = 1 (1.5e-4 at c = 1e-12), less toward grazing
    (1.8e-6 at c = 1e-15, mu_i = mu_o = 1e-4; 1.2e-8 at 1e-6; tests/test_brdf.py).  Away from grazing they are
    c times smaller than single scattering, and :func:`brdf` is c p(u)/(mu_i + mu_o) + c^2 L to 1e-10 down to
    c = 1e-15, > 0, and 0 at c = 0.
    """
    phase = check_phase(phase)
    mu_i = _checks.real_array(mu_i, "mu_i", 0.0, 1.0)
    mu_o = _checks.real_array(mu_o, "mu_o", 0.0, 1.0)
    c = _checks.real_array(c, "c", 0.0, 1.0, domain="[0, 1] (particle albedo)")
    if phase == "true":
        return _true_modes(mu_i, mu_o, c)
    return _modes(mu_i, mu_o, c, multiple_only=True)


def _true_modes(mu_i, mu_o, c):
    from fitlab.families.lambert_sphere.exact import true_phase

    mu_i, mu_o = check_cosines(mu_i, mu_o)
    c = check_albedo(c)
    mu_i, mu_o, c = np.broadcast_arrays(mu_i, mu_o, c)
    per_c = {}
    for cv in np.unique(c):
        sel = c == cv
        per_c[float(cv)] = (sel, true_phase.multiple_scattering_orders(mu_i[sel], mu_o[sel], float(cv)))
    n = max(len(v[1]) for v in per_c.values()) if per_c else 1
    out = [np.zeros(mu_i.shape) for _ in range(n)]
    for sel, modes in per_c.values():
        for m, fm in enumerate(modes):
            out[m][sel] = fm
    return tuple(out)


def _true_multiple(mu_i, mu_o, phi, c):
    """sum_m fm_m cos(m phi) of the true-phase half space (broadcast arrays, any number of c values)."""
    from fitlab.families.lambert_sphere.exact import true_phase

    out = np.empty(mu_i.shape)
    for cv in np.unique(c):
        sel = c == cv
        out[sel] = true_phase.multiple_scattering_sum(mu_i[sel], mu_o[sel], phi[sel], float(cv))
    return out


def brdf(mu_i, mu_o, phi, c, phase=None):
    """The reference Lambert-sphere BRDF (1/sr).

    phase (default :data:`DEFAULT_PHASE`, "true"):

    * "true": f = c p(u)/(mu_i + mu_o)  [exact single scattering, true phase function, eq. 10]
      plus the multiple scattering of the half space with the whole phase function
      (:mod:`true_phase`; 1e-10 relative, docs/derivation.md): the BRDF of the material;
    * "mixed": the same single scattering + fm0 + fm1 cos(phi) + fm2 cos(2 phi)  [exact multiple
      scattering of the three-term half space, all three orders];
    * "three_term": the paper's model in every collision, single scattering included
      (c p3(u)/(mu_i + mu_o) + the same fm0..fm2).

    u = -(mu_i mu_o + S cos phi); phi = 0 is back-scattering.  mu_i, mu_o in
    [0, 1], phi any real (radians), c in [0, 1]; broadcast.  +inf at the pole
    mu_i = mu_o = 0 (c > 0, p(u) > 0).
    """
    mu_i = _checks.real_array(mu_i, "mu_i", 0.0, 1.0)
    mu_o = _checks.real_array(mu_o, "mu_o", 0.0, 1.0)
    phi = _checks.real_array(phi, "phi", domain="(-inf, inf), finite (radians)", allow_inf=False)
    c = _checks.real_array(c, "c", 0.0, 1.0, domain="[0, 1] (particle albedo)")
    mu_i, mu_o = check_cosines(mu_i, mu_o)
    phi = np.asarray(phi, dtype=float)
    if np.any(~np.isfinite(phi)):
        raise ValueError("phi must be finite (radians)")
    c = check_albedo(c)
    phase = check_phase(phase)
    mu_i, mu_o, phi, c = np.broadcast_arrays(mu_i, mu_o, phi, c)
    cos_phi = np.cos(phi)
    s = np.sqrt((1.0 - mu_i * mu_i) * (1.0 - mu_o * mu_o))
    u = -(mu_i * mu_o + s * cos_phi)
    pole = (mu_i + mu_o) == 0.0
    p = three_term_phase_function if phase == "three_term" else phase_function
    with np.errstate(divide="ignore", invalid="ignore"):
        single = c * p(u) / (mu_i + mu_o)
        if phase == "true":
            multiple = _true_multiple(mu_i, mu_o, phi, c)
        else:
            fm0, fm1, fm2 = multiple_scattering_modes(mu_i, mu_o, c, phase="three_term")
            multiple = fm0 + fm1 * cos_phi + fm2 * np.cos(2.0 * phi)
        out = np.asarray(single + multiple)
    # At mu_i = mu_o = 0 the log poles of fm0 + fm1 cos + fm2 cos 2phi add up to
    # c^2 (0.1453 - 0.1111 cos phi + 0.0034 cos 2phi) log(1/mu) / pi > 0: +inf.
    out[pole] = np.where(c[pole] > 0.0, np.inf, 0.0)
    return out
