"""A family is one folder: a toy family registered from a temporary folder works with refit,
codegen (Python and C), residuals and the report's parts table, with no change to fitlab."""

from __future__ import annotations

import importlib
import importlib.util
import json
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from fitlab.cli import main
from fitlab.codegen import emit, load_program
from fitlab.codegen.native import CompileError, build, compiler
from fitlab.core import families, get_target, targets, unregister_family
from fitlab.report.accuracy import part_accuracy
from fitlab.report.methods import fit_inventory, part_methods
from fitlab.report.write import parts_table
from fitlab.residuals import residuals
from fitlab.store import load

# y = 1/(1 + x) on [0, 2]: closed form; the form (1 + a x)/(1 + b x) holds it exactly at a = 0, b = 1,
# and the preset (a, b) = (0.1, 0.9) is what the refit must improve on
TOY = '''
"""A toy family: one target with a closed-form exact value, one form."""

import numpy as np
import sympy as sp

from fitlab.core import Dataset, Family, Input, Target, register_family
from fitlab.forms import Form

X = Input("x", (0.0, 2.0), "the toy input")


def _set(n, grid):
    x = np.linspace(0.0, 2.0, n)
    return Dataset({"x": x}, 1.0 / (1.0 + x), grid)


def _grid(axes):
    x = np.asarray(axes["x"], dtype=float)
    return {"x": x}, 1.0 / (1.0 + x), {}


TARGET = Target(
    name="toy_recip", description="1/(1 + x), x in [0, 2]", variables=(X,), default_form="rational",
    published=(("rational", "guess"),), training=lambda: _set(41, "x = k/20"),
    validation=lambda: _set(161, "x = k/80"), exact_grid=_grid, routine="toy_recip",
)
x, a, b = sp.symbols("x a b", real=True)
FORM = Form("toy_recip", "rational", ("x",), ("a", "b"), (1 + a * x) / (1 + b * x),
            presets={"guess": {"a": 0.1, "b": 0.9}}, description="(1 + a x)/(1 + b x)")
FAMILY = register_family(Family("toy", "A toy family", (TARGET,), (FORM,)))
'''


@pytest.fixture(scope="module")
def toy_family(tmp_path_factory):
    folder = tmp_path_factory.mktemp("toy_family")
    (folder / "toy_family.py").write_text(textwrap.dedent(TOY))
    sys.path.insert(0, str(folder))
    try:
        module = importlib.import_module("toy_family")
        yield module
    finally:
        unregister_family("toy")
        sys.modules.pop("toy_family", None)
        sys.path.remove(str(folder))


@pytest.fixture(scope="module")
def toy_fits(toy_family, tmp_path_factory):
    # a fits folder of both families: the report takes the Lambert sphere's committed fits beside the toy's
    out = tmp_path_factory.mktemp("toy_fits")
    for path in (Path(__file__).resolve().parents[1] / "fitlab" / "fits").glob("*.json"):
        (out / path.name).write_bytes(path.read_bytes())
    assert main(["refit", "--target", "toy_recip", "--out", str(out), "--quiet"]) == 0
    return out


def test_the_family_is_registered_beside_the_builtin_one(toy_family):
    assert "toy" in families() and "lambert_sphere" in families()
    t = get_target("toy_recip")
    assert t.family == "toy" and t.domain == {"x": (0.0, 2.0)} and list(t.forms) == ["rational"]
    assert "toy_recip" in targets() and "H0" in targets()


def test_refit_through_the_cli(toy_fits):
    rec = json.loads((toy_fits / "toy_recip.json").read_text())
    assert rec["target"] == "toy_recip" and rec["domain"] == {"x": [0.0, 2.0]}
    assert rec["validation"]["max_rel"] < 1e-10  # the form holds 1/(1 + x) exactly
    assert rec["published"][0]["validation"]["max_rel"] > 1e-2
    f = load(toy_fits / "toy_recip.json")
    np.testing.assert_allclose(f(x=np.array([0.0, 1.0, 2.0])), [1.0, 0.5, 1.0 / 3.0], rtol=1e-10)


def test_codegen_python_and_c(toy_fits, tmp_path):
    prog = load_program(toy_fits, family="toy")
    assert [r.name for r in prog.routines] == ["toy_recip"]
    files = emit(prog, "python")
    (name, text), = files.items()
    path = tmp_path / name
    path.write_text(text)
    spec = importlib.util.spec_from_file_location("toy_generated", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    x = np.linspace(0.0, 2.0, 7)
    np.testing.assert_allclose(mod.toy_recip(x), 1.0 / (1.0 + x), rtol=1e-10)
    if compiler() is None:
        pytest.skip("no C compiler")
    try:
        lib = build(emit(prog, "c"), prog, tmp_path / "c")
    except CompileError as exc:  # pragma: no cover - the strict flags must pass
        pytest.fail(str(exc))
    np.testing.assert_allclose(lib("toy_recip", x), 1.0 / (1.0 + x), rtol=1e-10)


def test_residuals_and_the_report_parts_table(toy_fits):
    fit = load(toy_fits / "toy_recip.json")
    r = residuals("toy_recip", fit, x=np.linspace(0.0, 2.0, 33))
    assert r.error.shape == (33,) and float(np.max(r.error)) < 1e-10
    preset = residuals("toy_recip", ("rational", "guess"), x=np.linspace(0.0, 2.0, 33))
    assert float(np.max(preset.error)) > 1e-2
    entries = [e for e in fit_inventory(toy_fits) if e.target == "toy_recip"]
    rows = []
    for pm in part_methods("toy_recip", entries):
        acc = part_accuracy(pm, get_target("toy_recip"))
        rows.append({"target": "toy_recip", "method": pm.name, "group": pm.group, **acc})
    assert len(rows) >= 2
    table = "\n".join(parts_table(rows))
    assert table.count("| toy_recip |") == len(rows)
