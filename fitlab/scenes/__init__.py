r"""Monte Carlo scenes, for every family: one loader and checker of scene files, and one simulate runner.

A family that simulates is a :class:`fitlab.core.HasMonteCarlo`: its ``simulation()`` gives a
:class:`Simulation` of a :class:`SceneSchema` (which files, which fields, the rules) and a :class:`Walk` (its
jobs, one round of a job, the stopping rule, the rows and figures).  Everything else is here, once:

* reading (:func:`load_scene`): a regular file only, UTF-8, at most :data:`MAX_SCENE_BYTES`; TOML or
  JSON; every problem one line ``file:line: field: what`` (the line from the parsers' own positions), all
  of a file's problems in one :class:`SceneError`;
* the family: a scene names it (``[scene] family = "lambert_sphere"``); a scene read by another family's
  schema is refused;
* command-line overrides (:func:`scene_with_overrides`: ``--seed``, ``--max-paths``, ``--target-se``), by
  the scene file's own rules (:func:`check_option`);
* running (:func:`simulate`): rounds (in chunks of a fraction of a second where the walk allows: Ctrl-C
  between two), the stopping rule, the progress bar, the pilot's estimate of a run past a minute, the
  warning for a job projected past an hour; and the outputs (:func:`write_outputs`: the rows' CSV, the summary CSV, the figures, as one
  unit), the summary table, the jobs that missed their target (:func:`unconverged`) and those whose walk
  counted paths ending on a non-finite state (:func:`failures`), the output folder's
  check (:func:`check_out_dir`); :func:`simulate_file` does all of it, in that order, every error before any
  work.

``fitlab simulate`` is :func:`simulate_file` with the family's simulation (:mod:`fitlab.cli.simulate`).
"""

from fitlab.scenes._check import NAME_RE, Checker, check_option, keypath_name, with_overrides
from fitlab.scenes._document import MAX_SCENE_BYTES, Document, SceneError, parse_document, peek, read_scene_text
from fitlab.scenes._protocol import Job, SceneSchema, Simulation, Walk
from fitlab.scenes._runner import (
    JobStats,
    SimulationResult,
    check_out_dir,
    csv_text,
    failures,
    load_scene,
    output_files,
    parse_scene,
    scene_with_overrides,
    simulate,
    simulate_file,
    summary_table,
    unconverged,
    write_outputs,
)

__all__ = [
    "MAX_SCENE_BYTES",
    "NAME_RE",
    "Checker",
    "Document",
    "Job",
    "JobStats",
    "SceneError",
    "SceneSchema",
    "Simulation",
    "SimulationResult",
    "Walk",
    "check_option",
    "check_out_dir",
    "csv_text",
    "declared_family",
    "failures",
    "keypath_name",
    "load_scene",
    "output_files",
    "parse_document",
    "parse_scene",
    "peek",
    "read_scene_text",
    "scene_with_overrides",
    "simulate",
    "simulate_file",
    "summary_table",
    "unconverged",
    "with_overrides",
    "write_outputs",
]


def declared_family(data: dict) -> str | None:
    """The family a scene's data names (``[scene] family``), or None."""
    sc = data.get("scene") if isinstance(data, dict) else None
    fam = sc.get("family") if isinstance(sc, dict) else None
    return fam if isinstance(fam, str) else None
