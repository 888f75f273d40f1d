r"""What a family's Monte Carlo gives the shared runner: its scene schema and its walk, as
:class:`typing.Protocol` s, in a :class:`Simulation` (what :meth:`fitlab.core.HasMonteCarlo.simulation`
returns)."""

from __future__ import annotations

from collections.abc import Callable, Hashable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

from fitlab.scenes._check import Checker

__all__ = ["Job", "SceneSchema", "Walk", "Simulation"]


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


class SceneSchema(Protocol):
    """A family's scene files: which suffixes, which rules; :func:`fitlab.scenes.parse_scene` reads and
    parses the file, checks its ``scene.family``, and hands the rest to :meth:`parse`."""

    @property
    def family(self) -> str:
        """The family's name: a scene's ``[scene] family`` must say it."""
        ...

    @property
    def noun(self) -> str:
        """What its files are called in messages ("scene")."""
        ...

    @property
    def suffixes(self) -> tuple[str, ...]:
        """The file suffixes it reads (".toml", ".json")."""
        ...

    @property
    def limits(self) -> Mapping[str, tuple[int, int]]:
        """Closed ranges of the integer fields, seed and max_paths included."""
        ...

    def parse(self, data: dict, ck: Checker, /) -> Any:
        """The validated scene (a dataclass with path, name, seed, max_paths, batch, target_se) from the
        file's ``data``; every problem recorded in ``ck`` and raised by ``ck.raise_errors()``."""
        ...

    def target_keys(self, scene) -> Iterable[str]:
        """The keys of ``scene.target_se`` that ``--target-se`` sets."""
        ...


class Walk(Protocol):
    """A family's Monte Carlo walk: its jobs, one round of a job, the stopping rule, the rows."""

    @property
    def unit(self) -> str:
        """What a path is called in the stopping rule's message ("photons", "paths")."""
        ...

    @property
    def min_paths(self) -> int:
        """The fewest paths after which a job may stop on its target."""
        ...

    @property
    def row_fields(self) -> tuple[str, ...]:
        """The columns of <name>.csv."""
        ...

    @property
    def summary_fields(self) -> tuple[str, ...]:
        """The columns of <name>_summary.csv."""
        ...

    @property
    def summary_columns(self) -> tuple[tuple[str, str, str], ...]:
        """The printed summary: (title, key, format spec)."""
        ...

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


@dataclass(frozen=True)
class Simulation:
    """A family's Monte Carlo: its scene schema and its walk; the shared runner (:func:`fitlab.scenes.simulate_file`)
    does the rest.  ``claims`` (optional): whether the data of a scene file that names no family is this family's
    (``fitlab simulate`` asks, for the scenes written before a scene named its family)."""

    schema: SceneSchema
    walk: Walk
    claims: Callable[[dict], bool] | None = None
