"""fitlab.scenes, the shared scene loader and simulate runner: positions from the parsers, a scene that
names its family, the simulate hook's contract, and a toy family's walk (numpy, no JAX) run end to end."""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field

import numpy as np
import pytest

import fitlab  # noqa: F401
from fitlab import scenes
from fitlab.cli import main
from fitlab.core import Family, HasMonteCarlo, family_with, offering, register_family, unregister_family

TOY_SCENE = """\
[scene]
family = "toy_scenes"
name = "coin"
seed = 5
[coin]
p = [0.25,
     0.5]
[precision]
target_se = 0.02
max_paths = 4000
batch = 1000
"""


@dataclass(frozen=True)
class ToyScene:
    path: str
    name: str
    seed: int
    p: tuple
    target_se: dict = field(hash=False)
    max_paths: int = 4000
    batch: int = 1000


class ToySchema:
    family = "toy_scenes"
    noun = "toy scene"
    suffixes = (".toml", ".json")
    limits = {"seed": (0, 2**63 - 1), "max_paths": (1000, 2**32), "batch": (100, 10**7)}

    def target_keys(self, scene):
        return ("p",)

    def parse(self, data, ck):
        ck.unknown(data, (), {"scene", "coin", "precision"})
        sc = ck.table(data, ("scene",), {"name", "seed"})
        coin = ck.table(data, ("coin",), {"p"})
        prec = ck.table(data, ("precision",), {"target_se", "max_paths", "batch"})
        name = ck.name(sc, ("scene", "name"))
        seed = ck.number(sc, ("scene", "seed"), *self.limits["seed"], default=0, integer=True)
        ps = coin.get("p", [])
        if not isinstance(ps, list) or not ps:
            ck.fail(("coin", "p"), "expected a list of probabilities")
            ps = []
        for k, x in enumerate(ps):
            if isinstance(x, bool) or not isinstance(x, (int, float)) or not 0.0 <= x <= 1.0:
                ck.fail(("coin", "p", k), f"{x!r} is outside [0.0, 1.0]")
        target = ck.number(prec, ("precision", "target_se"), 1e-9, 1.0)
        nums = {
            k: ck.number(prec, ("precision", k), *self.limits[k], default=d, integer=True)
            for k, d in (("max_paths", 4000), ("batch", 1000))
        }
        ck.raise_errors()
        return ToyScene(path=ck.path, name=name, seed=seed, p=tuple(ps), target_se={"p": target}, **nums)


class ToyWalk:
    """Coin flips: a job per probability, its row the mean of the flips."""

    unit = "flips"
    min_paths = 2000
    row_fields = ("p", "estimate", "se", "paths", "converged")
    summary_fields = ("p", "paths", "converged", "estimate")
    summary_columns = (
        ("p", "p", "<8"),
        ("paths", "paths", ">8"),
        ("conv", "converged", ">6"),
        ("estimate", "estimate", ">10.4f"),
    )

    def jobs(self, scene):
        return [scenes.Job(key=i, name=f"coin p = {p:g}", label=f"p={p:g}", data=p) for i, p in enumerate(scene.p)]

    def compile(self, scene, job):
        return 0.0

    def run_round(self, scene, job, rounds, paths, n):
        flips = np.random.default_rng([scene.seed, job.key, rounds]).random(n) < job.data
        return {"n": n, "s1": float(flips.sum()), "events": n}

    def count(self, tallies):
        return int(tallies["n"]), int(tallies["events"])

    def _row(self, job_p, t):
        n = int(t["n"])
        mean = float(t["s1"]) / n
        return dict(p=job_p, estimate=mean, se=math.sqrt(max(mean * (1 - mean), 0.0) / max(n - 1, 1)))

    def converged(self, scene, job, tallies):
        se = self._row(job.data, tallies)["se"]
        return se <= scene.target_se["p"], se / scene.target_se["p"]

    def finish(self, scene, jobs, tallies, stats):
        rows = []
        for job in jobs:
            r = self._row(job.data, tallies[job.key])
            r.update(paths=stats[job.key].paths, converged=stats[job.key].converged)
            rows.append(r)
        return rows, [dict(r) for r in rows]

    def csv_rows(self, result):
        return result.rows

    def plots(self, result):
        return [(f"{result.scene.name}_coin.png", b"\x89PNG toy")]


TOY = scenes.Simulation(schema=ToySchema(), walk=ToyWalk())


def test_a_toy_family_runs_through_the_shared_runner(tmp_path, capsys):
    p = tmp_path / "coin.toml"
    p.write_text(TOY_SCENE)
    result, paths = scenes.simulate_file(TOY, p, out_dir=tmp_path / "out")
    assert [x.name for x in paths] == ["coin.csv", "coin_summary.csv", "coin_coin.png"]
    rows = list(csv.DictReader(paths[0].open()))
    assert [r["p"] for r in rows] == ["0.25", "0.5"] and tuple(rows[0]) == ToyWalk.row_fields
    for r in rows:
        assert abs(float(r["estimate"]) - float(r["p"])) < 4 * float(r["se"])
    # p = 0.25 reaches se 0.02 by the minimum of 2000 flips; p = 0.5 needs 625: both stop at 2000
    assert [st.paths for st in result.jobs.values()] == [2000, 2000] and scenes.unconverged(result) == []
    table = scenes.summary_table(result).splitlines()
    assert table[0] == f"{'p':<8}{'paths':>8}{'conv':>6}{'estimate':>10}"
    assert table[1].startswith(f"{0.25:<8}{2000:>8}{'yes':>6}") and table[-1].endswith(", 2 jobs")
    # a target out of reach: the budget stops the job, and it is named
    result, _ = scenes.simulate_file(TOY, p, out_dir=tmp_path / "out2", target_se="1e-4", max_paths="3000", plots=False)
    assert scenes.unconverged(result)[0].startswith("not converged: coin p = 0.25: standard error ")
    assert "after 3000 paths (max_paths)" in scenes.unconverged(result)[0]
    assert not (tmp_path / "out2" / "coin_coin.png").exists()


def test_positions_come_from_the_parsers():
    bad = TOY_SCENE.replace("     0.5]", "     1.5]").replace("seed = 5", "seed = -5")
    with pytest.raises(scenes.SceneError) as exc:
        scenes.parse_scene(TOY.schema, bad, "c.toml")
    assert str(exc.value).splitlines() == [
        "c.toml:4: scene.seed: -5 is outside [0, 9223372036854775807]",
        "c.toml:7: coin.p[1]: 1.5 is outside [0.0, 1.0]",  # the array closes on line 7
    ]
    import json
    import tomllib

    text = json.dumps(tomllib.loads(bad), indent=1)
    with pytest.raises(scenes.SceneError) as exc:
        scenes.parse_scene(TOY.schema, text, "c.json")
    line = next(i for i, s in enumerate(text.splitlines(), 1) if "1.5" in s)
    assert f"c.json:{line}: coin.p[1]: 1.5 is outside" in str(exc.value)
    with pytest.raises(scenes.SceneError, match=r"^c.toml:3: not valid TOML"):
        scenes.parse_scene(TOY.schema, TOY_SCENE.replace("name =", "name == "), "c.toml")


def test_a_scene_names_its_family(tmp_path):
    with pytest.raises(scenes.SceneError) as exc:
        scenes.parse_scene(TOY.schema, TOY_SCENE.replace("toy_scenes", "lambert_sphere"), "c.toml")
    assert str(exc.value).startswith("c.toml:2: scene.family: this scene is for family 'lambert_sphere'")
    from fitlab.families.microfacet_energy.mc.scene import parse_scene

    with pytest.raises(scenes.SceneError, match="scene.family: this scene is for family 'toy_scenes'"):
        parse_scene(TOY_SCENE, "c.toml")
    assert scenes.declared_family(scenes.peek(tmp_path / "absent.toml")) is None


def test_fitlab_simulate_takes_the_family_the_scene_names(tmp_path, capsys):
    from fitlab.cli import main
    from fitlab.cli.simulate import _family_of

    micro = tmp_path / "m.toml"
    micro.write_text(
        '[scene]\nfamily = "microfacet_energy"\n[[material]]\nkind = "conductor"\n'
        'distribution = "ggx"\nalpha = 0.5\n[incident]\nmu_i = [0.5]\n[precision]\ntarget_se = 0.01\n'
    )
    assert _family_of(micro, None) == "microfacet_energy"
    sphere = tmp_path / "s.toml"  # microsurface materials, but the scene says lambert_sphere: its rules apply
    sphere.write_text(micro.read_text().replace("microfacet_energy", "lambert_sphere"))
    assert _family_of(sphere, None) == "lambert_sphere"
    assert main(["simulate", str(sphere), "--quiet", "--out", str(tmp_path / "o")]) == 2
    assert "material[0].kind: unknown field" in capsys.readouterr().err
    assert (
        main(["simulate", str(sphere), "--quiet", "--family", "microfacet_energy", "--out", str(tmp_path / "o")]) == 2
    )
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and f"{sphere}:2: scene.family: this scene is for family 'lambert_sphere'" in err[0], err
    assert not (tmp_path / "o").exists()


class ToyFamily(Family, HasMonteCarlo, name="toy_scenes", description="A toy family", target_names=()):
    def targets(self):
        return ()

    def forms(self):
        return ()

    def simulation(self) -> scenes.Simulation:
        return TOY


def test_a_toy_familys_monte_carlo_runs_through_fitlab_simulate(tmp_path, capsys):
    """A family is a HasMonteCarlo: ``fitlab simulate --family`` finds it among the families that simulate and runs
    its walk (its schema and walk meet their protocols: basedpyright checks them where the Simulation is made)."""
    p = tmp_path / "coin.toml"
    p.write_text(TOY_SCENE)
    register_family(ToyFamily())
    try:
        assert list(offering(HasMonteCarlo)) == ["lambert_sphere", "microfacet_energy", "toy_scenes"]
        assert main(["simulate", str(p), "--family", "toy_scenes", "--quiet", "--out", str(tmp_path / "o")]) == 0
        assert sorted(x.name for x in (tmp_path / "o").iterdir()) == ["coin.csv", "coin_coin.png", "coin_summary.csv"]
        assert main(["simulate", str(p), "--quiet", "--out", str(tmp_path / "o2")]) == 0  # its [scene] family
        assert (tmp_path / "o2" / "coin.csv").is_file()
    finally:
        unregister_family("toy_scenes")
    capsys.readouterr()
    for fam in ("lambert_sphere", "microfacet_energy"):  # the built-in families' Monte Carlos
        assert family_with(HasMonteCarlo, fam).simulation().schema.family == fam


# -- rounds in chunks: Ctrl-C, the progress bar and the pilot's estimate -----------------------------------
class ChunkedToyWalk(ToyWalk):
    """The coin walk as a walk whose rounds run in chunks (:class:`fitlab._montecarlo.ChunkedRound`): a step
    ends ``LANES`` flips and costs ``step_seconds`` of (slept) device time; ``on_chunk`` sees every chunk."""

    LANES = 10

    def __init__(self, step_seconds=0.0, on_chunk=None):
        self.step_seconds, self.on_chunk, self.chunks = step_seconds, on_chunk, []

    def start_round(self, scene, job, rounds, paths, n):
        import time

        from fitlab._montecarlo import ChunkedRound

        flips = np.random.default_rng([scene.seed, job.key, rounds]).random(n) < job.data

        def run(state, steps):
            done = min(state + steps * self.LANES, n)
            time.sleep(self.step_seconds * -(-(done - state) // self.LANES))
            self.chunks.append((job.key, rounds, steps))
            if self.on_chunk is not None:
                self.on_chunk(len(self.chunks))
            return done, np.array([[done == n, done, 0]])

        return ChunkedRound(0, [run], [], lambda state: {"n": n, "s1": float(flips[:state].sum()), "events": n})


def _coin(tmp_path, text=TOY_SCENE):
    p = tmp_path / "coin.toml"
    p.write_text(text)
    return scenes.load_scene(TOY.schema, p)


def test_chunked_rounds_give_the_rounds_tallies(tmp_path):
    """A walk with start_round runs each round in chunks of loop steps, growing from a few; the tallies are
    those of the rounds run whole (run_round)."""
    scene = _coin(tmp_path)
    whole = scenes.simulate(ToyWalk(), scene)
    walk = ChunkedToyWalk()
    chunked = scenes.simulate(walk, scene)
    assert chunked.tallies == whole.tallies and [st.paths for st in chunked.jobs.values()] == [2000, 2000]
    assert len(walk.chunks) > 2 * 2 and walk.chunks[0][2] < 100  # several chunks per round, the first small


def test_ctrl_c_stops_a_round_between_two_chunks(tmp_path, monkeypatch):
    """A Ctrl-C that comes while the device runs a chunk (the handler records it; Python cannot raise it in
    JAX's code) stops the round when the chunk ends: no further chunk, nothing returned (before: a round of
    1e7 photons ran to its end, Ctrl-C ignored for minutes)."""
    from fitlab import _interrupt

    def ctrl_c(count):
        if count == 5:
            monkeypatch.setattr(_interrupt, "_requested", True)

    walk = ChunkedToyWalk(on_chunk=ctrl_c)
    with pytest.raises(KeyboardInterrupt):
        scenes.simulate(walk, _coin(tmp_path))
    assert len(walk.chunks) == 5


def test_a_long_run_is_announced_in_one_line_and_chunks_stay_short(tmp_path, monkeypatch, capsys):
    """Every job's pilot (the first chunks of its first round, kept) projects the run to its budgets; past
    ANNOUNCE_SECONDS that is said in one line before the rounds, and chunks stay near CHUNK_SECONDS of
    device time (here scaled down: 10 ms chunks, a 30 ms pilot, 0.2 s to announce)."""
    from fitlab.scenes import _runner

    monkeypatch.setattr(_runner, "CHUNK_SECONDS", 0.01)
    monkeypatch.setattr(_runner, "PILOT_SECONDS", 0.03)
    monkeypatch.setattr(_runner, "ANNOUNCE_SECONDS", 0.2)
    walk = ChunkedToyWalk(step_seconds=2e-5)  # 2 ms per 1000 flips: 4000 flips per job, 2 jobs, 16 ms
    scenes.simulate(walk, _coin(tmp_path))
    assert capsys.readouterr().err == ""
    slow = ChunkedToyWalk(step_seconds=5e-4)  # 50 ms per 1000 flips: projected 0.4 s to the budgets
    result = scenes.simulate(slow, scenes.scene_with_overrides(TOY.schema, _coin(tmp_path), target_se="1e-6"))
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("fitlab simulate: a pilot estimates about ") and "Ctrl-C" in err[0]
    assert "first rounds of the 2 jobs (1000 paths each)" in err[0] and "budgets of 4000 paths each" in err[0]
    assert [st.paths for st in result.jobs.values()] == [4000, 4000]
    # every chunk but the first few aims at 10 ms: 20 steps of 0.5 ms, growing at most 4-fold
    sizes = [steps for _, _, steps in slow.chunks]
    assert sizes[0] == 32 and max(sizes) <= 4 * 20 and all(b <= 4 * a for a, b in zip(sizes, sizes[1:]))


def test_the_progress_bar_moves_within_a_round(tmp_path, monkeypatch):
    """The bar counts the paths each chunk ends, so it moves during a round, not only after it."""
    import tqdm

    counts = []

    class Bar:
        def __init__(self, total, **kwargs):
            self.n = 0

        def update(self, k):
            self.n += k
            counts.append(self.n)

        def set_postfix_str(self, *a, **k):
            pass

        def write(self, *a, **k):
            pass

        def close(self):
            pass

    monkeypatch.setattr(tqdm, "tqdm", Bar)
    scene = _coin(tmp_path, TOY_SCENE.replace("batch = 1000", "batch = 4000"))
    scenes.simulate(ChunkedToyWalk(), scene, progress=True)
    within = [c for c in counts if 0 < c < 4000]  # the first job's one round of 4000 flips, chunk by chunk
    assert len(set(within)) >= 2 and counts[-1] == 2 * 4000
