"""``fitlab simulate``: the command-line face of :mod:`fitlab.families.lambert_sphere.mc.simulate`.

The Monte Carlo (JAX) is imported inside :func:`run` only."""

from __future__ import annotations

import sys

__all__ = ["HELP", "add_arguments", "run"]

HELP = "Monte Carlo: simulate only the effects a scene asks for (data/scenes/)"


def add_arguments(p) -> None:
    p.add_argument("scene", help="scene file (.toml or .json), e.g. data/scenes/order1_normalisation.toml")
    p.add_argument("--out", help="output folder (default: mc_out/<scene name>)")
    p.add_argument("--target-se", type=float, help="override every effect's standard-error target")
    p.add_argument("--max-paths", type=int, help="override the path budget per job")
    p.add_argument("--seed", type=int, help="override the scene's seed")
    p.add_argument("--no-plots", action="store_true", help="CSV only")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args) -> int:
    """Validate the scene (every error before any work), simulate, write; 2 on a bad scene."""
    from fitlab.families.lambert_sphere.mc.scene import SceneError  # JAX
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
