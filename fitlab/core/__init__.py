"""fitlab's core vocabulary: inputs, targets, datasets, families and their registry.

A *family* (one folder under :mod:`fitlab.families`, or any importable module that
calls :func:`register_family`) owns its targets, forms, exact engine, runtime
models and report methods.  The generic machinery (fit, codegen, discover,
residuals, report, cli) loops over :func:`targets` and names no family's
targets.
"""

from fitlab.core._dataset import Dataset, data_hash
from fitlab.core._hooks import (
    AuditHook,
    BenchHook,
    BrdfGrid,
    BrdfGridHook,
    BrdfReportHook,
    ImagesHook,
    ModelContract,
    Outputs,
    ProgramContract,
    RenderHook,
    ReportHook,
    TableExportHook,
    TablesHook,
    check_hook,
)
from fitlab.core._input import Input
from fitlab.core._precision import float64
from fitlab.core._registry import (
    Family,
    broken_families,
    did_you_mean,
    families,
    families_offering,
    family_service,
    forms_for,
    get_family,
    get_form,
    get_target,
    manifest_hooks,
    register_family,
    resolve_hook,
    target_names,
    targets,
    unregister_family,
)
from fitlab.core._target import Target

__all__ = [
    "AuditHook",
    "Outputs",
    "BenchHook",
    "BrdfGrid",
    "BrdfGridHook",
    "BrdfReportHook",
    "ModelContract",
    "ProgramContract",
    "RenderHook",
    "ReportHook",
    "TableExportHook",
    "ImagesHook",
    "TablesHook",
    "check_hook",
    "resolve_hook",
    "Dataset",
    "Family",
    "Input",
    "Target",
    "broken_families",
    "data_hash",
    "did_you_mean",
    "families",
    "families_offering",
    "family_service",
    "float64",
    "forms_for",
    "get_family",
    "get_form",
    "get_target",
    "manifest_hooks",
    "register_family",
    "target_names",
    "targets",
    "unregister_family",
]
