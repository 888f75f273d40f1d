"""Write fitlab/data/examples/renderer_E.csv: the example table of docs/your_own_data.md.

A renderer's table of the directional albedo E(mu, alpha) of the GGX microfacet BRDF with height-correlated
Smith masking-shadowing and F = 1 (the white furnace), on the texel centres of a 32 x 32 texture:
mu = (j + 1/2)/32, alpha = (k + 1/2)/32, j, k = 0..31.  E is fitlab's own exact value
(fitlab.families.microfacet_energy.exact.directional_albedo, model ggx_correlated, exact to 1e-9), plus
the noise of a Monte Carlo estimate a renderer would bake: a Gaussian of standard deviation
sqrt(E (1 - E) / 65536), the bound on the standard error of the mean of 65536 samples that lie in [0, 1],
drawn by numpy.random.default_rng(2024).  Values are written with 6 decimals.

    python tools/example_table.py            # writes the file
    python tools/example_table.py --check    # recomputes it and compares, byte for byte
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parents[1] / "fitlab" / "data" / "examples" / "renderer_E.csv"
NODES, SAMPLES, SEED = 32, 65536, 2024


def table_text() -> str:
    from fitlab.families.microfacet_energy.exact import directional_albedo

    centres = (np.arange(NODES) + 0.5) / NODES
    mu, alpha = (g.ravel() for g in np.meshgrid(centres, centres, indexing="ij"))
    exact = directional_albedo(mu, alpha, "ggx_correlated")
    sigma = np.sqrt(exact * (1.0 - exact) / SAMPLES)
    noisy = exact + np.random.default_rng(SEED).normal(size=exact.shape) * sigma
    lines = [
        "# E(mu, alpha) as a renderer tabulates it: the directional albedo of GGX with height-correlated Smith",
        "# masking-shadowing and F = 1, on the texel centres of a 32 x 32 texture, "
        "mu = (j + 1/2)/32, alpha = (k + 1/2)/32.",
        "# Made by tools/example_table.py: fitlab's exact E (microfacet_energy, ggx_correlated, to 1e-9) plus Gaussian",
        f"# noise of standard deviation sqrt(E (1 - E) / {SAMPLES}) (a {SAMPLES}-sample Monte Carlo estimate), "
        f"numpy.random.default_rng({SEED}).",
        "mu,alpha,E",
    ]
    lines += [f"{float(m)!r},{float(a)!r},{e:.6f}" for m, a, e in zip(mu, alpha, noisy)]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=(__doc__ or "").partition("\n")[0])
    p.add_argument("--check", action="store_true", help="recompute and compare with the file")
    args = p.parse_args(argv)
    text = table_text()
    if args.check:
        same = OUT.read_text() == text
        print(f"{OUT}: {'as recomputed' if same else 'differs from the recomputation'}")
        return 0 if same else 1
    from fitlab._io import atomic_write_text

    atomic_write_text(OUT, text)
    print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
