"""``fitlab simulate``: the shared simulate runner (:func:`fitlab.scenes.simulate_file`) with the scene's
family's Monte Carlo (:class:`fitlab.core.HasMonteCarlo`: a :class:`fitlab.scenes.Simulation` of its scene schema
and its walk; for the Lambert sphere :mod:`fitlab.families.lambert_sphere.mc.simulate`).

The scene's family: ``--family``; else the one family that simulates; else the family whose packaged
scenes hold it; else the one its ``[scene] family`` names; else (a scene written before scenes named their
family) the one whose ``claims`` accepts it; else the first family that simulates, whose rules then say what
is wrong.  The Monte Carlo (JAX) is imported inside :func:`run` only.

Exit status: 0 when every job reached its standard-error target; 1 when a job
stopped on its path budget without reaching it ("conv NO"; the outputs are
written and their rows say converged = False) unless ``--allow-unconverged``,
or on a runtime failure; 2 when an input is refused, always before any
computation (one line per problem); 130 on Ctrl-C, within a fraction of a second
of device time, nothing written.  A run whose pilot projects more than a minute is
announced in one line before its rounds; a job whose walk ended paths on a
non-finite state is named in one warning line.
"""

from __future__ import annotations

import sys
from pathlib import Path

from fitlab._montecarlo import MAX_PATHS, MIN_PATHS_BUDGET, SLOW_JOB_SECONDS, duration
from fitlab.cli._common import FAILURE, USAGE, add_family, fail, family_with
from fitlab.core import HasMonteCarlo, offering
from fitlab.resources import find_scene, packaged_scenes

__all__ = ["add_arguments", "run"]


def add_arguments(p) -> None:
    p.add_argument(
        "scene",
        help="scene file (.toml or .json), or the name of a scene packaged with fitlab "
        f"({', '.join(packaged_scene_names()) or 'none'})",
    )
    p.add_argument("--out", help="output folder (default: mc_out/<scene name>)")
    # strings: checked by the scene file's own rules (fitlab.scenes.check_option), one line each
    p.add_argument("--target-se", help="override every effect's standard-error target (positive, finite)")
    p.add_argument(
        "--max-paths",
        help=f"override the path budget per job (integer in [{MIN_PATHS_BUDGET}, "
        f"2^{MAX_PATHS.bit_length() - 1}]); a job projected to run longer than "
        f"{duration(SLOW_JOB_SECONDS)} is named in a warning on stderr",
    )
    p.add_argument("--seed", help="override the scene's seed (integer in [0, 2^63 - 1], as in the scene file)")
    p.add_argument(
        "--allow-unconverged",
        action="store_true",
        help="exit 0 even when a job stops on its path budget above its target",
    )
    p.add_argument("--no-plots", action="store_true", help="CSV only")
    add_family(p, "simulate")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def _simulating_families() -> list[str]:
    return list(offering(HasMonteCarlo))  # the families' classes: imports none of their Monte Carlos


def _family_of(scene: Path, family: str | None) -> str | None:
    """Whose Monte Carlo runs ``scene`` (see the module's docstring); None: the one family that simulates."""
    if family is not None:
        return family
    simulating = _simulating_families()
    if len(simulating) <= 1:
        return None
    for fam in simulating:
        if scene.resolve().parent == packaged_scenes(fam).resolve():
            return fam
    from fitlab.scenes import declared_family, peek

    raw = peek(scene)  # a regular file only (a FIFO never blocks); {} when it cannot be read or parsed
    declared = declared_family(raw)
    if declared is not None:
        return declared  # a family that does not simulate is refused by family_with(), one line
    claiming = [fam for fam in simulating if (family_with(HasMonteCarlo, fam).simulation().claims or _nothing)(raw)]
    return claiming[0] if len(claiming) == 1 else simulating[0]


def _nothing(raw) -> bool:
    return False


def packaged_scene_names() -> list[str]:
    """The names of the example scenes packaged with fitlab (``fitlab simulate NAME`` runs one)."""
    return sorted(p.stem for fam in _simulating_families() for p in packaged_scenes(fam).glob("*.toml"))


def run(args) -> int:
    """Validate everything (every error before any work), simulate, write; see the module's exit statuses."""
    scene = find_scene(args.scene, _simulating_families())
    if scene is None:
        return fail(
            "simulate",
            f"{args.scene}: no such scene file, and no packaged scene of that name "
            f"(packaged: {', '.join(packaged_scene_names())})",
            USAGE,
        )

    from fitlab.scenes import SceneError, failures, simulate_file, summary_table, unconverged

    simulation = family_with(HasMonteCarlo, _family_of(scene, args.family)).simulation()  # imports JAX
    try:
        result, paths = simulate_file(
            simulation,
            scene,
            out_dir=args.out,
            progress=not args.quiet,
            plots=not args.no_plots,
            target_se=args.target_se,
            max_paths=args.max_paths,
            seed=args.seed,
        )
    except SceneError as exc:  # every input is checked before any work: a usage error
        return fail("simulate", exc, USAGE)
    except (OSError, ValueError, RuntimeError) as exc:
        return fail("simulate", f"{type(exc).__name__}: {exc}", FAILURE)
    print(summary_table(result))
    for p in paths:
        print(f"wrote {p}")
    for line in failures(result):
        print(f"fitlab simulate: warning: {line}", file=sys.stderr)
    missed = unconverged(result)
    for line in missed:
        print(f"fitlab simulate: {line}", file=sys.stderr)
    if missed and not args.allow_unconverged:
        return fail(
            "simulate",
            f"{len(missed)} job(s) did not reach the standard-error target (--allow-unconverged accepts this)",
            FAILURE,
        )
    return 0
