"""The microfacet_energy forms, each defined once as a sympy expression.

Every published approximation found for these targets (the research note /tmp/kc_approximations.md,
sources in each module's docstring) is a preset of its form; richer forms for refit sit beside them.
The forms of E are written once (:mod:`.ggx`, :mod:`.oren_nayar`); the 1 - E target of each model
takes every one of them as 1 - (that form), same name, parameters and presets
(:func:`.common.complement`).  :mod:`.average` holds the forms of E_avg.
"""

from fitlab.families.microfacet_energy.forms import average, ggx, oren_nayar
from fitlab.families.microfacet_energy.forms.common import complement
from fitlab.families.microfacet_energy.forms.lobes import lobe_forms
from fitlab.families.microfacet_energy.targets import target_name

__all__ = ["FORMS"]


def _model_forms(model: str) -> tuple:
    e_target = target_name("E", model)
    e = oren_nayar.e_forms(e_target) if model == "oren_nayar" else ggx.e_forms(e_target, model)
    one_minus = tuple(complement(f, target_name("one_minus_E", model)) for f in e)
    return (*e, *one_minus, *average.average_forms(target_name("E_avg", model), model))


FORMS = tuple(f for model in ("ggx_separable", "ggx_correlated", "oren_nayar") for f in _model_forms(model))
# the forms of the multiple-scattering lobe parameters, with the blog's presets: forms.lobes
FORMS += tuple(f for kind in ("diffuse", "conductor") for f in lobe_forms(kind))
