r"""The sizes of one report: :data:`FULL` (``fitlab report``) and :data:`QUICK` (``--quick``, the test).

Every random number of the report comes from a seed here, so that every
column but the timings is reproducible run to run.  How hard the report measures a family's own engines
(the Lambert sphere's exact engine and Monte Carlo) is the family's: its report's
``REPORT_SETTINGS`` (:func:`family_settings`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

__all__ = ["Settings", "FULL", "QUICK", "family_settings"]


@dataclass(frozen=True)
class Settings:
    """What one report measures and how hard.

    BRDF validation set (see :mod:`fitlab.report.validation`): at each of the family's materials (the report
    report's ``validation_materials``; the Lambert sphere's albedos c), the same 2^``log2_points`` scrambled
    Sobol points (seed ``seed``) in (mu_i, mu_o, phi/pi) in (0, 1)^3; the black material is measured as
    max |f| (exactly 0 for an exact model).

    A second, independent set (:func:`fitlab.report.validation.fresh_set`) that nothing is fitted or
    selected on: ``fresh_points`` points in all over the family's materials for it (``fresh_materials``, the first
    draws), (mu_i, mu_o, phi) uniform, from numpy's PCG64 with seed ``fresh_seed`` (another generator and seed
    than the main set's).  Energy: the directional albedo against the exact one at the family's
    ``energy_materials`` x ``energy_mu`` incident cosines (uniform on [0, 1], 0 replaced by 1e-3).
    """

    name: str
    log2_points: int
    seed: int = 2021
    fresh_points: int = 100_000
    fresh_seed: int = 18_2026
    energy_mu: int = 11
    #: targets whose parts are measured on their validation sets; None: the family's choice for these settings
    #: (its report settings' ``parts``), else every target the families' reports measure at part level
    #: (fitlab.report.methods.report_parts)
    parts: tuple | None = None
    #: runtime presets whose C is built and timed; None: every preset set of the families' runtime
    #: models (fitlab.report.methods.preset_variants)
    preset_c: tuple | None = None
    #: build and time C for every catalogue entry (False: only the default refit and the baselines)
    all_c: bool = True
    #: BRDF-level entries for discovered forms (False: they are measured as parts only)
    discovered_brdf: bool = True
    #: random inputs per C timing, best of ``repeat``
    c_points: int = 1 << 19
    repeat: int = 5
    #: random inputs per numpy / JAX timing (best of ``repeat``)
    numpy_points: int = 1 << 17
    jax_points: int = 1 << 20
    #: JAX throughput for every entry with an expression (False: the default refit only)
    all_jax: bool = True
    #: refits timed (target, form); None: the family's choice for these settings (its report settings'
    #: ``refits``), else every fit file whose form fitlab.forms defines
    refits: tuple | None = None
    #: errors at which the time to reach them is reported (Monte Carlo and the exact engine)
    error_targets: tuple = (1e-2, 1e-3, 1e-6, 1e-10)
    #: the settings of the family whose BRDF the report measures (its exact engine, Monte Carlo), given by
    #: its report (``REPORT_SETTINGS``); None: the family report's settings of this one's ``name``
    family: Any = None


FULL = Settings(name="full", log2_points=12)

QUICK = Settings(
    name="quick",
    log2_points=8,
    preset_c=(),
    all_c=False,
    discovered_brdf=False,
    fresh_points=3000,
    energy_mu=3,
    c_points=1 << 14,
    repeat=2,
    numpy_points=1 << 12,
    jax_points=1 << 12,
    all_jax=False,
)


def family_settings(settings: Settings, report):
    """The settings of the family whose BRDF the report measures (its ``report``): ``settings.family``,
    else the report's ``REPORT_SETTINGS[settings.name]``."""
    if settings.family is not None:
        return settings.family
    return report.REPORT_SETTINGS[settings.name]
