"""One PNG per effect: the MC estimates with error bars (2 standard errors)
beside their reference values.  Matplotlib's Agg canvas; the PNG is returned as bytes (the shared
runner, :func:`fitlab.scenes.write_outputs`, writes every output as one unit)."""

from __future__ import annotations

import io
import math

from matplotlib.figure import Figure  # not pyplot: plotting leaves the caller's backend alone

__all__ = ["effect_png"]


def _finite(x):
    return isinstance(x, float) and math.isfinite(x)


def _groups(rows, keys):
    out = {}
    for r in rows:
        out.setdefault(tuple(r[k] for k in keys), []).append(r)
    return out


def _directional(ax, rows, title):
    """Estimate vs mu_o bin centre, one series per Fourier order (or phi bin)."""
    series = _groups(rows, ("m", "phi_lo"))
    for (m, phi_lo), rs in sorted(series.items(), key=lambda kv: str(kv[0])):
        x = [(r["mu_lo"] + r["mu_hi"]) / 2 for r in rs]
        y = [r["estimate"] for r in rs]
        e = [2 * r["se"] for r in rs]
        label = f"m={m}" if m != "" else f"|phi| from {phi_lo:.2f}"
        line = ax.errorbar(x, y, yerr=e, fmt="o", ms=3, capsize=2, label=label)
        ref = [r["ref"] for r in rs]
        if all(_finite(v) for v in ref):
            ax.plot(x, ref, "-", color=line[0].get_color(), lw=1)
        alt = [r["alt"] for r in rs]
        if all(_finite(v) for v in alt):
            ax.plot(x, alt, ":", color=line[0].get_color(), lw=1)
    ax.axhline(0.0, color="0.7", lw=0.5)
    ax.set_xlabel("mu_o (bin centre)")
    ax.set_title(title, fontsize=8)
    ax.legend(fontsize=6)


def effect_png(effect: str, rows: list, scene_name: str) -> bytes:
    """The PNG of one effect."""
    rows = [r for r in rows if r["quantity"] != "capped"]
    if effect in ("single", "multiple", "phase_difference"):
        q = {"single": "f_ss", "multiple": "f_ms", "phase_difference": "d_f_ms"}[effect]
        rows = [r for r in rows if r["quantity"] == q]
        panels = _groups(rows, ("material", "mu_i"))
        n = max(len(panels), 1)
        cols = min(n, 3)
        rows_n = (n + cols - 1) // cols
        fig = Figure(figsize=(max(4.0 * cols, 5.5), 3.2 * rows_n + 0.6))
        axes = fig.subplots(rows_n, cols, squeeze=False)
        for ax, ((mat, mu_i), rs) in zip(axes.ravel(), sorted(panels.items(), key=lambda kv: str(kv[0]))):
            _directional(ax, rs, f"{mat}, mu_i={mu_i:g}: {q} (1/sr)")
        for ax in axes.ravel()[len(panels) :]:
            ax.axis("off")
        fig.suptitle(f"{scene_name}: {effect}\npoints: MC +- 2 se; lines: reference; dotted: printed", fontsize=9)
    elif effect == "collisions":
        rows = [r for r in rows if r["quantity"] == "a_ms_n"]
        fig = Figure(figsize=(6, 4))
        ax = fig.subplots()
        for (mat, mu_i), rs in sorted(_groups(rows, ("material", "mu_i")).items(), key=lambda kv: str(kv[0])):
            x = list(range(len(rs)))
            ax.errorbar(
                x,
                [r["estimate"] for r in rs],
                yerr=[2 * r["se"] for r in rs],
                fmt="o-",
                ms=3,
                capsize=2,
                label=f"{mat}, mu_i={mu_i:g}",
            )
            ax.set_xticks(x, [r["n"] for r in rs])
        ax.set_yscale("log")
        ax.set_xlabel("collisions before escape")
        ax.set_ylabel("escaping fraction (albedo by order)")
        ax.legend(fontsize=6)
        ax.set_title(f"{scene_name}: multiple scattering by number of collisions", fontsize=9)
    else:
        q = "a" if effect == "albedo" else "kd"
        rows = [r for r in rows if r["quantity"] == q]
        xkey = "mu_i" if effect == "albedo" else "c"
        fig = Figure(figsize=(9, 3.6))
        (ax, az) = fig.subplots(1, 2)
        for mat, rs in sorted(
            _groups(rows, ("material",) if effect == "albedo" else ()).items(), key=lambda kv: str(kv[0])
        ):
            rs = sorted(rs, key=lambda r: r[xkey])
            x = [r[xkey] for r in rs]
            line = ax.errorbar(
                x,
                [r["estimate"] for r in rs],
                yerr=[2 * r["se"] for r in rs],
                fmt="o",
                ms=3,
                capsize=2,
                label=f"MC {mat[0] if mat else ''}",
            )
            ref = [r["ref"] for r in rs]
            if all(_finite(v) for v in ref):
                ax.plot(x, ref, "-", color=line[0].get_color(), lw=1)
            alt = [r["alt"] for r in rs]
            if all(_finite(v) for v in alt):
                ax.plot(x, alt, ":", color=line[0].get_color(), lw=1, label=rs[0]["alt_name"])
            z = [r["z_ref"] for r in rs]
            az.plot(x, z, "o", ms=3, label="vs reference")
            za = [r["z_alt"] for r in rs]
            if any(_finite(v) for v in za):
                az.plot(x, za, "x", ms=4, label=f"vs {rs[0]['alt_name']}")
                az.legend(fontsize=6)
        az.axhline(0, color="0.6", lw=0.5)
        for s in (-4, 4):
            az.axhline(s, color="r", lw=0.5, ls="--")
        az.set_xlabel(xkey)
        az.set_ylabel("(MC - reference) / se")
        ax.set_xlabel(xkey)
        ax.set_ylabel(q)
        ax.legend(fontsize=6)
        fig.suptitle(f"{scene_name}: {effect} (MC +- 2 se; line: reference; dotted: published)", fontsize=9)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    return buf.getvalue()
