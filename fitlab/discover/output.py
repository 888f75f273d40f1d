r"""What ``fitlab discover`` writes: the front's table (Markdown and JSON), its plot, and
front members saved as fits/ JSON forms.

The Markdown table and JSON hold no timings, so they are reproducible: rerunning
the same search gives the same files.
"""

from __future__ import annotations

import io
import json
import math
from pathlib import Path

from fitlab._io import atomic_write_many
from fitlab.discover.search import Discovery, library_tag, pareto_front
from fitlab.store import decode_nonfinite, fit_path, strict_json, write_fit, write_fits

__all__ = ["front_table", "front_json", "plot_front", "save", "save_from_front", "write_outputs"]


def _e(x: float) -> str:
    return "inf" if not math.isfinite(x) else f"{x:.2e}"


def _tag(disc: Discovery, d) -> str:
    """The library of a form from a target's secondary library, in parentheses; empty for the primary."""
    tag = library_tag(disc.libraries, d.candidate)
    return f" (library {tag})" if tag else ""


def front_table(disc: Discovery) -> str:
    """Markdown: the published presets and saved refits, then every refitted candidate (front marked)."""
    m = disc.metric
    lines = [
        f"# fitlab discover --target {disc.target}",
        "",
        *(f"Library `{lib.name}`: {lib.description}.\n" for lib in disc.libraries),
        f"{len(disc.candidates)} sparse supports from the regression; {len(disc.refined)} refitted (optimistix LM, "
        f"then minimax where the target asks) and validated on the target's validation set"
        f"{f' (the other {len(disc.dropped)}, and why: below)' if disc.dropped else ''}. Front: lowest "
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
                     f"{_e(v['rms_rel'])} | {d.candidate.found_by}{_tag(disc, d)} |")  # fmt: skip
    lines += [
        "",
        "terms: free parameters (for discovered forms: library terms kept); ops: operations after "
        "common-subexpression elimination (sympy count_ops), parameters as numbers.",
        "",
    ]
    lines.append("## The front's forms")
    lines.append("")
    for d in disc.refined:
        if d.name in disc.front:
            lines.append(f"- **{d.name}**{_tag(disc, d)}: numerator {', '.join(d.candidate.num) or '-'}; "
                         f"denominator {', '.join(d.candidate.den) or '-'}")  # fmt: skip
    if disc.dropped:
        lines += ["", "## The supports not refitted or not kept, and why", "",
                  "| numerator | denominator | terms | found by | linearised error | why |",
                  "|---|---|---:|---|---:|---|"]  # fmt: skip
        for g in disc.dropped:
            tag = f" (library {g['library']})" if g["library"] != disc.libraries[0].name else ""
            lines.append(f"| {', '.join(g['numerator']) or '-'} | {', '.join(g['denominator']) or '-'} | "
                         f"{g['terms']} | {g['found_by']}{tag} | {_e(g['linear_error'])} | {g['reason']} |")  # fmt: skip
    return "\n".join(lines) + "\n"


def front_json(disc: Discovery) -> str:
    return strict_json({
        "target": disc.target,
        "libraries": [lib.name for lib in disc.libraries],
        "metric": disc.metric,
        "reference": disc.reference,
        "front": disc.front,
        "refined": [{"name": d.name, "terms": d.terms, "operations": d.operations, "front": d.name in disc.front,
                     "record": d.record} for d in disc.refined],
        "dropped": disc.dropped,
    })  # fmt: skip


def plot_front(disc: Discovery) -> bytes:
    """PNG: validation error against term count (left) and operation count (right), log error axis."""
    # a Figure of its own, not pyplot's: drawing leaves the caller's backend (a notebook's) alone
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    m = disc.metric
    ylabel = f"validation {'max' if m == 'max_rel' else 'RMS'} relative error"
    fig = Figure(figsize=(11, 4.2))
    axes = fig.subplots(1, 2, sharey=True)
    for ax, key, xlabel in ((axes[0], "terms", "terms (free parameters)"), (axes[1], "operations", "operations")):
        xs = [getattr(d, key) for d in disc.refined]
        ys = [d.validation[m] for d in disc.refined]
        ax.scatter(xs, ys, s=18, color="0.6", label="discovered (refitted)", zorder=2)
        front = sorted((getattr(d, key), d.validation[m]) for d in disc.refined if d.name in disc.front)

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
        Line2D([], [], marker="o", ls="", color="0.6", label="discovered"),
        Line2D([], [], marker="o", color="C0", label="Pareto front"),
        Line2D([], [], marker="*", ls="", color="C3", markersize=11, label="published preset"),
        Line2D([], [], marker="s", ls="", color="C2", label="refit of a fitlab form"),
    ]
    axes[1].legend(handles=handles, fontsize=8, loc="upper right")
    names = ", ".join(lib.name for lib in disc.libraries)
    fig.suptitle(f"fitlab discover --target {disc.target} (librar{'ies' if len(disc.libraries) > 1 else 'y'} {names})")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, metadata={"Software": None})
    return buf.getvalue()


def save(disc: Discovery, name: str, fits_dir: Path = Path("fits")) -> Path:
    """Write the discovered form ``name`` as fits/TARGET.NAME.json, a form ``fitlab refit --form``,
    ``fitlab codegen --form`` and :func:`fitlab.store.load` take like any other."""
    d = disc.get(name)
    path = fit_path(Path(fits_dir), disc.target, name)
    write_fit(path, d.record)
    return path


#: the largest front file read (a front holds its refitted records, each at most a fit file's size)
MAX_FRONT_BYTES = 100_000_000


def save_from_front(front_file: Path, names, fits_dir: Path = Path("fits"), table=None) -> list[Path]:
    """:func:`save` from a front written earlier (docs/discover/TARGET.json), without searching again.

    ``names``: front members (one name or several).  A front of a table of one's own (its records hold
    ``user_data``) needs ``table`` (:class:`fitlab.fit.user.UserTable`), the table searched (its sha256 is
    checked): each fit is written as FITS/COLUMN.NAME.json with the table beside it, as ``fitlab fit``
    writes one.  Every name is checked before anything is written, and the files are written as one unit.
    """
    from fitlab._io import InputFileError, read_regular_file

    names = [names] if isinstance(names, str) else list(names)
    front_file = Path(front_file)
    try:
        data = json.loads(read_regular_file(front_file, MAX_FRONT_BYTES).decode("utf-8"))
    except InputFileError as exc:
        if exc.kind == "missing":
            raise ValueError(f"{front_file}: no such front; run `fitlab discover` without --from-front first") from None
        raise ValueError(f"{front_file}: {exc.refusal('front')}") from None
    except json.JSONDecodeError as exc:
        raise ValueError(f"{front_file}: corrupt JSON ({exc.msg}, line {exc.lineno})") from None
    except (UnicodeDecodeError, RecursionError) as exc:
        raise ValueError(f"{front_file}: not a front ({type(exc).__name__})") from None
    if not isinstance(data, dict) or not isinstance(data.get("refined"), list):
        raise ValueError(f"{front_file}: not a front written by fitlab discover")
    front = [n for n in data.get("front", []) if isinstance(n, str)]
    records = {
        item["name"]: item["record"]
        for item in data["refined"]
        if isinstance(item, dict) and item.get("name") in front and isinstance(item.get("record"), dict)
    }
    for name in names:
        if name not in records:
            raise KeyError(f"{front_file}: {name!r} is not on the front; the front is {', '.join(front)}")
        if records[name].get("form") != name:
            raise ValueError(f"{front_file}: the front's {name!r} holds a fit of the form "
                             f"{str(records[name].get('form'))[:70]!r}; the front is damaged")  # fmt: skip
    own = [n for n in names if "user_data" in records[n]]
    if not own:
        if table is not None:
            raise ValueError(f"{front_file}: a front of fitlab's target {data.get('target')}, not of a table")
        return write_fits({fit_path(Path(fits_dir), data["target"], n): decode_nonfinite(records[n]) for n in names})
    from fitlab.fit.user import table_beside
    from fitlab.store import check_fit

    if table is None or len(own) != len(names):
        raise ValueError(f"{front_file}: a front of a table of your own; give that table")
    files = {}
    for name in names:
        record = decode_nonfinite(records[name])
        if record["user_data"].get("sha256") != table.sha256:
            raise ValueError(f"{front_file}: {name} was fitted to a table with sha256 "
                             f"{str(record['user_data'].get('sha256'))[:16]}..., not {table.name} "
                             f"({table.sha256[:16]}...); the table changed since the search")  # fmt: skip
        path = Path(fits_dir) / f"{record['target']}.{name}.json"
        beside = table_beside(path)
        record["user_data"] = {**record["user_data"], "file": beside.name}
        files[beside] = table.data
        files[path] = strict_json(check_fit(record, f"{front_file} ({name})")).encode()
    atomic_write_many(files)
    return list(files)


def write_outputs(disc: Discovery, out_dir: Path) -> list[Path]:
    """out_dir/TARGET.md, TARGET.json and TARGET.png, rendered first and then written as one unit."""
    out_dir = Path(out_dir)
    files = {out_dir / f"{disc.target}.md": front_table(disc).encode(),
             out_dir / f"{disc.target}.json": front_json(disc).encode(),
             out_dir / f"{disc.target}.png": plot_front(disc)}  # fmt: skip
    atomic_write_many(files)
    return list(files)
