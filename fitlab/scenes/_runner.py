r"""The shared simulate runner: load and check a scene (every error before any work: the scene, the
overrides, the output folder), run its jobs in rounds until each reaches its standard-error target or its
path budget, then write a CSV of every row, a summary CSV and the family's figures.

Stopping rule, per job: after every round of ``batch`` paths, the job stops when the walk says every row
is at or below its target (:meth:`Walk.converged`) after at least :attr:`Walk.min_paths` paths; or when it
has used ``max_paths`` (then its rows say converged = False, and :func:`unconverged` names it).  A job whose
stop (its target, or its budget when the target needs more paths) is projected more than an hour away at
its measured rate is named in one warning line on stderr, once (:func:`fitlab._montecarlo.slow_job_warning`).

Rounds in chunks: a walk with ``start_round`` gives each round as a :class:`fitlab._montecarlo.ChunkedRound`,
run in chunks of about :data:`CHUNK_SECONDS` of device time, so that Ctrl-C stops the run between two chunks
and the progress bar moves within a round; the tallies do not depend on the chunks.  Before any round every
job is compiled and piloted (the first :data:`PILOT_SECONDS` of its first round, which then goes on), and a
run projected past :data:`ANNOUNCE_SECONDS` to the path budgets is announced in one line.

Nothing is written until the run and its references are complete; the files are then written as one unit
(:func:`fitlab._io.atomic_write_many`): all of them, or none.
"""

from __future__ import annotations

import csv
import io
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from fitlab import _montecarlo
from fitlab._io import FolderError, atomic_write_many, check_output_folder
from fitlab.scenes._check import Checker, with_overrides
from fitlab.scenes._document import SceneError, parse_document, read_scene_text
from fitlab.scenes._protocol import Simulation

__all__ = [
    "JobStats",
    "SimulationResult",
    "parse_scene",
    "load_scene",
    "scene_with_overrides",
    "simulate",
    "csv_text",
    "output_files",
    "write_outputs",
    "summary_table",
    "unconverged",
    "failures",
    "check_out_dir",
    "simulate_file",
]


@dataclass
class JobStats:
    name: str = ""  # the job in messages
    paths: int = 0
    events: int = 0  # scattering events: the Lambert sphere's collisions, the microsurface's bounces
    seconds: float = 0.0
    compile_seconds: float = 0.0
    rounds: int = 0
    converged: bool = False
    se_ratio: float = math.nan  # worst (standard error / target) of the job's rows, last round

    # the families' names for events
    @property
    def collisions(self) -> int:
        return self.events

    @property
    def bounces(self) -> int:
        return self.events


@dataclass
class SimulationResult:
    scene: Any
    rows: Any = None  # as the walk gives them (a list, or a dict of lists)
    summary: list = field(default_factory=list)  # one dict per summary row
    jobs: dict = field(default_factory=dict)  # job key -> JobStats, in run order
    tallies: dict = field(default_factory=dict)  # job key -> summed tallies
    wall_seconds: float = 0.0
    walk: Any = field(default=None, repr=False, compare=False)


# ------------------------------------------------------------------ scenes
def _family_of(doc, ck: Checker, family: str) -> dict:
    """The document's data without ``scene.family``, which must name ``family`` when given."""
    data = doc.data
    sc = data.get("scene")
    if isinstance(sc, dict) and "family" in sc:
        if sc["family"] != family:
            ck.fail(
                ("scene", "family"),
                f"this scene is for family {sc['family']!r}; it is read as a "
                f"{family} scene (name the family in the scene, or with --family)",
            )
        data = dict(data, scene={k: v for k, v in sc.items() if k != "family"})
    return data


def parse_scene(schema, text: str, path: str = "<scene>", fmt: str | None = None, **options):
    """Parse and validate scene text by ``schema`` (format ``fmt``, else from the suffix of ``path``);
    raises one :class:`SceneError` listing every problem."""
    doc = parse_document(text, str(path), fmt)
    ck = Checker(doc)
    data = _family_of(doc, ck, schema.family)
    if ck.errors:
        ck.raise_errors()
    scene = schema.parse(data, ck, **options)
    ck.raise_errors()
    return scene


def load_scene(schema, path, **options):
    """Read and validate a scene file; see :func:`parse_scene`."""
    text = read_scene_text(path, schema.suffixes, schema.noun)
    return parse_scene(schema, text, str(Path(path)), **options)


def scene_with_overrides(schema, scene, target_se=None, max_paths=None, seed=None):
    """``scene`` with the command-line overrides (None: keep), by the scene file's rules."""
    return with_overrides(
        scene, schema.limits, tuple(schema.target_keys(scene)), target_se=target_se, max_paths=max_paths, seed=seed
    )


# ------------------------------------------------------------------ running
def _accumulate(acc, new):
    if acc is None:
        return {k: np.array(v, copy=True) for k, v in new.items()}
    for k, v in new.items():
        acc[k] = acc[k] + v
    return acc


def _warn(line: str, bar=None) -> None:
    """One warning line on stderr (through the progress bar when there is one)."""
    _say(f"warning: {line}", bar)


def _say(line: str, bar=None) -> None:
    """One line on stderr, ``fitlab simulate: LINE`` (through the progress bar when there is one)."""
    line = f"fitlab simulate: {line}"
    if bar is not None:
        bar.write(line, file=sys.stderr)
    else:
        print(line, file=sys.stderr, flush=True)


#: the device time a chunk of a round aims at (:class:`fitlab._montecarlo.ChunkedRound`): Ctrl-C and the
#: progress bar are answered between chunks, so within about this long (chunks grow at most 4-fold, and each
#: level of a walk keeps its own size)
CHUNK_SECONDS = 0.25
#: the pilot of a job: the first chunks of its first round, this long at least (or the whole round)
PILOT_SECONDS = 0.5
#: a run whose pilots project more than this to the path budgets is announced in one line before its rounds
ANNOUNCE_SECONDS = 60.0
#: the first chunk of a job's first round, in loop steps
_FIRST_STEPS = 32


class _Chunks:
    """A job's chunk sizes, one per level of its walk: each aims at :data:`CHUNK_SECONDS` at the rate its last
    chunk at that level measured."""

    def __init__(self):
        self.steps: dict[int, int] = {}

    def size(self, level: int) -> int:
        return self.steps.get(level, self.steps.get(level - 1, _FIRST_STEPS))

    def measured(self, level: int, steps: int, seconds: float) -> None:
        aim = steps * CHUNK_SECONDS / seconds if seconds > 0 else 4 * steps
        self.steps[level] = int(min(max(aim, steps / 4, 1), 4 * steps))


def _advance(rnd, chunks: _Chunks, st: JobStats, seconds: float, on_chunk) -> bool:
    """Run chunks of ``rnd`` for ``seconds`` at least (math.inf: to its end), Ctrl-C checked after each;
    returns whether the round is done."""
    from fitlab import _interrupt

    spent = 0.0
    while spent < seconds:
        level = rnd.level
        steps = chunks.size(level)
        t0 = time.perf_counter()
        done = rnd.advance(steps)
        dt = time.perf_counter() - t0
        spent += dt
        st.seconds += dt
        chunks.measured(level, steps, dt)
        _interrupt.check()  # a Ctrl-C the handler could not raise while the device ran: before the next chunk
        on_chunk(rnd)
        if done:
            return True
    return False


def _estimate(scene, jobs, pilots) -> str | None:
    """The line announcing a run that the pilots project past :data:`ANNOUNCE_SECONDS` to the path budgets,
    or None.  A job's rate: the paths its pilot ended per second (at least one)."""
    first = total = 0.0
    for job in jobs:
        rnd, spent = pilots.get(job.key, (None, 0.0))
        if rnd is None or spent <= 0.0:
            continue
        rate = max(rnd.finished, 1) / spent
        n = min(scene.batch, scene.max_paths)
        first += n / rate
        total += scene.max_paths / rate
    if total <= ANNOUNCE_SECONDS:
        return None
    several = len(jobs) > 1
    if scene.batch >= scene.max_paths:
        return (
            f"a pilot estimates about {_montecarlo.duration(total)} for this scene ("
            f"{f'{len(jobs)} jobs of ' if several else ''}{scene.max_paths} paths); Ctrl-C stops it"
        )
    return (
        f"a pilot estimates about {_montecarlo.duration(first)} for the first round"
        f"{f's of the {len(jobs)} jobs ({scene.batch} paths each)' if several else f' ({scene.batch} paths)'}"
        f" and up to {_montecarlo.duration(total)} to {'their budgets' if several else 'the budget'} of "
        f"{scene.max_paths} paths{' each' if several else ''} (less "
        f"{'where a job reaches its' if several else 'if it reaches its'} target sooner); Ctrl-C stops it"
    )


def simulate(walk, scene, progress: bool = False) -> SimulationResult:
    """Run every job of ``scene`` with ``walk`` (writes nothing); a progress bar on stderr when
    ``progress``.

    A walk with ``start_round`` (a :class:`fitlab._montecarlo.ChunkedRound` per round) runs each round in
    chunks of about :data:`CHUNK_SECONDS` of device time: Ctrl-C stops it between two, and the progress bar
    moves with each.  Every job is compiled and piloted first (the first :data:`PILOT_SECONDS` of its first
    round, which then goes on from there: nothing is run twice); a run the pilots project past
    :data:`ANNOUNCE_SECONDS` to the path budgets is announced in one line.  The chunks change no tally."""
    t_start = time.perf_counter()
    jobs = list(walk.jobs(scene))
    stats = {job.key: JobStats(name=job.name) for job in jobs}
    tallies: dict = {}
    chunked = callable(getattr(walk, "start_round", None))
    chunks = {job.key: _Chunks() for job in jobs}
    shown = dict.fromkeys(stats, 0)  # the paths of each job the bar counts
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(jobs) * scene.max_paths, unit="path", unit_scale=True, desc=scene.name, disable=not jobs)

    def show(job, k: int, paths: int, what: str) -> None:
        if bar is not None:
            bar.update(max(paths - shown[job.key], 0))
            shown[job.key] = max(paths, shown[job.key])
            bar.set_postfix_str(f"job {k + 1}/{len(jobs)} ({job.label}) {what}", refresh=False)

    try:
        pilots: dict = {}
        for k, job in enumerate(jobs):
            st = stats[job.key]
            st.compile_seconds = walk.compile(scene, job)
            if chunked:
                rnd = walk.start_round(scene, job, 0, 0, min(scene.batch, scene.max_paths))
                before = st.seconds
                _advance(
                    rnd, chunks[job.key], st, PILOT_SECONDS, lambda r, job=job, k=k: show(job, k, r.finished, "pilot")
                )
                pilots[job.key] = (rnd, st.seconds - before)
        line = _estimate(scene, jobs, pilots) if chunked else None
        if line:
            _say(line, bar)
        for k, job in enumerate(jobs):
            st = stats[job.key]
            warned = False
            while st.paths < scene.max_paths:
                n = min(scene.batch, scene.max_paths - st.paths)
                if chunked:
                    rnd = pilots.pop(job.key, (None, 0.0))[0] or walk.start_round(scene, job, st.rounds, st.paths, n)
                    base = st.paths
                    _advance(
                        rnd,
                        chunks[job.key],
                        st,
                        math.inf,
                        lambda r, job=job, k=k, base=base: show(job, k, base + r.finished, "running"),
                    )
                    res = rnd.tallies()
                else:
                    t0 = time.perf_counter()
                    res = walk.run_round(scene, job, st.rounds, st.paths, n)
                    st.seconds += time.perf_counter() - t0
                st.rounds += 1
                tallies[job.key] = _accumulate(tallies.get(job.key), res)
                st.paths, st.events = walk.count(tallies[job.key])
                done, st.se_ratio = walk.converged(scene, job, tallies[job.key])
                show(job, k, st.paths, f"se/target={st.se_ratio:.2f}")
                if done and st.paths >= walk.min_paths:
                    st.converged = True
                    break
                slow = (
                    None if warned else _montecarlo.slow_job_warning(st.paths, st.seconds, st.se_ratio, scene.max_paths)
                )
                if slow:
                    warned = True
                    _warn(f"{job.name}: {slow}", bar)
            show(job, k, scene.max_paths, "done")
    finally:
        if bar is not None:
            bar.close()
    rows, summary = walk.finish(scene, jobs, tallies, stats)
    out = SimulationResult(scene=scene, rows=rows, summary=summary, jobs=stats, tallies=tallies, walk=walk)
    out.wall_seconds = time.perf_counter() - t_start
    return out


# ------------------------------------------------------------------ outputs
def _fmt(v) -> str:
    if isinstance(v, (float, np.floating)):
        return "" if math.isnan(v) else f"{float(v):.10g}"
    return str(v)


def csv_text(rows, fields) -> str:
    """CSV text: a header of ``fields``, then one line per row (floats to 10 significant digits, NaN
    empty, a missing field empty)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(fields)
    for r in rows:
        w.writerow([_fmt(r.get(f, "")) for f in fields])
    return buf.getvalue()


def output_files(result: SimulationResult, out_dir, plots: bool = True) -> dict:
    """{path: bytes} of every output: <name>.csv (every row), <name>_summary.csv, the figures."""
    out_dir, walk, name = Path(out_dir), result.walk, result.scene.name
    files = {
        out_dir / f"{name}.csv": csv_text(walk.csv_rows(result), walk.row_fields).encode(),
        out_dir / f"{name}_summary.csv": csv_text(result.summary, walk.summary_fields).encode(),
    }
    if plots:
        for fname, png in walk.plots(result):
            files[out_dir / fname] = png
    return files


def write_outputs(result: SimulationResult, out_dir, plots: bool = True) -> list:
    """Write :func:`output_files` as one unit; returns the paths written."""
    files = output_files(result, out_dir, plots)
    atomic_write_many(files)
    return list(files)


def summary_table(result: SimulationResult) -> str:
    """A plain-text table of the summary (the walk's columns; a bool is "yes" or "NO"), and a last line
    with the wall time, the compilation time and the number of jobs."""
    columns = result.walk.summary_columns

    def head(spec):  # the alignment and width of a value's format
        i = 0
        while i < len(spec) and (spec[i] in "<>^" or spec[i].isdigit()):
            i += 1
        return spec[:i]

    lines = ["".join(f"{title:{head(spec)}}" for title, _, spec in columns)]
    for s in result.summary:
        cells = []
        for _, key, spec in columns:
            v = s[key]
            cells.append(f"{('yes' if v else 'NO'):{head(spec)}}" if isinstance(v, bool) else f"{v:{spec}}")
        lines.append("".join(cells))
    comp = sum(st.compile_seconds for st in result.jobs.values())
    lines.append(f"wall {result.wall_seconds:.1f} s (compilation {comp:.1f} s), {len(result.jobs)} jobs")
    return "\n".join(lines)


def unconverged(result: SimulationResult) -> list:
    """One line per job that stopped on its path budget without converging (above its standard-error
    target, or under the walk's minimum of paths)."""
    lines = []
    for st in result.jobs.values():
        if st.converged:
            continue
        why = (
            f"standard error {st.se_ratio:.3g} x its target"
            if not st.se_ratio <= 1.0
            else f"fewer than the {result.walk.min_paths} {result.walk.unit} the stopping rule needs"
        )
        lines.append(f"not converged: {st.name}: {why} after {st.paths} paths (max_paths)")
    return lines


def failures(result: SimulationResult) -> list:
    """One line per job some of whose paths ended on a non-finite state (a walk with a ``failed(tallies)``
    count: those paths are tallied apart from capped ones, never as light)."""
    count = getattr(result.walk, "failed", None)
    if count is None:
        return []
    lines = []
    for key, st in result.jobs.items():
        n = count(result.tallies[key]) if key in result.tallies else 0
        if n:
            lines.append(
                f"{st.name}: {n} of {st.paths} {result.walk.unit} ended on a non-finite height, direction "
                "or weight (a walk error, tallied as failed: the estimates leave them out)"
            )
    return lines


def check_out_dir(out_dir) -> None:
    """Refuse (one-line SceneError) an output location that is not, or cannot become, a writable folder
    (:func:`fitlab._io.check_output_folder`, the check every command makes; nothing is created)."""
    out_dir = Path(out_dir)
    try:
        check_output_folder(out_dir)
    except FolderError as exc:
        if exc.kind == "file":
            raise SceneError(f"--out: {out_dir} exists and is not a folder") from None
        raise SceneError(
            f"--out: cannot write in {out_dir}: {exc.detail or exc.kind.replace('_', ' ')} at {exc.where}"
        ) from None


def simulate_file(
    simulation: Simulation, path, out_dir=None, progress=False, plots=True, target_se=None, max_paths=None, seed=None
):
    """Load and validate (the scene, the overrides, the output folder: every error before any work),
    simulate, write; ``simulation`` is a family's :class:`Simulation`.  Returns (result, paths written).
    The default output folder is mc_out/<scene name>."""
    scene = scene_with_overrides(
        simulation.schema, load_scene(simulation.schema, path), target_se=target_se, max_paths=max_paths, seed=seed
    )
    out_dir = Path(out_dir) if out_dir is not None else Path("mc_out") / scene.name
    check_out_dir(out_dir)
    result = simulate(simulation.walk, scene, progress=progress)
    return result, write_outputs(result, out_dir, plots=plots)
