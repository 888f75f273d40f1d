"""The baselines' program: Lambert and Oren-Nayar (sigma = 0.5) from :mod:`..forms.baselines`, as routines with the
runtime model's per-material set-up, printed by the code generator (the benchmark's C, the renders' Dr.Jit)."""

from __future__ import annotations

from fitlab.codegen import MaterialSpec, Program, Routine, material_of
from fitlab.families.lambert_sphere.forms.baselines import BASELINE_INPUTS, LAMBERT, oren_nayar

__all__ = ["baseline_program"]

_BASELINE_DOMAIN = {"mu_i": (0.0, 1.0), "mu_o": (0.0, 1.0), "cos_phi": (-1.0, 1.0), "kd": (0.0, 1.0)}


def baseline_program() -> Program:
    """Lambert and Oren-Nayar (sigma = 0.5) from :mod:`fitlab.families.lambert_sphere.forms.baselines`, as routines,
    with the same per-material set-up as the runtime model (``eval_lambert(m, ...)``, ``eval_oren_nayar(m, ...)``,
    m = ``prepare_kd(kd)``), so that the benchmark compares like with like."""
    routines = (Routine("baseline_lambert", BASELINE_INPUTS, LAMBERT, "Lambert, kd/pi.", domain=_BASELINE_DOMAIN),
                Routine("baseline_oren_nayar", BASELINE_INPUTS, oren_nayar(), "Oren-Nayar (qualitative), sigma = 0.5.",
                        domain=_BASELINE_DOMAIN))  # fmt: skip
    spec = MaterialSpec(("kd",), {"eval_lambert": "baseline_lambert", "eval_oren_nayar": "baseline_oren_nayar"})
    return Program(routines, (), (), name="baselines", material=material_of(routines, spec))
