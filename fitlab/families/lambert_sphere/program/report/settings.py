r"""The Lambert sphere's settings of ``fitlab report`` (moved from :mod:`fitlab.report.settings`, which knows
no family), by the generic settings' name (:data:`REPORT_SETTINGS`: "full", "quick"): at which albedos the BRDF
is measured (:mod:`.materials`), how hard the family's exact engine and Monte Carlo are measured, and the quick
report's choice of parts and refits; and the BRDF's signature (:data:`BRDF_INPUTS`).  The family's report
(:mod:`.methods`) gives them to the report (:class:`fitlab.report.methods.BrdfReport`).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["EngineSettings", "REPORT_SETTINGS", "BRDF_INPUTS", "BRDF_POINT", "BRDF_MATERIAL"]

#: the BRDF's inputs, in the order every method's ``evaluate`` takes them: directions (mu_i, mu_o, phi), the
#: albedo c and its diffuse albedo kd (0 where a method ignores it)
BRDF_INPUTS = ("mu_i", "mu_o", "phi", "c", "kd")
#: the inputs that name a point of the validation set (kd follows from c)
BRDF_POINT = ("mu_i", "mu_o", "phi", "c")
#: the material's inputs: all 0 is the black material, where an exact model's BRDF is exactly 0 (max_abs_c0)
BRDF_MATERIAL = ("c", "kd")


@dataclass(frozen=True)
class EngineSettings:
    """How hard the report measures the exact engine and Monte Carlo, and at which albedos it measures the
    BRDF (:mod:`.materials`)."""

    #: the validation sets' albedos: ``small_c``, then ``n_c`` values c = 1 - s^2 off every grid, then c = 1
    #: when ``with_c1``; the independent set's ``fresh_c`` albedos; the energy check's ``energy_c``
    n_c: int = 15
    with_c1: bool = True
    small_c: tuple = (1e-6, 1e-5, 1e-4, 1e-3, 1e-2)
    fresh_c: int = 64
    energy_c: tuple = (1e-3, 0.3, 0.7, 0.95, 1.0)

    #: exact engine: H-function convergence study (orders, albedos, resolutions)
    exact_orders: tuple = (0, 1)
    exact_c: tuple = (0.5, 0.99, 1.0)
    exact_mu_points: int = 256
    nystrom_nodes: tuple = (2, 3, 4, 6, 8, 12, 16, 24)
    fock_steps: tuple = (1.4, 1.0, 0.7, 0.5, 0.35, 0.25, 0.1)
    #: exact engine: the cost of the BRDF, timed on this many of the numpy timing inputs (at most)
    exact_cost_points: int = 8192
    #: exact engine vs discrete ordinates + doubling (albedo, orders); () skips it
    doubling_c: float = 0.5
    doubling_orders: tuple = (0, 1, 2)
    #: Monte Carlo: materials, incident cosines, path counts
    mc_c: tuple = (0.5, 0.9)
    mc_mu_i: tuple = (0.3, 0.7)
    mc_mu_edges: tuple = (0.2, 0.4, 0.6, 0.8, 1.0)
    mc_phi_bins: int = 4
    mc_paths: tuple = (1_000, 10_000, 100_000, 1_000_000)
    #: the report's choices where its generic settings leave them to the family (None: every one): the targets
    #: measured at part level, the refits timed as (target, form)
    parts: tuple | None = None
    refits: tuple | None = None


#: the generic settings' name (fitlab.report.FULL, QUICK) -> the family's
REPORT_SETTINGS = {
    "full": EngineSettings(),
    "quick": EngineSettings(
        n_c=2,
        with_c1=False,
        small_c=(1e-4,),
        fresh_c=3,
        energy_c=(1.0,),
        exact_orders=(1,),
        exact_c=(0.5,),
        exact_mu_points=32,
        nystrom_nodes=(4, 8),
        fock_steps=(0.7, 0.35),
        exact_cost_points=1024,
        doubling_orders=(),
        mc_c=(0.5,),
        mc_mu_i=(0.5,),
        mc_mu_edges=(0.0, 0.5, 1.0),
        mc_phi_bins=2,
        mc_paths=(1_000, 4_000),
        parts=("H0", "m"),
        refits=(("m", "linear"),),
    ),
}
