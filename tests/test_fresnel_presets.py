"""The Fresnel preset table of ``fitlab export fresnel_presets``: its parameters are the published constructions
of the exact F, its F_avg agrees with the second quadrature route, its error columns find the maximum a dense
independent scan finds, and its committed C and GLSL regenerate byte for byte."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fitlab.core import get_form
from fitlab.export import encode
from fitlab.families.fresnel.exact import CHANNELS, MATERIALS, average_reflectance, reflectance
from fitlab.families.fresnel.program.images import COLUMNS, ERROR_FLOOR, preset_table

GENERATED = Path(__file__).resolve().parents[1] / "fitlab" / "fits" / "generated"
COLUMN = {name: j for j, (name, _) in enumerate(COLUMNS)}


@pytest.fixture(scope="module")
def table():
    return preset_table()


def test_rows_are_the_materials_and_f0_is_the_exact_normal_reflectance(table):
    assert table.data.shape == (len(MATERIALS), len(COLUMNS), len(CHANNELS))
    for i, material in enumerate(MATERIALS):
        f0 = reflectance(material, 1.0)
        assert np.abs(table.data[i, COLUMN["F0"]] - f0).max() < 1e-15
        assert np.abs(table.data[i, COLUMN["r"]] - np.minimum(f0, 0.999)).max() < 1e-15
        assert f"row {i}: {material} " in "\n".join(table.layout)


def test_f82_tint_meets_the_exact_f_at_82_degrees(table):
    """F82-tint's defining property: tint * Schlick(F0, 1/7) = F_exact(1/7)."""
    mu_bar = 1 / 7
    for i, material in enumerate(MATERIALS):
        f0, tint = table.data[i, COLUMN["F0"]], table.data[i, COLUMN["tint"]]
        schlick = f0 + (1 - f0) * (1 - mu_bar) ** 5
        assert np.abs(tint * schlick - reflectance(material, mu_bar)).max() < 1e-14


def test_f_avg_is_the_average_by_the_other_route(table):
    for i, material in enumerate(MATERIALS):
        assert np.abs(table.data[i, COLUMN["F_avg"]] - average_reflectance(material, route="theta")).max() < 1e-10


def test_error_columns_find_the_maximum_of_a_dense_scan(table):
    """Each construction's max |F - F_exact|, scanned on 20001 angles evenly spaced in theta: the table's figure
    (on the 1027 validation angles, at least ERROR_FLOOR) is within 1 % of it either way."""
    theta = np.linspace(0.0, np.pi / 2, 20001)
    mu = np.cos(theta)
    forms = {
        "error_schlick": ("schlick", "normal"),
        "error_f82_tint": ("f82_tint", "f82"),
        "error_gulbrandsen": ("gulbrandsen", "gulbrandsen"),
    }
    for material in ("cu", "al", "cr", "au", "glass"):
        row = list(MATERIALS).index(material)
        exact = reflectance(material, mu)
        for column, (form_name, preset) in forms.items():
            for c, channel in enumerate(CHANNELS):
                form = get_form(f"F_{material}_{channel}", form_name)
                dense = np.max(np.abs(form(preset, mu) - exact[:, c]))
                stated = table.data[row, COLUMN[column], c]
                assert stated >= 0.99 * dense, (material, column, channel, stated, dense)
                assert stated <= 1.01 * dense + ERROR_FLOOR, (material, column, channel, stated, dense)


@pytest.mark.parametrize("fmt, suffix", [("c", ".h"), ("glsl", ".glsl")])
def test_committed_preset_code_is_what_the_table_generates(table, fmt, suffix):
    """Regenerate (fitlab export fresnel_presets --format c --format glsl --out fitlab/fits/generated), diff."""
    assert (GENERATED / f"fresnel_presets{suffix}").read_bytes() == encode(table, fmt)
