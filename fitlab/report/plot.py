r"""docs/accuracy_vs_cost.png: error against cost, log-log, one point per method, Pareto front drawn.

Two panels share the x axis (ns per evaluation: the generated C in double where
it exists, else numpy or the exact engine's Python, else Monte Carlo's seconds
per BRDF value) and show the max and the RMS relative error against the exact
BRDF.  Filled markers: cost of generated C; hollow: Python (numpy / exact
engine); triangles: Monte Carlo (error against exact bin averages, its own
points).  The front (:func:`fitlab.report.pareto.pareto_front`) is the staircase
through the methods no other method beats in both cost and error.
"""

from __future__ import annotations

import io
import math

import numpy as np

from fitlab.report.methods import GROUPS
from fitlab.report.pareto import pareto_front

__all__ = ["plot_png", "plot_cost"]


def plot_cost(row) -> tuple[float, str]:
    """(ns per evaluation, kind) a row is plotted at: C double, else numpy/Python."""
    c = row.get("ns_c_double")
    if c is not None and math.isfinite(c):
        return c, "C"
    if row["group"] == "monte carlo":
        return row.get("ns_python", math.nan), "MC"
    return row.get("ns_python", math.nan), "python"


def _numbered(rows) -> list[tuple[int, dict, float, str]]:
    """(number, row, x, kind) for every plottable row, numbered by group then cost."""
    order = {g: k for k, g in enumerate(GROUPS)}
    pts = [(r, *plot_cost(r)) for r in rows]
    pts = [t for t in pts if math.isfinite(t[1]) and t[1] > 0]
    pts.sort(key=lambda t: (order.get(t[0]["group"], len(GROUPS)), t[1], t[0]["method"]))
    return [(k + 1, r, x, kind) for k, (r, x, kind) in enumerate(pts)]


def _place_numbers(ax, pts, key):
    """Write each point's number beside it; a number that would sit on one already written moves
    round the point (right, left, above, below) until it is clear."""
    to_px = ax.transData.transform
    placed = []
    offsets = [(4, 2), (-11, 2), (-3, 6), (-3, -10), (6, -8), (-13, -8), (10, 6), (-17, 6)]
    for n, r, x, _ in sorted(pts, key=lambda t: (t[1][key], t[2])):
        px, py = to_px((x, r[key]))
        for dx, dy in offsets:
            if all(abs(px + dx - qx) > 10 or abs(py + dy - qy) > 8 for qx, qy in placed):
                break
        placed.append((px + dx, py + dy))
        ax.annotate(str(n), (x, r[key]), xytext=(dx, dy), textcoords="offset points", fontsize=7,
                    color="0.15")  # fmt: skip


#: the groups whose C-costed points the inset enlarges (they crowd one corner of the full view)
ZOOM_GROUPS = ("published", "refit", "refit, richer", "discovered", "fast")


def _draw(ax, sel, key, colors, front, size):
    """The points of ``sel`` (filled: C, hollow: Python, triangles: MC) and the staircase of ``front``."""
    for _number, r, x, kind in sel:
        col = colors.get(r["group"], "k")
        ax.scatter(
            [x],
            [r[key]],
            s=size,
            marker="^" if kind == "MC" else "o",
            facecolors="none" if kind == "python" else col,
            edgecolors=col,
            linewidths=1.3,
            zorder=3,
        )
    if front:
        fx = np.array([sel[i][2] for i in front])
        fy = np.array([sel[i][1][key] for i in front])
        ax.step(np.append(fx, fx[-1] * 4), np.append(fy, fy[-1]), where="post", color="0.35", lw=1.0, ls="--",
                zorder=2)  # fmt: skip
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.grid(True, which="major", alpha=0.3)


def plot_png(rows: list[dict], title: str) -> bytes:
    """The figure as PNG bytes (rows: BRDF-level rows with group, method, max_rel, rms_rel and costs).

    Points are numbered (the same number in both panels); the key on the right names them."""
    # a Figure of its own, not pyplot's: drawing leaves the caller's backend (a notebook's) alone
    from matplotlib import colormaps
    from matplotlib.figure import Figure

    colors = {g: colormaps["tab10"](k) for k, g in enumerate(GROUPS)}
    pts = _numbered(rows)
    fig = Figure(figsize=(15, 6.8))
    grid = fig.add_gridspec(1, 3, width_ratios=(1, 1, 0.62), wspace=0.22)
    axes = [fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[0, 1])]
    key_ax = fig.add_subplot(grid[0, 2])
    for ax, key, label in ((axes[0], "max_rel", "max relative error"), (axes[1], "rms_rel", "RMS relative error")):
        sel = [t for t in pts if math.isfinite(t[1][key]) and t[1][key] > 0]
        xs = [x for _, _, x, _ in sel]
        ys = [r[key] for _, r, _, _ in sel]
        _draw(ax, sel, key, colors, pareto_front(xs, ys), 38)
        ax.set_xlim(min(xs) / 3, max(xs) * 6)
        ax.set_ylim(min(ys) / 6, max(ys) * 6)
        ax.set_xlabel("cost: ns per evaluation")
        ax.set_ylabel(f"{label} vs the exact BRDF")
        zoom = [t for t in sel if t[1]["group"] in ZOOM_GROUPS and t[3] == "C"]
        if len(zoom) < 2:
            zoom = []
        _place_numbers(ax, [t for t in sel if t not in zoom], key)  # the zoomed ones are numbered in the inset
        if zoom:
            ins = ax.inset_axes([0.61, 0.13, 0.37, 0.36])
            _draw(ins, sel, key, colors, pareto_front(xs, ys), 30)
            zx, zy = [t[2] for t in zoom], [t[1][key] for t in zoom]
            ins.set_xlim(min(zx) / 1.4, max(zx) * 1.4)
            ins.set_ylim(min(zy) / 2.5, max(zy) * 2.5)
            ins.tick_params(labelsize=6, which="both")
            ins.set_title("zoom: the analytic models in C", fontsize=7)
            _place_numbers(ins, zoom, key)
            ax.indicate_inset_zoom(ins, edgecolor="0.5")
    key_ax.axis("off")
    lines = [(f"{n:>2}  {r['method']}", colors.get(r["group"], "k")) for n, r, _, _ in pts]
    step = min(0.045, 0.80 / max(len(lines), 1))
    for k, (text, col) in enumerate(lines):
        key_ax.text(0.0, 1.0 - k * step, text, color=col, fontsize=7.5, family="monospace", va="top",
                    transform=key_ax.transAxes)  # fmt: skip
    y = 1.0 - len(lines) * step - 0.02
    notes = [
        "filled: generated C (double)",
        "hollow: numpy / exact engine (Python)",
        "triangles: Monte Carlo, per BRDF value,",
        "  error vs exact bin averages",
        "dashed: Pareto front",
        "colour: the group of docs/report.md",
    ]
    for k, text in enumerate(notes):
        key_ax.text(0.0, y - k * 0.035, text, fontsize=7, color="0.3", va="top", transform=key_ax.transAxes,
                    wrap=True)  # fmt: skip
    fig.suptitle(title, fontsize=10)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=130, metadata={"Software": None}, bbox_inches="tight")
    return buf.getvalue()
