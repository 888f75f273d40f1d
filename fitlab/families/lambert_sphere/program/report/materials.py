r"""The Lambert sphere's material axis in ``fitlab report``: the albedos c at which the report's validation
sets, its independent set and its energy check are taken.  The family's report (:mod:`.methods`) gives them to
:mod:`fitlab.report.validation` and :mod:`fitlab.report.run`, which know no family; how many of each the
family's report settings say (:class:`.settings.EngineSettings`: ``n_c``, ``with_c1``, ``small_c``,
``fresh_c``, ``energy_c``).

The validation sets' albedos: the small ones (the BRDF is O(c) there, and O(c^2) in forward scattering at
grazing, where fitted O(c) terms fail), then c = 1 - s^2 with s = (k + g)/n, k = 0..n-1, g = (sqrt 5 - 1)/2,
plus c = 1 when asked: the irrational offset keeps every s off the tables' grid s = k/64 (a table method
would otherwise be exact in c at every point) and off the fits' training and validation grids (dyadic in s).
c = 0 is left out: the BRDF is 0 there and a relative error means nothing (the report measures max |f| at
c = 0 instead).  The independent set's albedos are uniform in (0, 1), drawn first from its generator.
"""

from __future__ import annotations

import numpy as np

__all__ = ["GOLDEN", "albedos", "validation_materials", "fresh_materials", "energy_materials"]

GOLDEN = (np.sqrt(5.0) - 1.0) / 2.0


def albedos(n: int, with_c1: bool, small: tuple = ()) -> np.ndarray:
    """The ``small`` albedos, then c = 1 - s^2, s = (k + g)/n for k = 0..n-1 (g the golden ratio's fraction),
    then c = 1 if asked."""
    s = (np.arange(n) + GOLDEN) / n
    c = np.concatenate((np.asarray(small, dtype=float), 1.0 - s**2))
    return np.concatenate((c, [1.0])) if with_c1 else c


def validation_materials(fam) -> tuple[np.ndarray, str]:
    """(albedos, what they are) of the validation and grazing sets, by the family's report settings ``fam``."""
    small = f"c in {{{', '.join(f'{c:g}' for c in fam.small_c)}}} and " if fam.small_c else ""
    text = f"{len(fam.small_c) + fam.n_c + fam.with_c1} albedos: {small}c = 1 - s^2, s = (k + 0.618...)/{fam.n_c}" + (
        " and c = 1" if fam.with_c1 else ""
    )
    return albedos(fam.n_c, fam.with_c1, fam.small_c), text


def fresh_materials(rng: np.random.Generator, fam) -> tuple[np.ndarray, str]:
    """(albedos, what they are) of the independent set: ``fam.fresh_c`` uniform in (0, 1), the first draws of
    the set's generator ``rng``."""
    return rng.uniform(0.0, 1.0, fam.fresh_c), f"{fam.fresh_c} albedos uniform in (0, 1)"


def energy_materials(fam) -> tuple[np.ndarray, str]:
    """(albedos, what they are) at which the directional albedo is checked against the exact one."""
    return np.asarray(fam.energy_c, dtype=float), f"c in {{{', '.join(f'{c:g}' for c in fam.energy_c)}}}"
