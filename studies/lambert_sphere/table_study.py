r"""What to store in the exported tables, and at what resolution: docs/table_export.md (and .json, .png).

``python -m studies.lambert_sphere.table_study --out docs`` measures, against the exact engine (for the
BRDF the true one, the whole phase function in every collision: the BRDF the tables carry, so that the error is
the lookups' and the Fourier orders m >= 3 the correction leaves out):

* the candidates for what the H rows hold (:data:`fitlab.families.lambert_sphere.program.table_export.QUANTITIES`: H
  itself, log(H)/mu less its grazing term, the remainder beyond the exact grazing and first-order parts), each with the
  bilinear and the bicubic lookup, at 17, 33 and 65 nodes per axis: H0, H1, H2 on their validation sets (relative error
  of H and of H - 1, which the BRDF's (H_i H_o - 1)/(mu_i + mu_o) terms magnify) and the BRDF on the report's sets
  (:mod:`fitlab.report.validation`: the validation set with c down to 1e-6, the grazing set with mu down to 1e-6, the
  independent set);
* the resolution of the shipped quantity, 5 to 65 nodes, against bytes and texel reads per call, for both lookups;
* how the true-phase correction is read along s
  (:data:`fitlab.families.lambert_sphere.program.table_export.CORRECTION_S_CHOICES`: linear or cubic, on every node of
  the exact table's s grid or every other one) at the shipped resolution: the BRDF on the report's sets, its distance
  from the tricubic lookup on every node (what the reading along s adds), and the correction's error at the exact
  table's s nodes a reading skips.

The constants, c(kd) and the true-phase correction are stored and read the same way in every candidate row
(the correction with the H rows' lookup across the cosines and the shipped one along s), so rows of one lookup
differ in H alone.  Every exact value comes from
the caches of the report and the targets (computed by the
exact engine on a first run, several minutes).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from fitlab.families.lambert_sphere.program import table_export as te
from fitlab.families.lambert_sphere.targets.datasets import h_validation

__all__ = [
    "candidate_rows",
    "resolution_rows",
    "correction_rows",
    "study",
    "markdown",
    "plot_png",
    "main",
    "FILES",
    "REFERENCE_PHASE",
]

FILES = ("table_export.md", "table_export.json", "table_export.png")
#: H - 1 is measured where |H - 1| is at least this (the exact values are H in double: 1e-16 of H)
H_MINUS_1_FLOOR = 1e-8
_INPUTS = ("mu_i", "mu_o", "phi", "c")


def _rel(approx, exact) -> np.ndarray:
    approx, exact = np.asarray(approx, dtype=float), np.asarray(exact, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        err = np.abs(approx - exact) / np.abs(exact)
    err = np.where(exact == approx, 0.0, err)
    return np.where(np.isfinite(err), err, np.inf)


#: the exact BRDF the tables are measured against: the one they carry (the three-term orders corrected to the whole
#: phase function)
REFERENCE_PHASE = "true"


def _sets():
    """The report's validation, grazing and independent sets: their values are the exact BRDF of
    :data:`REFERENCE_PHASE` (the report's exact method), computed once and cached by the report."""
    from fitlab.report.settings import FULL
    from fitlab.report.validation import fresh_set, validation_sets

    valid, grazing = validation_sets(FULL)
    return {"valid": valid, "grazing": grazing, "fresh": fresh_set(FULL)}


def _measure(nodes: int, lookup: str, quantity: str, sets: dict, h_sets: dict, data_dir) -> dict:
    out = {"nodes": nodes, "lookup": lookup, "quantity": quantity, "bytes": te.memory_bytes(nodes),
           "texels": te.texels_per_call(nodes, lookup)}  # fmt: skip
    for order, v in h_sets.items():
        h = te.numpy_part(f"H{order}", nodes, lookup, data_dir, quantity)(v.inputs["mu"], v.inputs["c"])
        out[f"H{order}_max_rel"] = float(_rel(h, v.y).max())
        # where |H - 1| >= 1e-8: below, the exact value's own rounding (1e-16 of H) is 1e-8 of H - 1 or more
        moved = np.abs(v.y - 1.0) >= H_MINUS_1_FLOOR
        out[f"H{order}_minus_1_max_rel"] = float(_rel(h[moved] - 1.0, v.y[moved] - 1.0).max())
    f = te.numpy_brdf(nodes, lookup, data_dir, quantity)
    for name, v in sets.items():
        e = _rel(f(*(v.inputs[k] for k in _INPUTS)), v.y)
        out[f"{name}_max_rel"] = float(e.max())
        out[f"{name}_rms_rel"] = float(np.sqrt(np.mean(e**2)))
        k = int(np.argmax(e))
        out[f"{name}_worst"] = {n: float(v.inputs[n][k]) for n in _INPUTS}
    if quantity == te.DEFAULT_QUANTITY and lookup == te.DEFAULT_LOOKUP and nodes == te.DEFAULT_NODES:
        out["tiny_c"] = _tiny_c(f)
    valid = sets["valid"]
    at0 = f(valid.inputs["mu_i"], valid.inputs["mu_o"], valid.inputs["phi"], np.zeros_like(valid.inputs["c"]))
    out["max_abs_c0"] = float(np.max(np.abs(at0)))
    return out


#: below the report's smallest albedo: forward scattering (phi = pi) at mu_i = mu_o = mu
TINY_C = (1e-6, 1e-8, 1e-10)
TINY_MU = (1e-6, 1e-4, 1e-2)


def _tiny_c(f) -> list[dict]:
    """Forward scattering at grazing for albedos down to 1e-10, against :data:`REFERENCE_PHASE` (one point each)."""
    from fitlab.families.lambert_sphere.exact import brdf

    out = []
    for cv in TINY_C:
        for m in TINY_MU:
            exact = float(brdf(np.array([m]), np.array([m]), np.array([np.pi]), cv, phase=REFERENCE_PHASE)[0])
            value = float(f(m, m, np.pi, cv))
            out.append({"c": cv, "mu": m, "exact": exact, "value": value, "rel": float(_rel(value, exact))})
    return out


def candidate_rows(sets, h_sets, data_dir=None, tick=None) -> list[dict]:
    """Every stored quantity x lookup at 17, 33, 65 nodes."""
    rows = []
    for quantity in te.QUANTITIES:
        for lookup in ("linear", "cubic"):
            for nodes in (17, 33, 65):
                rows.append(_measure(nodes, lookup, quantity, sets, h_sets, data_dir))
                if tick:
                    tick()
    return rows


def resolution_rows(sets, h_sets, data_dir=None, tick=None) -> list[dict]:
    """The shipped quantity at every resolution (:data:`fitlab.families.lambert_sphere.program.table_export.NODES`),
    both lookups."""
    rows = []
    for lookup in ("linear", "cubic"):
        for nodes in te.NODES:
            rows.append(_measure(nodes, lookup, te.DEFAULT_QUANTITY, sets, h_sets, data_dir))
            if tick:
                tick()
    return rows


#: the reading along s every other one is measured against: cubic on every node of the exact table's s grid
CORRECTION_REFERENCE = ("cubic", 1)


def correction_rows(sets, data_dir=None, tick=None) -> list[dict]:
    """Each reading of the correction along s
    (:data:`fitlab.families.lambert_sphere.program.table_export.CORRECTION_S_CHOICES`) at the shipped resolution and
    lookup: the BRDF against the exact one on the report's sets; its distance from the BRDF that reads the correction by
    :data:`CORRECTION_REFERENCE` (max and RMS of |f - f_ref|/f_exact: what the reading along s adds, the rest being
    common); and, for a reading that skips nodes of the exact table's s grid, the correction there against the table's
    exact values (sum over the orders of max |dQ_m|, an error relative to fm0)."""
    from fitlab.families.lambert_sphere.targets.table_files import TRUE_S_GRID

    nodes, lookup = te.DEFAULT_NODES, te.DEFAULT_LOOKUP
    inputs = {name: [v.inputs[k] for k in _INPUTS] for name, v in sets.items()}
    ref_f = te.numpy_brdf(nodes, lookup, data_dir, correction_s=CORRECTION_REFERENCE)
    ref = {name: ref_f(*x) for name, x in inputs.items()}
    every = te.stored_correction(nodes, data_dir, CORRECTION_REFERENCE).astype(np.float32).astype(float)
    n = every.shape[2]
    root = (np.arange(n) / (n - 1)) ** 2
    mi, mo = np.meshgrid(root, root, indexing="ij")
    rows = []
    for choice in te.CORRECTION_S_CHOICES:
        s_lookup, step = choice
        out = {"s_lookup": s_lookup, "s_nodes": int(te.layout(nodes, choice).correction_s_nodes),
               "bytes": te.memory_bytes(nodes, choice), "texels": te.texels_per_call(nodes, lookup, choice),
               "shipped": tuple(choice) == tuple(te.DEFAULT_CORRECTION_S)}  # fmt: skip
        f = te.numpy_brdf(nodes, lookup, data_dir, correction_s=choice)
        for name, v in sets.items():
            got = f(*inputs[name])
            e = _rel(got, v.y)
            out[f"{name}_max_rel"] = float(e.max())
            out[f"{name}_rms_rel"] = float(np.sqrt(np.mean(e**2)))
            d = np.abs(got - ref[name]) / np.abs(v.y)
            out[f"{name}_from_reference_max"] = float(d.max())
            out[f"{name}_from_reference_rms"] = float(np.sqrt(np.mean(d**2)))
        skipped = [k for k in range(TRUE_S_GRID.size) if k % step]
        if skipped:
            worst = []
            for m in range(every.shape[0]):
                q = te.numpy_correction(m, nodes, lookup, data_dir, correction_s=choice)
                at = [q(mi, mo, np.full_like(mi, 1.0 - TRUE_S_GRID[k] ** 2)) - every[m, k] for k in skipped]
                worst.append(max(float(np.abs(d).max()) for d in at))
            out["skipped_s"] = [float(TRUE_S_GRID[k]) for k in skipped]
            out["skipped_max_abs_q"] = float(sum(worst))
        rows.append(out)
        if tick:
            tick()
    return rows


#: where the Fourier orders m >= 3 the correction leaves out are measured: c x mu_i x mu_o x phi
LEFT_OUT_GRID = ((1.0, 0.75, 0.3, 0.05), (1e-4, 1e-3, 0.01, 0.05, 0.2, 0.5, 1.0), (0.0, np.pi / 3, np.pi / 2, np.pi))


def orders_left_out() -> dict:
    """max |sum_{m >= 3} fm_m cos(m phi)| / f over :data:`LEFT_OUT_GRID` (f the true BRDF), with its point: what
    the tables leave out by correcting orders 0 to 2 only."""
    from fitlab.families.lambert_sphere.exact import brdf, true_phase

    cs, mus, phis = LEFT_OUT_GRID
    mi, mo, ph = np.meshgrid(mus, mus, phis, indexing="ij")
    worst = {"rel": 0.0}
    for cv in cs:
        orders = true_phase.multiple_scattering_orders(mi, mo, cv)
        rest = sum(fm * np.cos(m * ph) for m, fm in enumerate(orders) if m >= 3)
        rel = np.abs(rest) / brdf(mi, mo, ph, cv, phase="true")
        k = np.unravel_index(int(np.argmax(rel)), rel.shape)
        if rel[k] > worst["rel"]:
            worst = {"rel": float(rel[k]), "c": cv, "mu_i": float(mi[k]), "mu_o": float(mo[k]), "phi": float(ph[k])}
    return worst


def study(data_dir=None, progress: bool = True) -> dict:
    """Both tables of the study (exact values from the caches)."""
    from tqdm import tqdm

    steps = 3 + 18 + 2 * len(te.NODES) + len(te.CORRECTION_S_CHOICES)
    with tqdm(total=steps, desc="table study", unit="step", disable=not progress) as bar:
        sets = _sets()
        bar.update(1)
        h_sets = {m: h_validation(m) for m in range(3)}
        bar.update(2)
        candidates = candidate_rows(sets, h_sets, data_dir, lambda: bar.update(1))
        resolution = resolution_rows(sets, h_sets, data_dir, lambda: bar.update(1))
        correction = correction_rows(sets, data_dir, lambda: bar.update(1))
    points = {name: len(v) for name, v in sets.items()}
    return {"candidates": candidates, "resolution": resolution, "correction": correction, "points": points,
            "left_out": orders_left_out(),
            "sets": {name: v.grid for name, v in sets.items()},
            "h_sets": {f"H{m}": v.grid for m, v in h_sets.items()}}  # fmt: skip


def _e(x: float) -> str:
    return f"{x:.2e}"


def _listed(values) -> str:
    return "{" + ", ".join(f"{v:g}" for v in values) + "}"


def _kb(n: int) -> str:
    return f"{n / 1000:.1f}"


def markdown(result: dict) -> str:
    c = result["candidates"]
    p = result["points"]
    lo = result["left_out"]
    lookup_name = {"linear": "bilinear", "cubic": "bicubic"}
    out = ["# The exported tables: what is stored, and at what resolution", "",
           "Generated by `python -m studies.lambert_sphere.table_study --out docs` (do not edit; every number "
           "is in table_export.json). What engines ship: one float32 texture read by a bilinear or bicubic lookup "
           "(`fitlab codegen --tables`; docs/codegen.md, 'Tables as engines ship them'). Every node of the texture is "
           "a node of the exact tables (s = sqrt(1 - c) = k/64, mu = j/64; the true-phase correction Q_m at s = k/4, "
           "sqrt(mu) = j/32, nodes of true_orders.csv), so the error is the lookups' between the nodes, float32's "
           "rounding of the stored values, and the Fourier orders m >= 3 of the true multiple scattering, which the "
           f"correction leaves out: at most {_e(lo['rel'])} of the BRDF (at c = {lo['c']:g}, mu_i = {lo['mu_i']:g}, "
           f"mu_o = {lo['mu_o']:g}, phi = {lo['phi'] / np.pi:g} pi) on c in {_listed(LEFT_OUT_GRID[0])} "
           f"x mu_i, mu_o in {_listed(LEFT_OUT_GRID[1])} x phi in {{0, pi/3, pi/2, pi}}.", "",
           f"**Sets.** H: each target's validation set ({result['h_sets']['H0']}; relative error of H and of H - 1). "
           "BRDF, against the true BRDF (`exact.brdf(phase=\"true\")`: the whole phase function in every collision, "
           "the BRDF the tables carry) at "
           f"the points of the report's validation set ({p['valid']} points: {result['sets']['valid']}), "
           f"its grazing set ({p['grazing']} points: {result['sets']['grazing']}) and its independent set ({p['fresh']} "
           f"points: {result['sets']['fresh']}); max and RMS relative error. The constants are read the same way in "
           "every row (cubic in s, per material) and the true-phase correction with the row's lookup across the "
           "cosines and as shipped along s (below, 'The correction along s'), so rows of one lookup differ in H "
           "alone.", "",
           "## What the H rows hold", "",
           "| stored | lookup | nodes | bytes | H0 max rel | H0 - 1 max rel | H1 - 1 max rel | H2 - 1 max rel | BRDF max rel "
           "| BRDF RMS rel | grazing max rel | fresh max rel |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    names = {"remainder": "remainder R (shipped)", "log": "log(H)/mu - Psi log(1 + 1/mu)", "h": "H"}
    for r in c:
        out.append(f"| {names[r['quantity']]} | {lookup_name[r['lookup']]} | {r['nodes']} | {r['bytes']} | "
                   f"{_e(r['H0_max_rel'])} | {_e(r['H0_minus_1_max_rel'])} | {_e(r['H1_minus_1_max_rel'])} | "
                   f"{_e(r['H2_minus_1_max_rel'])} | {_e(r['valid_max_rel'])} | {_e(r['valid_rms_rel'])} | "
                   f"{_e(r['grazing_max_rel'])} | {_e(r['fresh_max_rel'])} |")  # fmt: skip
    tiny = next(r for r in result["resolution"] if "tiny_c" in r)["tiny_c"]
    floor = next(r["rel"] for r in tiny if r["c"] == TINY_C[0] and r["mu"] == TINY_MU[0])

    def at(q, lookup, n):
        return next(r for r in c if r["quantity"] == q and r["lookup"] == lookup and r["nodes"] == n)

    lowest = all(min(te.QUANTITIES, key=lambda q: at(q, lk, n)["valid_max_rel"]) == "remainder"
                 for lk in ("linear", "cubic") for n in (17, 33, 65))  # fmt: skip
    h, lg, rm = (at(q, "cubic", 65) for q in ("h", "log", "remainder"))
    lg1, rm1 = at("log", "linear", 65), at("remainder", "linear", 65)
    out += ["", f"H - 1 is measured where |H - 1| >= {H_MINUS_1_FLOOR:g} (the exact values are H in double). Why the "
            "remainder (65 nodes):", "",
            "* H itself: near mu = 0, H - 1 ~ Psi(0) mu log(1/mu) has an infinite slope, which no polynomial lookup "
            "follows, and the BRDF's (H_i H_o - 1)/(mu_i + mu_o) magnifies the error of H - 1: bicubic "
            f"{_e(h['valid_max_rel'])} on the BRDF, {_e(h['grazing_max_rel'])} at grazing.",
            "* log(H)/mu less its grazing term: the grazing behaviour is exact, but the O(c) part is interpolated in "
            "s = sqrt(1 - c), and as c -> 0 the multiple scattering is O(c^2), a difference of O(c) terms that needs "
            f"the O(c) part to relative accuracy: bilinear {_e(lg1['valid_max_rel'])} (worst at c = "
            f"{lg1['valid_worst']['c']:.3g}), bicubic {_e(lg['valid_max_rel'])}.",
            "* the remainder beyond the exact grazing and first-order parts: it enters the BRDF at O(c^3) as c -> 0: "
            f"bilinear {_e(rm1['valid_max_rel'])}, bicubic {_e(rm['valid_max_rel'])}"
            + ("; the lowest of the three in every row above." if lowest else "."), "",
            f"In forward scattering at grazing (c = {TINY_C[0]:g}, mu_i = mu_o = {TINY_MU[0]:g}: {_e(floor)}) the "
            "multiple scattering is O(c^2) (the BRDF about 1e-12) while each of its terms is of order c/(mu_i + mu_o) "
            "= 0.5; the runtime formula subtracts their O(c) parts in the algebra, not in floating point (docs/model.md, "
            "'The runtime BRDF'), so the error stays at the table's level below the report's smallest albedo too (the "
            "shipped table, forward scattering, mu_i = mu_o = mu, against the true BRDF):", "", "| c | " + " | ".join(f"mu = {m:g}" for m in TINY_MU) + " |",
            "|---|" + "---|" * len(TINY_MU),
            *(f"| {cv:g} | " + " | ".join(_e(r["rel"]) for r in tiny if r["c"] == cv) + " |" for cv in TINY_C), "",
            "## Resolution against accuracy (the shipped quantity)", "",
            "| lookup | nodes per axis | texture (columns x rows) | bytes | KB | texels per call | BRDF max rel | "
            "BRDF RMS rel | grazing max rel | fresh max rel | fresh RMS rel | max abs, c = 0 |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for r in result["resolution"]:
        n = r["nodes"]
        out.append(f"| {lookup_name[r['lookup']]} | {n} | {n} x {te.layout(n).rows} | {r['bytes']} | {_kb(r['bytes'])} | "
                   f"{r['texels']} | "
                   f"{_e(r['valid_max_rel'])} | {_e(r['valid_rms_rel'])} | {_e(r['grazing_max_rel'])} | "
                   f"{_e(r['fresh_max_rel'])} | {_e(r['fresh_rms_rel'])} | {r['max_abs_c0']:.1e} |")  # fmt: skip
    cubic = {r["nodes"]: r for r in result["resolution"] if r["lookup"] == "cubic"}
    linear = {r["nodes"]: r for r in result["resolution"] if r["lookup"] == "linear"}
    d = te.DEFAULT_NODES
    out += ["", f"The bicubic lookup pays: at {d} nodes ({_kb(cubic[d]['bytes'])} KB) it is "
            f"{_e(cubic[d]['valid_max_rel'])} on the BRDF, where the bilinear one needs 65 nodes "
            f"({_kb(linear[65]['bytes'])} KB) for {_e(linear[65]['valid_max_rel'])}; the H lookups' error falls as "
            "h^4 (16 texels per lookup instead of 4; H0 at 65 nodes: "
            f"{_e(cubic[65]['H0_max_rel'])}), and what is left from 33 nodes up is the true-phase correction's "
            f"(at most {te.CORRECTION_MAX_NODES} nodes per cosine axis) and the orders m >= 3 it leaves out. "
            f"`fitlab codegen --tables` ships {d} nodes, bicubic, by default; 65 nodes "
            f"({_e(cubic[65]['valid_max_rel'])}) buy nothing on the BRDF, and any node count of the table's grid can "
            "be asked for (`--nodes`, `--lookup linear`). Texels per call: the distinct texel reads of one call of "
            "brdf (`table_export.texels_per_call`), which is one routine: every lookup's weights and node indices "
            "are computed once and shared (those in s by H0, H1, H2 and the constants, those in mu by the three H "
            "at mu_i and at mu_o, those of the correction by its three orders).", "",
            "![BRDF error against bytes](table_export.png)", "", *_correction_markdown(result)]  # fmt: skip
    return "\n".join(out)


def _correction_markdown(result: dict) -> list[str]:
    rows = result["correction"]
    ref = CORRECTION_REFERENCE
    names = {"linear": "linear", "cubic": "cubic"}
    out = [f"## The correction along s ({te.DEFAULT_NODES} nodes, bicubic)", "",
           "The correction Q_m is read bicubic across sqrt(mu_o), sqrt(mu_i) and, along s, linear or cubic on the "
           "nodes of true_orders.csv (s = k/8) or on every other one (s = k/4), one lookup for the three orders. "
           f"'From the reference': max and RMS over the validation set of |f - f_ref|/f, f_ref the BRDF with the "
           f"correction read {names[ref[0]]} on every node: what the reading along s adds, the rest of the error being "
           "common. 'Skipped nodes': at the nodes of true_orders.csv a reading does not read (s = k/8, k odd; every "
           "sqrt(mu) = j/32), the correction against the table's exact values, sum over m of max |dQ_m| (an error "
           "relative to fm0, by which Q multiplies).", "",
           "| along s | s nodes | texels per call | bytes | BRDF max rel | BRDF RMS rel | grazing max rel | "
           "fresh max rel | from the reference: max | from the reference: RMS | skipped nodes: sum max abs dQ |",
           "|---|---|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for r in rows:
        label = f"{names[r['s_lookup']]}{' (shipped)' if r['shipped'] else ''}"
        skipped = _e(r["skipped_max_abs_q"]) if "skipped_max_abs_q" in r else "-"
        out.append(f"| {label} | {r['s_nodes']} | {r['texels']} | {r['bytes']} | {_e(r['valid_max_rel'])} | "
                   f"{_e(r['valid_rms_rel'])} | {_e(r['grazing_max_rel'])} | {_e(r['fresh_max_rel'])} | "
                   f"{_e(r['valid_from_reference_max'])} | {_e(r['valid_from_reference_rms'])} | "
                   f"{skipped} |")  # fmt: skip
    shipped = next(r for r in rows if r["shipped"])
    adds = max(shipped[f"{name}_from_reference_max"] for name in ("valid", "grazing", "fresh"))
    most = max(r[f"{name}_max_rel"] for r in rows for name in ("valid", "fresh"))
    cheapest = min(rows, key=lambda r: (r["texels"], r["bytes"]))
    out += ["", f"The shipped reading, {names[shipped['s_lookup']]} on {shipped['s_nodes']} nodes, reads "
            f"{shipped['texels']} texels per call in {_kb(shipped['bytes'])} KB"
            + (" (the fewest, in the fewest bytes)" if cheapest is shipped else "")
            + f"; it adds at most {_e(adds)} of the BRDF (over the three sets, from the reference) to an error every "
            f"reading shares, at most {_e(most)} on the validation and independent sets: the orders m >= 3 the "
            "correction leaves out and the lookups across the cosines, not the reading along s.",
            ""]  # fmt: skip
    return out


def plot_png(result: dict) -> bytes:
    """Max relative error of the BRDF against the texture's bytes, one line per stored quantity and lookup."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5), dpi=100)
    rows = result["candidates"] + [r for r in result["resolution"] if r["nodes"] not in (17, 33, 65)]
    for quantity in te.QUANTITIES:
        for lookup, style in (("linear", "--"), ("cubic", "-")):
            pts = sorted(
                (r["bytes"], r["valid_max_rel"]) for r in rows if r["quantity"] == quantity and r["lookup"] == lookup
            )
            ax.loglog(
                *zip(*pts), style, marker="o", label=f"{quantity}, {'bilinear' if lookup == 'linear' else 'bicubic'}"
            )
    ax.set_xlabel("texture bytes (float32)")
    ax.set_ylabel("BRDF max relative error (validation set)")
    ax.set_title("Exported Lambert-sphere tables: error against memory")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", metadata={"Software": None})
    plt.close(fig)
    return buf.getvalue()


def main(argv=None) -> int:
    from fitlab._io import FolderError, atomic_write_many, check_output_folder

    p = argparse.ArgumentParser(prog="python -m studies.lambert_sphere.table_study",
                                description="Measure what the exported tables store and at what resolution; write "
                                            + ", ".join(FILES) + " into --out as one unit.")  # fmt: skip
    p.add_argument("--out", default="docs", help="output folder (default: docs)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    args = p.parse_args(argv)
    try:
        out = check_output_folder(Path(args.out), FILES)
    except FolderError as exc:
        print(f"table_study: error: --out {args.out}: {exc}", file=sys.stderr)
        return 2
    result = study(progress=not args.quiet)
    files = {out / "table_export.md": markdown(result).encode(),
             out / "table_export.json": (json.dumps(result, indent=1, sort_keys=True) + "\n").encode(),
             out / "table_export.png": plot_png(result)}  # fmt: skip
    atomic_write_many(files)
    for path in files:
        print(f"wrote {path}") if not args.quiet else None
    return 0


if __name__ == "__main__":
    sys.exit(main())
