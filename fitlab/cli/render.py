"""``fitlab render``: spheres rendered in Mitsuba 3 with the generated BRDF, beside Lambert, Oren-Nayar and
Chandrasekhar (Mitsuba is imported by the renderer, when :func:`run` renders)."""

from __future__ import annotations

import sys
from pathlib import Path

from fitlab.families.lambert_sphere.render import RenderError, render_comparison

__all__ = ["HELP", "add_arguments", "run"]

HELP = "render spheres with the generated BRDF in Mitsuba 3 beside Lambert, Oren-Nayar, Chandrasekhar"


def add_arguments(p) -> None:
    p.add_argument("--out", default="docs/render.png", help="PNG to write (default: docs/render.png)")
    p.add_argument("--generated", default="fits/generated/lambert_sphere.py", help="the generated Python BRDF module")
    p.add_argument("--kd", type=float, default=0.8, help="spherical albedo of every material (default 0.8)")
    p.add_argument("--size", type=int, default=64, help="image size per sphere in pixels (default 64)")
    p.add_argument("--spp", type=int, default=4, help="samples per pixel (default 4)")
    p.add_argument("--lights", type=int, default=3, help="number of light directions, 1-5 (default 3)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args) -> int:
    try:
        path = render_comparison(
            Path(args.out), generated=Path(args.generated), kd=args.kd, size=args.size, spp=args.spp,
            lights=args.lights, show_progress=not args.quiet,
        )
    except (RenderError, ValueError) as exc:
        print(f"fitlab render: error: {exc}", file=sys.stderr)
        return 2
    print(f"wrote {path}")
    return 0
