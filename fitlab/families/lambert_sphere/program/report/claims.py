r"""What the generated code states about itself, in the report: the accuracy against the true BRDF that
``fitlab codegen`` measures and prints in the banner of each model of the family's program
(:func:`fitlab.families.lambert_sphere.program.spec.claim`, :func:`..runtime.model_accuracy`), so that the
report, the README and the banner print the same figures."""

from __future__ import annotations

from fitlab.codegen import program_spec
from fitlab.core import get_target
from fitlab.families.lambert_sphere.program.runtime import model_accuracy
from fitlab.families.lambert_sphere.program.spec import MODEL_PARTS, THREE_TERM_MODEL, TRUE_MODEL
from fitlab.report.write import sci
from fitlab.store import fit_source, load

__all__ = ["CLAIM_MODELS", "claim_rows", "claim_section"]

#: the models whose claims the report prints, with the report's name of each (its BRDF rows' names)
CLAIM_MODELS = {TRUE_MODEL: "model true (the default)", THREE_TERM_MODEL: "model three-term"}


def claim_rows() -> list[dict]:
    """One row per model of :data:`CLAIM_MODELS` (section "claim"), from the packaged fits: the figures its generated
    banner states (max and RMS relative error over mu_i, mu_o in [0.01, 1], every c and phi; max at grazing; the
    directional albedo at c = 1)."""
    spec = program_spec("lambert_sphere")
    rows = []
    for model_name, method in CLAIM_MODELS.items():
        model = spec.model(model_name)
        parts = {p: load(fit_source(None, p, model.forms.get(p, get_target(p).default_form), model.folder)).expression
                 for p in MODEL_PARTS}  # fmt: skip
        a = model_accuracy(parts, spec.terms)
        rows.append({"section": "claim", "target": "f_r", "group": "claim", "method": method,
                     "source": f"fitlab codegen --model {model_name}", "points": a["points"], "max_rel": a["max"],
                     "rms_rel": a["rms"], "max_rel_grazing": a["max_grazing"], "albedo_err": a["albedo_err"],
                     "note": f"as the generated banner states it: mu_i, mu_o in [0.01, 1], every c and phi; grazing "
                             f"down to mu = 1e-6 ({a['grazing_points']} points); albedo at c = 1 from "
                             f"{a['albedo_c1_min']:.6f} to {a['albedo_c1_max']:.6f}"})  # fmt: skip
    return rows


def claim_section(rows) -> list[str]:
    """report.md's section on what the generated code states (markdown lines)."""
    claims = [r for r in rows if r["section"] == "claim"]
    if not claims:
        return []
    out = [
        "## What the generated code states",
        "",
        "The accuracy against the true BRDF that `fitlab codegen` measures when it prints each model, and states "
        "in the banner and in the documentation of `brdf` (on its own sets: `runtime.accuracy`, mu_i, mu_o in "
        "[0.01, 1], every c and phi, and a grazing set down to mu = 1e-6).",
        "",
        "| model | command | max rel | RMS rel | max rel, grazing | albedo at c = 1 |",
        "|---|---|---|---|---|---|",
    ]
    for r in claims:
        albedo = r["note"].rsplit("albedo at c = 1 ", 1)[-1]
        out.append(f"| {r['method']} | `{r['source']}` | {sci(r['max_rel'])} | {sci(r['rms_rel'])} | "
                   f"{sci(r['max_rel_grazing'])} | {albedo} |")  # fmt: skip
    return out
