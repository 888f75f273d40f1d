"""The built-in families: each a folder, declared by its package's :class:`fitlab.core.Family` subclass.

:data:`BUILTIN` is what the registry (:mod:`fitlab.core`) knows of them: importing this package imports each
family's class only (its name, description and targets' names), none of its targets, forms or services.
"""

from fitlab.core import Family
from fitlab.families.fresnel import Fresnel
from fitlab.families.lambert_sphere import LambertSphere
from fitlab.families.microfacet_energy import MicrofacetEnergy

__all__ = ["BUILTIN"]

#: the built-in families, in the order commands list them
BUILTIN: tuple[Family, ...] = (Fresnel(), LambertSphere(), MicrofacetEnergy())
