"""fitlab's core vocabulary: inputs, targets, datasets, the family contract and the registry.

A *family* (a :class:`Family` subclass: one folder under :mod:`fitlab.families`, or a class a distribution's
``fitlab.families`` entry point names) owns its targets, forms, exact engine and the services of its
capabilities (:class:`Capability`).  The generic machinery (fit, codegen, discover, residuals, report, cli)
loops over :func:`targets` and :func:`offering` and names no family's targets.
"""

from fitlab._precision import float64
from fitlab.core._capabilities import (
    Benchmarks,
    BrdfGrid,
    HasAudit,
    HasBenchmarks,
    HasBrdfGrid,
    HasImages,
    HasMaterials,
    HasMonteCarlo,
    HasRender,
    HasTableExport,
    HasTables,
    MeasuredMaterial,
    Outputs,
    Render,
    TableExport,
    Tables,
)
from fitlab.core._dataset import Dataset, data_hash
from fitlab.core._family import Capability, Family
from fitlab.core._input import Input
from fitlab.core._registry import (
    broken_families,
    did_you_mean,
    families,
    family_names,
    family_with,
    forms_for,
    get_family,
    get_form,
    get_target,
    offering,
    register_family,
    target_names,
    targets,
    unregister_family,
)
from fitlab.core._target import Target

__all__ = [
    "Benchmarks",
    "BrdfGrid",
    "Capability",
    "Dataset",
    "Family",
    "HasAudit",
    "HasBenchmarks",
    "HasBrdfGrid",
    "HasImages",
    "HasMaterials",
    "HasMonteCarlo",
    "HasRender",
    "HasTableExport",
    "HasTables",
    "Input",
    "MeasuredMaterial",
    "Outputs",
    "Render",
    "TableExport",
    "Tables",
    "Target",
    "broken_families",
    "data_hash",
    "did_you_mean",
    "families",
    "family_names",
    "family_with",
    "float64",
    "forms_for",
    "get_family",
    "get_form",
    "get_target",
    "offering",
    "register_family",
    "target_names",
    "targets",
    "unregister_family",
]
