"""A wheel built from the checkout works outside it: the installation a user gets from the package registry.

The wheel is built from the files git tracks (or would track), installed into a fresh virtual environment
(its dependencies come from the site-packages folders of the environment running the tests, whatever kind it
is: the base interpreter, a venv, a conda environment; nothing is downloaded), and driven from a temporary
folder far from the checkout, with a cold cache and no user data folder, so every table, fit and scene it uses
must come from inside the installed package:

* ``fitlab refit --target H0 --out TMP`` writes a fit that the schema accepts;
* ``fitlab codegen --lang c --out TMP`` writes the same bytes as the generated code packaged with fitlab
  (regenerated from the packaged fits), and the C compiles;
* ``fitlab simulate order1_normalisation`` (a packaged scene, by name) at a small budget writes its table.

The wheel itself holds fitlab's files and nothing else: no study (``studies/``, the scripts that write docs/), test
or tool.
"""

from __future__ import annotations

import json
import os
import shutil
import site
import subprocess
import sys
import sysconfig
import venv
import zipfile
from pathlib import Path

import pytest

pytestmark = pytest.mark.e2e  # the whole module runs commands end to end

ROOT = Path(__file__).resolve().parents[1]


def _sources() -> list[str]:
    """The checkout's files as git sees them: tracked, plus untracked ones that are not ignored."""
    out = subprocess.run(["git", "-C", str(ROOT), "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
                         capture_output=True, check=True).stdout.decode()  # fmt: skip
    return [name for name in out.split("\0") if name and (ROOT / name).is_file()]


def _site_folders() -> list[str]:
    """The site-packages folders of the interpreter running the tests, where fitlab's dependencies are.

    site.getsitepackages() is the environment's own (a venv's, a conda environment's, the base
    interpreter's) plus its base interpreter's when the environment includes those; the user's site
    folder is listed when this interpreter reads it.  The checkout itself is never listed."""
    folders = [*site.getsitepackages(), sysconfig.get_path("purelib"), sysconfig.get_path("platlib")]
    if site.ENABLE_USER_SITE:
        folders.append(site.getusersitepackages())
    out = []
    for folder in folders:
        if Path(folder).is_dir() and Path(folder).resolve() != ROOT and folder not in out:
            out.append(folder)
    return out


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("needs a git checkout to know which files are the sources")
    base = tmp_path_factory.mktemp("wheel")
    src = base / "src"
    for name in _sources():
        (src / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / name, src / name)
    dist = base / "dist"
    # no build isolation: setuptools and build come with the [dev] extra, nothing is downloaded
    built = subprocess.run([sys.executable, "-m", "build", "--wheel", "--no-isolation", "--outdir", str(dist), str(src)],
                           capture_output=True, text=True)  # fmt: skip
    assert built.returncode == 0, built.stdout[-3000:] + built.stderr[-3000:]
    (wheel,) = dist.glob("fitlab_brdf-*.whl")
    env_dir = base / "venv"
    # not system_site_packages: those are the base interpreter's site-packages (not those of a venv running the
    # tests), and their .pth files run in the new venv (an editable install's finder among them)
    venv.EnvBuilder(system_site_packages=False, with_pip=True).create(env_dir)
    python = env_dir / "bin" / "python"
    pip = subprocess.run([str(python), "-m", "pip", "install", "--no-deps", "--no-index", "--quiet", str(wheel)],
                         capture_output=True, text=True)  # fmt: skip
    assert pip.returncode == 0, pip.stderr[-3000:]
    # the dependencies: the test environment's site-packages folders, after the venv's own (where the wheel is).
    # A .pth file's plain lines are only added to sys.path: the .pth files in those folders are not run, so an
    # editable install of fitlab there (its __editable__ finder, or a path to the checkout) never reaches the venv
    purelib = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                             capture_output=True, text=True, check=True).stdout.strip()  # fmt: skip
    (Path(purelib) / "fitlab-test-dependencies.pth").write_text("".join(f"{folder}\n" for folder in _site_folders()))
    work = base / "elsewhere"
    work.mkdir()
    # the run's cache of exact values and compiled programs (tests/conftest.py sets $FITLAB_CACHE_DIR): entries are
    # keyed by the bytes of the code that computes them, which the wheel's copy shares; the cache is not under test
    env = {**os.environ, "FITLAB_DATA": str(base / "no-data"), "PYTHONPATH": "", "OPENBLAS_NUM_THREADS": "1"}

    def run(*args, check=True):
        done = subprocess.run(
            [str(env_dir / "bin" / "fitlab"), *args], cwd=work, env=env, capture_output=True, text=True
        )
        if check:
            assert done.returncode == 0, (args, done.stdout[-2000:], done.stderr[-2000:])
        return done

    probe = ("import sys, fitlab; print(fitlab.__file__); print([f.__module__ + '.' + "
             "getattr(f, '__qualname__', type(f).__qualname__) for f in sys.meta_path])")  # fmt: skip
    where, finders = subprocess.run([str(python), "-c", probe], cwd=work, env=env, capture_output=True, text=True,
                                    check=True).stdout.splitlines()  # fmt: skip
    return {"run": run, "work": work, "package": Path(where).parent, "env": env_dir, "finders": finders,
            "wheel": wheel}  # fmt: skip


def test_the_wheel_holds_the_package_and_no_study(installed):
    """Every file of the checkout's fitlab/ is in the wheel (the modules; the fits, the generated code, the exact
    tables, the scenes, the seeds of exact values and the schema the package reads), and nothing else: no study
    (studies/ imports fitlab as a user's code does and writes docs/), no test, no tool."""
    with zipfile.ZipFile(installed["wheel"]) as wheel:
        names = wheel.namelist()
    held = {name for name in names if ".dist-info/" not in name}
    package = {name for name in _sources() if name.startswith("fitlab/")}
    assert held == package, (f"in the wheel, not in fitlab/: {sorted(held - package)[:10]}; "
                             f"in fitlab/, not in the wheel: {sorted(package - held)[:10]}")  # fmt: skip
    assert not [name for name in names if "studies" in name.split("/")[:-1] or name.startswith("studies")]
    for folder in ("fitlab/fits/", "fitlab/fits/true/", "fitlab/fits/generated/", "fitlab/data/lambert_sphere/",
                   "fitlab/data/microfacet_energy/", "fitlab/data/fresnel/", "fitlab/data/exact_values/",
                   "fitlab/data/lambert_sphere/scenes/", "fitlab/schemas/"):  # fmt: skip
        assert any(name.startswith(folder) and "/" not in name[len(folder) :] for name in held), folder


def test_the_installed_package_is_the_wheel_and_holds_its_data(installed):
    package = installed["package"]
    assert installed["env"] in package.parents, package  # not the checkout
    # nor can an editable install's finder (__editable___fitlab_brdf_0_1_0_finder._EditableFinder) reach the venv
    assert "editable" not in installed["finders"].lower(), installed["finders"]
    for name in ("h0.csv", "h1.csv", "h2.csv", "constants.csv", "kd.csv"):
        assert (package / "data" / "lambert_sphere" / name).is_file(), name
    assert (package / "fits" / "H0.json").is_file()
    assert (package / "fits" / "generated" / "lambert_sphere.c").is_file()
    assert (package / "data" / "lambert_sphere" / "scenes" / "order1_normalisation.toml").is_file()
    assert (package / "schemas" / "fit-1.schema.json").is_file()


def test_refit_from_any_folder(installed):
    done = installed["run"]("refit", "--target", "H0", "--out", "out/fits", "--quiet", "--json")
    summary = json.loads(done.stdout)
    assert summary["ok"] and summary["written"]
    (fit,) = summary["fits"]  # the form the default model prints: H0.json if it is H0's default form, else H0.FORM.json
    path = installed["work"] / fit["path"]
    assert path.parent == installed["work"] / "out" / "fits", path
    assert path.name in ("H0.json", f"H0.{fit['form']}.json"), path
    record = json.loads(path.read_text())
    assert (record["target"], record["form"], record["format"]) == ("H0", fit["form"], "fitlab-fit/1")


def test_codegen_from_any_folder_reproduces_the_packaged_code(installed):
    installed["run"]("codegen", "--lang", "c", "--out", "out/generated", "--quiet")
    out = installed["work"] / "out" / "generated"
    for name in ("lambert_sphere.c", "lambert_sphere.h"):
        assert (out / name).read_bytes() == (installed["package"] / "fits" / "generated" / name).read_bytes(), name
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is not None:
        subprocess.run([cc, "-std=c99", "-c", str(out / "lambert_sphere.c"), "-o", str(out / "lambert_sphere.o")],
                       check=True, capture_output=True)  # fmt: skip


def test_simulate_a_packaged_scene_by_name(installed):
    installed["run"]("simulate", "order1_normalisation", "--max-paths", "1000", "--allow-unconverged", "--no-plots",
                     "--quiet", "--out", "out/mc")  # fmt: skip
    written = sorted(p.name for p in (installed["work"] / "out" / "mc").iterdir())
    assert "order1_normalisation.csv" in written, written
    refused = installed["run"]("simulate", "no_such_scene", check=False)
    assert refused.returncode == 2 and "order1_normalisation" in refused.stderr


def test_refit_then_codegen_prints_the_refit_from_an_empty_folder(installed):
    """The loop of a new user, from an empty folder: `fitlab refit --target H1 && fitlab codegen --fits fits
    --model three-term --lang c` gives C whose h1 is that refit (the banner names its file, sha256 and origin); the
    refit of H1 is a fit of its three-term target, so it goes with the model whose parts are all such fits."""
    import hashlib

    work = installed["work"] / "loop"
    work.mkdir()
    env_run = installed["run"]
    done = env_run("refit", "--target", "H1", "--out", "loop/fits", "--quiet", "--json")
    (fit,) = json.loads(done.stdout)["fits"]
    path = installed["work"] / fit["path"]
    env_run(
        "codegen", "--fits", "loop/fits", "--model", "three-term", "--lang", "c", "--out", "loop/generated", "--quiet"
    )
    text = (work / "generated" / "lambert_sphere.c").read_text()
    line = next(ln for ln in text.splitlines() if f" {path.name}  " in ln)
    assert hashlib.sha256(path.read_bytes()).hexdigest() in line and "--fits;" in line


def test_fit_a_table_then_codegen_glsl_from_any_folder(installed):
    """`fitlab fit` on a CSV, then `fitlab codegen --fit`, gives GLSL (that glslangValidator accepts, where it is)."""
    work = installed["work"] / "own"
    work.mkdir()
    rows = ["x,y,z"] + [f"{x / 10},{y / 10},{1 + x / 10 + (y / 10) ** 2}" for x in range(11) for y in range(11)]
    (work / "t.csv").write_text("\n".join(rows) + "\n")
    installed["run"](
        "fit", "own/t.csv", "--target", "z", "--form", "a0 + a1*x + a2*y**2", "--out", "own/fits", "--quiet"
    )
    (fit_file,) = (work / "fits").glob("z.*.json")
    installed["run"]("codegen", "--fit", str(fit_file), "--lang", "glsl", "--out", "own/generated", "--quiet")
    (glsl,) = (work / "generated").glob("*.glsl")
    validator = shutil.which("glslangValidator")
    if validator is not None:
        shader = work / "generated" / "check.frag"
        name = fit_file.name.split(".")[1]
        shader.write_text(
            "#version 330\n" + glsl.read_text() + "uniform vec2 p; out vec4 colour;\n"
            f"void main() {{ colour = vec4(z_{name}(p.x, p.y)); }}\n"
        )
        checked = subprocess.run([validator, str(shader)], capture_output=True, text=True)
        assert checked.returncode == 0, checked.stdout[-2000:]
