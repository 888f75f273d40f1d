r"""The validation study of the microsurface walk at large budgets: order 1 of every kind of facet against
its deterministic reference (:mod:`fitlab.families.microfacet_energy.mc.reference`), bin by bin and in total, over
grazing to normal incidence, smooth to rough, isotropic and anisotropic, GGX and Beckmann; and energy, path by path.

``python -m studies.microfacet_energy.microsurface_validation [--paths N] [--quiet]`` prints one
line per material, over its order-1 lobe bins, reflected and transmitted, that the reference or a path
reaches: the smallest two-sided p-value of a bin's count under its reference (``simulate.count_p_value``,
binomial, calibrated where few paths land) and the number of bins below 6.3e-5 (a 4-sigma deviation; with
some 2200 bins in the study, 0.14 expected by chance); the z-scores (estimate - reference) / se of the
bins expected to hold 25 paths or more, where z is normal (max |z| and RMS z: RMS near 1, max |z| near 3.5
over a few hundred bins for unbiased estimates); the largest |z| of the order-1 totals (and of the
multiple-scattering albedo against 1 - A_1 where the facets lose nothing); the energy defect |sum of
every tally - N| (exactly 0 where every weight is 1); and the paths the walk ended as failed (a non-finite
state: 0 expected).  The smoothest cases (alpha = 1e-3) are dielectrics:
reflect-or-refract gives every bin a binomial spread, where a conductor with F = 1 sends every path into
the mirror bin with no spread to compare a reference with (its bins are checked against the integrals over
the normals instead, tests/test_microsurface_dielectric.py).
"""

from __future__ import annotations

import argparse
import contextlib
import math
import sys

import numpy as np

from fitlab.families.microfacet_energy.mc.scene import parse_scene
from fitlab.families.microfacet_energy.mc.simulate import count_p_value, simulate

__all__ = ["CASES", "MU_I", "run_validation", "format_table"]

#: (label, TOML lines of the material) of every case of the study
CASES = (
    ("white_ggx", 'kind = "conductor"\ndistribution = "ggx"\nalpha = 0.6'),
    (
        "gold_aniso_ggx",
        'kind = "conductor"\ndistribution = "ggx"\nalpha_x = 0.3\nalpha_y = 0.8\n'
        'fresnel = "conductor"\neta = 0.2\nk = 3.0',
    ),
    ("schlick_beckmann", 'kind = "conductor"\ndistribution = "beckmann"\nalpha = 0.4\nfresnel = "schlick"\nf0 = 0.3'),
    ("glass_ggx", 'kind = "dielectric"\ndistribution = "ggx"\nalpha = 0.6\neta = 1.5'),
    ("glass_mirror_beckmann", 'kind = "dielectric"\ndistribution = "beckmann"\nalpha = 0.001\neta = 1.5'),
    ("glass_smooth_ggx", 'kind = "dielectric"\ndistribution = "ggx"\nalpha = 0.1\neta = 1.5'),
    ("glass_mirror_ggx", 'kind = "dielectric"\ndistribution = "ggx"\nalpha = 0.001\neta = 1.5'),
    ("glass_rough_ggx", 'kind = "dielectric"\ndistribution = "ggx"\nalpha = 1.5\neta = 1.5'),
    ("glass_aniso_ggx", 'kind = "dielectric"\ndistribution = "ggx"\nalpha_x = 0.3\nalpha_y = 0.8\neta = 1.5'),
    ("glass_beckmann", 'kind = "dielectric"\ndistribution = "beckmann"\nalpha = 0.6\neta = 1.5'),
    ("inside_ggx", 'kind = "dielectric"\ndistribution = "ggx"\nalpha = 0.6\neta = 0.6666666666666666'),
    (
        "inside_aniso_beckmann",
        'kind = "dielectric"\ndistribution = "beckmann"\nalpha_x = 0.2\nalpha_y = 0.5\neta = 0.6666666666666666',
    ),
    ("diffuse_white_ggx", 'kind = "diffuse"\ndistribution = "ggx"\nalpha = 0.6'),
    (
        "diffuse_grey_aniso_beckmann",
        'kind = "diffuse"\ndistribution = "beckmann"\nalpha_x = 0.3\nalpha_y = 0.8\nalbedo = 0.8',
    ),
)
#: two-sided p-value of a 4-sigma normal deviation: the bins below it are counted
P_MIN = 6.3e-5
#: incident cosines: grazing, oblique, near normal
MU_I = (0.05, 0.5, 0.95)


def _scene_text(paths: int) -> str:
    materials = "\n".join(f'[[material]]\nlabel = "{label}"\n{body}\n' for label, body in CASES)
    return f"""
[scene]
name = "validation"
seed = 2016
{materials}
[incident]
mu_i = [{", ".join(str(m) for m in MU_I)}]
[outgoing]
mu_o = 8
phi = 6
orders = 4
[precision]
target_se = 1e-9
max_paths = {paths}
batch = {min(paths, 1_000_000)}
"""


def run_validation(paths: int = 2_000_000, progress: bool = False) -> list:
    """Simulate every case of :data:`CASES` at every :data:`MU_I` with ``paths`` paths per job; one dict per
    case (keys: case, kind, jobs, bins, min_p, bins_below_p, z_bins, max_abs_z, rms_z, max_abs_z_totals,
    energy_defect, failed, seconds)."""
    with contextlib.redirect_stdout(sys.stderr):  # simulate's progress lines go to stderr, results to stdout
        result = simulate(parse_scene(_scene_text(paths), "<validation>"), progress=progress)
    out = []
    for mi, mat in enumerate(result.scene.materials):
        rows = [r for r in result.rows if r["material"] == mat.label]
        lobe = [
            r
            for r in rows
            if r["quantity"] in ("lobe", "lobe_transmission")
            and r["order"] == "1"
            and (r["reference"] > 0.0 or r["_s1"] > 0.0)
        ]
        ps = np.array([count_p_value(r) for r in lobe])
        # z is normal where the bin holds many paths: those expected to hold 25 or more
        zs = np.array([r["z_ref"] for r in lobe if r["se"] > 0.0 and r["reference"] * r["_n"] * r["_norm"] >= 25.0])
        totals = [
            abs(r["z_ref"])
            for r in rows
            if r["quantity"] in ("albedo", "transmission", "albedo_multiple") and math.isfinite(r["z_ref"])
        ]
        defect = math.nan
        if mat.conserves_energy:
            defect = max(
                abs(float(np.sum(t["albedo"]) + np.sum(t["transmission"]) + t["capped"] - t["paths"]))
                for (m, _), t in result.tallies.items()
                if m == mi
            )
        jobs = [st for (m, _), st in result.jobs.items() if m == mi]
        out.append(
            dict(
                case=mat.label,
                kind=mat.kind,
                jobs=len(jobs),
                bins=len(lobe),
                min_p=float(np.min(ps)),
                bins_below_p=int(np.sum(ps < P_MIN)),
                z_bins=int(zs.size),
                max_abs_z=float(np.max(np.abs(zs), initial=math.nan if zs.size == 0 else 0.0)),
                rms_z=float(np.sqrt(np.mean(zs * zs))) if zs.size else math.nan,
                max_abs_z_totals=max(totals, default=math.nan),
                energy_defect=defect,
                failed=sum(int(t["failed"]) for (m, _), t in result.tallies.items() if m == mi),
                seconds=sum(st.seconds for st in jobs),
            )
        )
    return out


def format_table(rows: list) -> str:
    """A markdown table of :func:`run_validation`'s rows."""
    lines = [
        "| case | kind | bins | smallest p | bins with p < 6.3e-5 | bins >= 25 paths | max abs z | RMS z | "
        "max abs z of totals | energy defect | failed | seconds |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        defect = "n/a (absorbs)" if math.isnan(r["energy_defect"]) else f"{r['energy_defect']:g}"
        lines.append(
            f"| {r['case']} | {r['kind']} | {r['bins']} | {r['min_p']:.2g} | {r['bins_below_p']} | "
            f"{r['z_bins']} | {r['max_abs_z']:.2f} | {r['rms_z']:.2f} | {r['max_abs_z_totals']:.2f} | "
            f"{defect} | {r['failed']} | {r['seconds']:.1f} |"
        )
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m studies.microfacet_energy.microsurface_validation",
        description="Order 1 of the microsurface walk against its references at a large "
        "budget (prints a markdown table).",
    )
    p.add_argument("--paths", type=int, default=2_000_000, help="paths per job (material x mu_i), >= 10000")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    args = p.parse_args(argv)
    if not 10_000 <= args.paths <= 2**32:
        p.error(f"--paths must lie in [10000, 2^32], got {args.paths}")
    print(format_table(run_validation(args.paths, progress=not args.quiet)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
