r"""The simulate hook's contract: what a family gives the shared runner (its scene schema and its walk),
as :class:`typing.Protocol` s, and the check of a hook against them (one line naming the first missing
member)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Hashable, Iterable, Mapping, Protocol, Sequence, runtime_checkable

from fitlab.core._hooks import missing_member
from fitlab.scenes._check import Checker

__all__ = ["Job", "SceneSchema", "Walk", "SimulateHook", "Simulation", "missing_member", "check_simulate_hook"]


@dataclass(frozen=True)
class Job:
    """One job of a scene: run in rounds until its rows reach their targets or its path budget.

    key: how the result indexes the job's tallies and statistics.
    name: the job in a warning or an "not converged" line.
    label: the job in the progress bar.
    data: the walk's own (configuration, parameters).
    """

    key: Hashable
    name: str
    label: str
    data: Any = None


@runtime_checkable
class SceneSchema(Protocol):
    """A family's scene files: which suffixes, which rules; :func:`fitlab.scenes.parse_scene` reads and
    parses the file, checks its ``scene.family``, and hands the rest to :meth:`parse`."""

    family: str  #: the family's name: a scene's ``[scene] family`` must say it
    noun: str  #: what its files are called in messages ("scene")
    suffixes: tuple[str, ...]  #: the file suffixes it reads (".toml", ".json")
    limits: Mapping[str, tuple[int, int]]  #: closed ranges of the integer fields, seed and max_paths included

    def parse(self, data: dict, ck: Checker, **options) -> Any:
        """The validated scene (a dataclass with path, name, seed, max_paths, batch, target_se) from the
        file's ``data``; every problem recorded in ``ck`` and raised by ``ck.raise_errors()``."""
        ...

    def target_keys(self, scene) -> Iterable[str]:
        """The keys of ``scene.target_se`` that ``--target-se`` sets."""
        ...


@runtime_checkable
class Walk(Protocol):
    """A family's Monte Carlo walk: its jobs, one round of a job, the stopping rule, the rows."""

    unit: str  #: what a path is called in the stopping rule's message ("photons", "paths")
    min_paths: int  #: the fewest paths after which a job may stop on its target
    row_fields: tuple[str, ...]  #: the columns of <name>.csv
    summary_fields: tuple[str, ...]  #: the columns of <name>_summary.csv
    summary_columns: tuple[tuple[str, str, str], ...]  #: the printed summary: (title, key, format spec)

    def jobs(self, scene) -> Sequence[Job]:
        """The jobs, in the order they run (a :class:`SceneError` refuses a scene before any work)."""
        ...

    def compile(self, scene, job: Job) -> float:
        """Compile the job's walk; returns the seconds it took."""
        ...

    def run_round(self, scene, job: Job, rounds: int, paths: int, n: int) -> Mapping:
        """The tallies of ``n`` more paths (after ``rounds`` rounds of ``paths`` paths in all)."""
        ...

    def count(self, tallies: Mapping) -> tuple[int, int]:
        """(paths, scattering events) of summed tallies."""
        ...

    def converged(self, scene, job: Job, tallies: Mapping) -> tuple[bool, float]:
        """(every row at or below its target, the worst standard error / target)."""
        ...

    def finish(self, scene, jobs: Sequence[Job], tallies: Mapping, stats: Mapping) -> tuple[Any, list]:
        """(rows, summary rows) of the finished run, references attached."""
        ...

    def csv_rows(self, result) -> Iterable[Mapping]:
        """The rows of <name>.csv, in order."""
        ...

    def plots(self, result) -> list[tuple[str, bytes]]:
        """(file name, PNG bytes) of each figure."""
        ...

    # optional: ``start_round(scene, job, rounds, paths, n)``, run_round's round as a
    # fitlab._montecarlo.ChunkedRound (run in chunks: Ctrl-C and the progress bar within a round);
    # ``failed(tallies) -> int``, the paths that ended on a non-finite state (fitlab.scenes.failures)


@runtime_checkable
class SimulateHook(Protocol):
    """The ``simulate`` hook of a family (what ``hooks["simulate"]()`` returns): its scene schema and its
    walk; the shared runner (:func:`fitlab.scenes.simulate_file`) does the rest."""

    schema: SceneSchema
    walk: Walk


@dataclass(frozen=True)
class Simulation:
    """A :class:`SimulateHook`: a schema and a walk.  ``claims`` (optional): whether the data of a scene
    file that names no family is this family's (``fitlab simulate`` asks, for the scenes written before a
    scene named its family)."""

    schema: Any
    walk: Any
    claims: Callable[[dict], bool] | None = None


def check_simulate_hook(hook, family: str = "?") -> SimulateHook:
    """``hook`` when it meets :class:`SimulateHook` (its schema a :class:`SceneSchema`, its walk a
    :class:`Walk`); else TypeError, one line naming the family and the missing member."""
    name = missing_member(hook, SimulateHook)
    if name:
        raise TypeError(f"family {family}: its simulate hook lacks {name!r} (fitlab.scenes.SimulateHook)")
    for part, protocol in (("schema", SceneSchema), ("walk", Walk)):
        name = missing_member(getattr(hook, part), protocol)
        if name:
            raise TypeError(f"family {family}: its simulate hook's {part} lacks {name!r} "
                            f"(fitlab.scenes.{protocol.__name__})")
    return hook
