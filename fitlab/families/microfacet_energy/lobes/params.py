r"""The per-lobe fits, tabulated: the exact values of the lobe-parameter targets.

For every lobe of the lobe tables (:mod:`.tables`: kind, set, job (alpha, mu_i), orders 2, 3, 4 and the
tail above 4, which the tables' order column calls 5) this fits (:func:`.fitting.fit_lobes`):

* ``blog``: the blog's final lobe (:data:`.shapes.PER_LOBE_FORMS` ``blog_final``: scale sigma, exponent eta,
  normal flattening sigma_n; undeviated, isotropic, m = 0) to the lobe itself: columns blog_sigma, blog_eta,
  blog_sigma_n;
* ``blog_scale``: the scale alone of the same lobe with the shape (eta, sigma_n) of the order-2 lobe of the
  same job, as the blog fits its order 3 ("using the same generic parameters as order 2 and fitting the
  scale factor"): column blog_scale (at order 2 it is blog_sigma);
* ``tilt``: the better lobe (``tilted``: sigma, eta, sigma_n, b, k): columns tilt_*.

Every parameter comes with its standard error (se_ columns, from the Jacobian, :mod:`.fitting`), every fit
with its chi-square per degree of freedom and its Levenberg-Marquardt steps.  eta is stored, not the
lobe roughness alpha_l of the fit (eta = 2^(10 (1 - alpha_l)) - 1; its standard error by the chain rule).
Values are written with 6 significant digits: the fits are deterministic, and far less precise than that.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from tqdm import tqdm

from fitlab.families.microfacet_energy.lobes.fitting import fit_lobes, lobe_data
from fitlab.families.microfacet_energy.lobes.shapes import per_lobe_form
from fitlab.families.microfacet_energy.lobes.tables import KINDS, SETS, LobeTable, grid_points, lobe_file
from fitlab.store import Table, TableError, read_table

__all__ = [
    "PARAM_COLUMNS",
    "PARAM_FILES",
    "VALUE_COLUMNS",
    "params_file",
    "params_table",
    "read_params",
    "ORDERS",
    "lobe_inputs",
    "build_params_tables",
    "check_params_tables",
]

#: the orders of the parameter tables (5: every order above 4)
ORDERS = (2, 3, 4, 5)
VALUE_COLUMNS = (
    "blog_sigma",
    "blog_eta",
    "blog_sigma_n",
    "blog_scale",
    "tilt_sigma",
    "tilt_eta",
    "tilt_sigma_n",
    "tilt_b",
    "tilt_k",
)
PARAM_COLUMNS = (
    "alpha",
    "mu_i",
    "order",
    "albedo",
    "albedo_se",
    *VALUE_COLUMNS,
    *(f"se_{c}" for c in VALUE_COLUMNS),
    "blog_chi2",
    "tilt_chi2",
    "blog_steps",
    "tilt_steps",
)
_DIGITS = 6


def params_file(kind: str, which: str) -> str:
    return f"lobe_params_{kind}_{which}.csv"


#: every parameter table and its columns
PARAM_FILES = {params_file(k, w): PARAM_COLUMNS for k in KINDS for w in SETS}


def lobe_inputs(t: LobeTable, j: int, order: int) -> dict:
    """The data of the lobe of job ``j`` and ``order`` (2..5) for :func:`.fitting.fit_lobes`."""
    k = order - 1
    y, se, a, a_se = lobe_data(t.value[j, k], t.se[j, k], t.albedo[j, k], t.albedo_se[j, k], t.paths[j])
    return {"y": y, "se": se, "A": a, "A_se": a_se, "mu_i": float(t.mu_i[j]), "alpha": float(t.alpha[j])}


def _eta(form, fit):
    """eta and its standard error from the fit's alpha_l (eta = 2^(10 (1 - alpha_l)) - 1)."""
    i = form.params.index("alpha_l")
    al, se = fit.theta[:, i], fit.theta_se[:, i]
    eta = 2.0 ** (10.0 * (1.0 - al)) - 1.0
    return eta, (eta + 1.0) * 10.0 * np.log(2.0) * se


def _column(form, fit, name):
    i = form.params.index(name)
    return fit.theta[:, i], fit.theta_se[:, i]


def _round(x) -> list:
    return [float(f"{v:.{_DIGITS}g}") for v in np.asarray(x, dtype=float).ravel()]


def params_table(t: LobeTable, progress=None) -> Table:
    """Fit every lobe of ``t`` (orders 2..5) and return the parameter table (module docstring)."""
    jobs = [(j, s) for j in range(len(t)) for s in ORDERS]
    lobes = [lobe_inputs(t, j, s) for j, s in jobs]
    final, tilted, scale = (per_lobe_form(n) for n in ("blog_final", "tilted", "blog_scale"))
    f_final = fit_lobes(final, lobes)
    f_tilt = fit_lobes(tilted, lobes)
    # the scale with the order-2 shape of the same job: start (and fixed shape) from that lobe's fit
    order2 = {j: i for i, (j, s) in enumerate(jobs) if s == 2}
    start = np.array([f_final.theta[order2[j]] for j, _ in jobs])
    start[:, scale.params.index("sigma")] = [max(lb["A"], 1e-6) for lb in lobes]
    f_scale = fit_lobes(scale, lobes, theta_start=start)
    if progress is not None:
        progress.update(1)
    cols = {}
    cols["blog_sigma"], cols["se_blog_sigma"] = _column(final, f_final, "sigma")
    cols["blog_eta"], cols["se_blog_eta"] = _eta(final, f_final)
    cols["blog_sigma_n"], cols["se_blog_sigma_n"] = _column(final, f_final, "sigma_n")
    cols["blog_scale"], cols["se_blog_scale"] = _column(scale, f_scale, "sigma")
    two = np.array([s == 2 for _, s in jobs])
    cols["blog_scale"] = np.where(two, cols["blog_sigma"], cols["blog_scale"])
    cols["se_blog_scale"] = np.where(two, cols["se_blog_sigma"], cols["se_blog_scale"])
    cols["tilt_sigma"], cols["se_tilt_sigma"] = _column(tilted, f_tilt, "sigma")
    cols["tilt_eta"], cols["se_tilt_eta"] = _eta(tilted, f_tilt)
    for p in ("sigma_n", "b", "k"):
        cols[f"tilt_{p}"], cols[f"se_tilt_{p}"] = _column(tilted, f_tilt, p)
    rows = []
    for i, (j, s) in enumerate(jobs):
        rows.append(
            [
                float(t.alpha[j]),
                float(t.mu_i[j]),
                s,
                float(t.albedo[j, s - 1]),
                float(t.albedo_se[j, s - 1]),
                *_round([cols[c][i] for c in VALUE_COLUMNS]),
                *_round([cols["se_" + c][i] for c in VALUE_COLUMNS]),
                *_round([f_final.chi2_dof[i], f_tilt.chi2_dof[i]]),
                int(f_final.steps[i]),
                int(f_tilt.steps[i]),
            ]
        )
    return Table(
        params_file(t.kind, t.which).removesuffix(".csv"),
        f"per-lobe fits (fitlab.families.microfacet_energy.lobes.fitting: optimistix Levenberg-Marquardt on the chi-square "
        f"of the bins and of the albedo) of the lobes of {lobe_file(t.kind, t.which)}: blog_* the blog's final lobe "
        "(scale, exponent eta, normal flattening), blog_scale its scale with the order-2 lobe's shape, tilt_* the tilted "
        "lobe (lobes.shapes); se_* the parameters' standard errors from the Jacobian",
        f"as the Monte Carlo lobes allow (se_ columns); values rounded to {_DIGITS} significant digits",
        PARAM_COLUMNS,
        rows,
        f"the jobs of {lobe_file(t.kind, t.which)}, orders 2, 3, 4 and 5 (5: every order above 4) each",
    )


def read_params(folder: Path, kind: str, which: str) -> dict[str, np.ndarray]:
    """{column: array} of a parameter table, its header and its rows checked (:class:`fitlab.store.TableError`):
    one row per job of the lobe table's grid and order, in the order :func:`params_table` writes them."""
    path = Path(folder) / params_file(kind, which)
    pts = np.array(grid_points(which), dtype=float)
    rows = {
        "alpha": np.repeat(pts[:, 0], len(ORDERS)),
        "mu_i": np.repeat(pts[:, 1], len(ORDERS)),
        "order": np.tile(np.asarray(ORDERS, dtype=float), len(pts)),
    }
    _, data = read_table(path, PARAM_COLUMNS, points=rows)
    return {c: data[:, i] for i, c in enumerate(PARAM_COLUMNS)}


def build_params_tables(lobe_tables: dict, show_progress: bool = True) -> dict[str, Table]:
    """The parameter tables of ``lobe_tables`` ({(kind, set): LobeTable})."""
    out = {}
    with tqdm(total=len(lobe_tables), desc="fitting lobes", unit="table", disable=not show_progress) as bar:
        for (kind, which), t in lobe_tables.items():
            out[params_file(kind, which)] = params_table(t, bar)
    return out


def check_params_tables(folder: Path, kinds=KINDS) -> list[str]:
    """Read every parameter table in ``folder`` and refit the blog's final lobe of the first job's order-2 lobe
    of each training table from the lobe table beside it; one line per failure (a missing or malformed file,
    parameters that differ from the refit by more than 1e-4 relative, or a table whose jobs are not its lobe
    table's)."""
    from fitlab.families.microfacet_energy.lobes.tables import read_lobes

    failures, refits = [], []
    for kind in kinds:
        for which in SETS:
            try:
                p = read_params(folder, kind, which)
                t = read_lobes(folder, kind, which)
            except TableError as exc:
                failures.append(str(exc))
                continue
            jobs = np.repeat(np.arange(len(t)), len(ORDERS))
            if p["alpha"].size != jobs.size or not (
                np.array_equal(p["alpha"], t.alpha[jobs]) and np.array_equal(p["mu_i"], t.mu_i[jobs])
            ):
                failures.append(f"{params_file(kind, which)}: its jobs are not those of {lobe_file(kind, which)}")
            elif which == "training":
                refits.append(
                    (
                        params_file(kind, which),
                        lobe_inputs(t, 0, 2),
                        np.array([p["blog_sigma"][0], p["blog_eta"][0], p["blog_sigma_n"][0]]),
                    )
                )
    if refits:
        form = per_lobe_form("blog_final")
        fit = fit_lobes(form, [lobe for _, lobe, _ in refits])
        eta, _ = _eta(form, fit)
        for k, (name, _, want) in enumerate(refits):
            got = np.array(
                [fit.theta[k, form.params.index("sigma")], eta[k], fit.theta[k, form.params.index("sigma_n")]]
            )
            if not np.allclose(got, want, rtol=1e-4, atol=1e-6):
                failures.append(
                    f"{name}: the first lobe's blog_sigma, blog_eta, blog_sigma_n {want.tolist()} differ "
                    f"from a refit {got.tolist()}"
                )
    return failures
