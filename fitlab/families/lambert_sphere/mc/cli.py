"""``fitlab simulate``: the command-line face of :mod:`fitlab.families.lambert_sphere.mc.simulate`."""

from __future__ import annotations

import sys

from fitlab.families.lambert_sphere.mc.scene import SceneError

__all__ = ["run_simulate"]


def run_simulate(args) -> int:
    """Validate the scene (every error before any work), simulate, write; 2 on a bad scene."""
    from fitlab.families.lambert_sphere.mc.simulate import simulate_file, summary_table

    try:
        result, paths = simulate_file(
            args.scene, out_dir=args.out, progress=not args.quiet, plots=not args.no_plots,
            target_se=args.target_se, max_paths=args.max_paths, seed=args.seed,
        )
    except SceneError as exc:
        print(f"fitlab simulate: error in the scene:\n{exc}", file=sys.stderr)
        return 2
    except ValueError as exc:
        print(f"fitlab simulate: error: {exc}", file=sys.stderr)
        return 2
    print(summary_table(result))
    for p in paths:
        print(f"wrote {p}")
    return 0
