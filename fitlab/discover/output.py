r"""What ``fitlab discover`` writes: the front's table (Markdown and JSON), its plot, and
front members saved as fits/ JSON forms.

The Markdown table and JSON hold no timings, so they are reproducible: rerunning
the same search gives the same files.
"""

from __future__ import annotations

import io
import math
from pathlib import Path

from .._io import atomic_write_bytes, atomic_write_text
from ..fit.refit import fit_path
from ..fits import strict_json, write_fit
from .search import Discovery

__all__ = ["front_table", "front_json", "plot_front", "save", "save_from_front", "write_outputs"]


def _e(x: float) -> str:
    return "inf" if not math.isfinite(x) else f"{x:.2e}"


def front_table(disc: Discovery) -> str:
    """Markdown: the published presets and saved refits, then every refitted candidate (front marked)."""
    m = disc.metric
    lines = [
        f"# fitlab discover --target {disc.target}",
        "",
        f"Library `{disc.library.name}`: {disc.library.description}.",
        "",
        f"{len(disc.candidates)} sparse supports from the regression; {len(disc.refined)} refitted (optimistix LM, "
        f"then minimax where the target asks) and validated on the target's validation set. Front: lowest "
        f"validation {'max' if m == 'max_rel' else 'RMS'} relative error for its term count or operation count.",
        "",
        "| form | kind | terms | ops | max rel | RMS rel | found by |",
        "|---|---|---:|---:|---:|---:|---|",
    ]
    for r in disc.reference:
        # a published form that misses an exact zero of the target has an infinite relative error there
        mx = _e(r["max_rel"]) if math.isfinite(r["max_rel"]) else f"inf ({_e(r['max_rel_nonzero'])} without the zeros)"
        lines.append(f"| {r['label']} | {r['kind']} | {r['terms']} | {r['operations']} | {mx} | "
                     f"{_e(r['rms_rel'])} | |")  # fmt: skip
    for d in disc.refined:
        star = " (front)" if d.name in disc.front else ""
        v = d.validation
        lines.append(f"| {d.name}{star} | discovered | {d.terms} | {d.operations} | {_e(v['max_rel'])} | "
                     f"{_e(v['rms_rel'])} | {d.candidate.found_by} |")  # fmt: skip
    lines += ["", "terms: free parameters (for discovered forms: library terms kept); ops: operations after "
              "common-subexpression elimination (sympy count_ops), parameters as numbers.", ""]
    lines.append("## The front's forms")
    lines.append("")
    for d in disc.refined:
        if d.name in disc.front:
            lines.append(f"- **{d.name}**: numerator {', '.join(d.candidate.num) or '-'}; denominator "
                         f"{', '.join(d.candidate.den) or '-'}")  # fmt: skip
    return "\n".join(lines) + "\n"


def front_json(disc: Discovery) -> str:
    return strict_json({
        "target": disc.target,
        "library": disc.library.name,
        "metric": disc.metric,
        "reference": disc.reference,
        "front": disc.front,
        "refined": [{"name": d.name, "terms": d.terms, "operations": d.operations, "front": d.name in disc.front,
                     "record": d.record} for d in disc.refined],
    })  # fmt: skip


def plot_front(disc: Discovery) -> bytes:
    """PNG: validation error against term count (left) and operation count (right), log error axis."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    m = disc.metric
    ylabel = f"validation {'max' if m == 'max_rel' else 'RMS'} relative error"
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    for ax, key, xlabel in ((axes[0], "terms", "terms (free parameters)"), (axes[1], "operations", "operations")):
        xs = [getattr(d, key) for d in disc.refined]
        ys = [d.validation[m] for d in disc.refined]
        ax.scatter(xs, ys, s=18, color="0.6", label="discovered (refitted)", zorder=2)
        front = sorted((getattr(d, key), d.validation[m]) for d in disc.refined if d.name in disc.front)
        from .search import pareto_front

        idx = pareto_front(front)
        fx, fy = zip(*sorted(front[i] for i in idx))
        ax.step(fx, fy, where="post", color="C0", lw=1.5, label=f"front ({key})", zorder=3)
        ax.scatter(fx, fy, s=28, color="C0", zorder=4)
        for r in disc.reference:
            y = r[m] if math.isfinite(r[m]) else r.get("max_rel_nonzero", r[m])
            marker, color = ("*", "C3") if r["kind"] == "published" else ("s", "C2")
            ax.scatter([r[key]], [y], marker=marker, s=110 if marker == "*" else 50, color=color, zorder=5,
                       edgecolor="k", linewidth=0.5)  # fmt: skip
            ax.annotate(r["label"], (r[key], y), textcoords="offset points", xytext=(5, 4), fontsize=7)
        ax.set_yscale("log")
        ax.set_xlabel(xlabel)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel(ylabel)
    handles = [
        plt.Line2D([], [], marker="o", ls="", color="0.6", label="discovered"),
        plt.Line2D([], [], marker="o", color="C0", label="Pareto front"),
        plt.Line2D([], [], marker="*", ls="", color="C3", markersize=11, label="published preset"),
        plt.Line2D([], [], marker="s", ls="", color="C2", label="refit of a fitlab form"),
    ]
    axes[1].legend(handles=handles, fontsize=8, loc="upper right")
    fig.suptitle(f"fitlab discover --target {disc.target} (library {disc.library.name})")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, metadata={"Software": None})
    plt.close(fig)
    return buf.getvalue()


def save(disc: Discovery, name: str, fits_dir: Path = Path("fits")) -> Path:
    """Write the discovered form ``name`` as fits/TARGET.NAME.json, a form ``fitlab refit --form``,
    ``fitlab codegen --form`` and :func:`fitlab.fits.load` take like any other."""
    d = disc.get(name)
    path = fit_path(Path(fits_dir), disc.target, name)
    write_fit(path, d.record)
    return path


def save_from_front(front_file: Path, name: str, fits_dir: Path = Path("fits")) -> Path:
    """:func:`save` from a front written earlier (docs/discover/TARGET.json), without searching again."""
    import json

    front_file = Path(front_file)
    try:
        data = json.loads(front_file.read_text())
    except FileNotFoundError:
        raise ValueError(f"{front_file}: no such front; run `fitlab discover --target TARGET` first") from None
    except json.JSONDecodeError as exc:
        raise ValueError(f"{front_file}: corrupt JSON ({exc.msg}, line {exc.lineno})") from None
    from ..fits import _decode

    for item in data.get("refined", []):
        if item["name"] == name:
            path = fit_path(Path(fits_dir), data["target"], name)
            write_fit(path, _decode(item["record"]))
            return path
    raise KeyError(f"{front_file}: no discovered form {name!r}; front: {', '.join(data.get('front', []))}")


def write_outputs(disc: Discovery, out_dir: Path) -> list[Path]:
    """out_dir/TARGET.md, TARGET.json and TARGET.png; everything is rendered before anything is written."""
    out_dir = Path(out_dir)
    files = {f"{disc.target}.md": front_table(disc).encode(), f"{disc.target}.json": front_json(disc).encode(),
             f"{disc.target}.png": plot_front(disc)}  # fmt: skip
    paths = []
    for fname, data in files.items():
        path = out_dir / fname
        if fname.endswith(".png"):
            atomic_write_bytes(path, data)
        else:
            atomic_write_text(path, data.decode())
        paths.append(path)
    return paths
