r"""Residuals of an approximation against the exact engine, on a tensor grid.

The notebooks in notebooks/ explore where the fits and the published formulas
err; this module does their arithmetic, so that a notebook only picks grids
and plots.

* ``residuals(target, approx, **axes)``: the exact values of a refit target
  (:mod:`fitlab.families.lambert_sphere.targets`) on the tensor product of ``axes``, the
  approximation there, and the error in the target's own measure (relative to
  |exact|; to A = 69c/128 for B, C, D, F; to f^(0) for fm1).
* ``brdf_residuals(model, mu_i=..., mu_o=..., phi=..., c=...)``: the same for
  a model of the whole BRDF (:func:`fitlab.families.lambert_sphere.program.runtime.runtime_model`) against
  :func:`fitlab.families.lambert_sphere.exact.brdf`, relative to |exact|.
* :class:`Residuals`: the grid with ``worst(n)``, ``table(n)``, ``summary()``
  and ``at(c=0.9)`` (the slice at the nearest grid value).
* ``approximations(target, fits_dir)``: the published presets and saved fits of a target.
* ``heatmap(res, x, y)``: a two-axis residual map on a log colour scale.

Axes are 1-D arrays; the grid is their tensor product in the order given
(``numpy.meshgrid(..., indexing="ij")``).  A target takes one axis per input,
except where an input follows from another, as in its training data:
``c_of_kd`` takes ``c`` (the exact pair is (kd_true(c), c)) and ``fast_brdf``
takes mu_i, mu_o, phi, c with kd = kd_true(c).

``approx`` is a callable taking the target's inputs positionally, in the order
of ``Target.inputs`` (a :class:`fitlab.store.FitFunction`, or any function), or
a pair ``(form, preset)`` naming a published preset of :mod:`fitlab.forms`.
Labels: "form / preset" for a preset, "form (file name)" for a saved fit.
Exact values are cached per target and grid: comparing several
approximations on one grid costs the exact engine once.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property, lru_cache
from pathlib import Path

import numpy as np

from fitlab.core import BrdfGrid, Dataset, HasBrdfGrid, get_form, get_target, offering
from fitlab.fit.metrics import relative_errors, summary
from fitlab.store import FitFunction, fit_files, fits_folder, load

__all__ = ["Residuals", "residuals", "brdf_residuals", "approximations", "grid_axes", "heatmap"]

#: the pseudo-target of :func:`brdf_residuals`: a family's whole BRDF (its :class:`fitlab.core.HasBrdfGrid`)
BRDF = "brdf"


def _brdf_grid(family: str | None = None) -> BrdfGrid:
    """(axes, grid function, error measure) of the exact BRDF of ``family`` (default: the one family that is a
    :class:`fitlab.core.HasBrdfGrid`)."""
    found = offering(HasBrdfGrid)
    if family is None:
        if len(found) != 1:
            raise ValueError(f"brdf_residuals: name the family (one of {', '.join(found) or 'none'})")
        family = next(iter(found))
    if family not in found:
        raise KeyError(f"family {family!r} has no exact BRDF grid; families with one: {', '.join(found)}")
    return found[family].brdf_grid()


def grid_axes(target: str) -> tuple[str, ...]:
    """The axis names :func:`residuals` takes for ``target`` (:attr:`fitlab.core.Target.residual_axes`)."""
    if target == BRDF:
        return _brdf_grid()[0]
    return get_target(target).residual_axes


@dataclass(frozen=True, eq=False)
class Residuals:
    """An approximation and the exact values on a tensor grid.

    axes: name -> 1-D values; the grid is their tensor product, in this order.
    inputs: every input the approximation took, as arrays of the grid's shape
        (the axes, and inputs that follow from them, e.g. kd = kd_true(c)).
    exact, approx, scale: arrays of the grid's shape; error = |approx - exact| / scale.
    fixed: axes removed by :meth:`at`, with the grid value kept.
    published: whether the approximation is a published preset, given as (form, preset).
    """

    label: str
    target: str
    axes: dict
    inputs: dict
    exact: np.ndarray
    approx: np.ndarray
    scale: np.ndarray
    error_measure: str
    fixed: dict = field(default_factory=dict)
    published: bool = False

    @property
    def shape(self) -> tuple[int, ...]:
        return self.exact.shape

    @cached_property
    def error(self) -> np.ndarray:
        """|approx - exact| / scale (inf where the approximation misses an exact zero, or is not finite)."""
        return relative_errors(self.approx, self.exact, self.scale)

    def _flat_inputs(self) -> dict:
        return {k: np.ravel(v) for k, v in self.inputs.items()}

    def summary(self) -> dict:
        """max_rel, max_rel_nonzero, rms_rel, max_abs, points and the worst point (fitlab.fit.metrics.summary)."""
        return summary(self.approx.ravel(), self.exact.ravel(), self.scale.ravel(), self._flat_inputs())

    def worst(self, n: int = 10) -> list[dict]:
        """The ``n`` points of largest error, largest first: inputs, exact, approx, error."""
        flat = self._flat_inputs()
        order = np.argsort(-self.error.ravel(), kind="stable")[:n]
        exact, approx, err = self.exact.ravel(), self.approx.ravel(), self.error.ravel()
        return [
            {**{k: float(v[i]) for k, v in flat.items()}, "exact": float(exact[i]), "approx": float(approx[i]),
             "error": float(err[i])}
            for i in order
        ]  # fmt: skip

    def table(self, n: int = 10) -> str:
        """:meth:`worst` as aligned text, with the label and error measure on top."""
        rows = self.worst(n)
        names = list(self.inputs)
        head = [*names, "exact", "approx", "error"]
        cells = [[f"{r[k]:.6g}" for k in names] + [f"{r['exact']:.8g}", f"{r['approx']:.8g}", f"{r['error']:.3e}"]
                 for r in rows]  # fmt: skip
        widths = [max(len(h), *(len(c[j]) for c in cells)) if cells else len(h) for j, h in enumerate(head)]
        measure = self.error_measure.split(":")[0]
        lines = [f"{self.label}: {len(rows)} worst of {self.exact.size} points ({measure})"]
        if self.fixed:
            lines[0] += "; at " + ", ".join(f"{k} = {v:.6g}" for k, v in self.fixed.items())
        lines.append("  ".join(h.rjust(w) for h, w in zip(head, widths)))
        lines += ["  ".join(c.rjust(w) for c, w in zip(row, widths)) for row in cells]
        return "\n".join(lines)

    def at(self, **values) -> Residuals:
        """The slice at the grid value nearest to each ``name=value`` (those axes are removed)."""
        res = self
        for name, value in values.items():
            names = list(res.axes)
            if name not in names:
                raise KeyError(f"{name!r} is not an axis of this grid; axes: {', '.join(names) or 'none'}")
            k = names.index(name)
            i = int(np.argmin(np.abs(res.axes[name] - float(value))))

            def take(a, k=k, i=i):
                return np.take(a, i, axis=k)

            res = replace(
                res,
                axes={n: a for n, a in res.axes.items() if n != name},
                inputs={n: take(a) for n, a in res.inputs.items()},
                exact=take(res.exact), approx=take(res.approx), scale=take(res.scale),
                fixed={**res.fixed, name: float(res.axes[name][i])},
            )  # fmt: skip
        return res


def _key(axes: dict) -> tuple:
    return tuple((name, tuple(float(x) for x in values)) for name, values in axes.items())


def _check_axes(target: str, axes: dict) -> dict:
    want = grid_axes(target)
    if set(axes) != set(want):
        raise ValueError(f"{target} takes the axes {', '.join(want)}; got {', '.join(axes) or 'none'}")
    out = {}
    for name in want:  # the target's order, whatever the order of the keywords
        a = np.asarray(axes[name], dtype=float)
        if a.ndim != 1 or a.size == 0:
            raise ValueError(f"axis {name} must be a non-empty 1-D array")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"axis {name} must be finite")
        out[name] = a
    return out


def _readonly(d: dict) -> dict:
    for a in d.values():
        a.flags.writeable = False
    return d


@lru_cache(maxsize=32)
def _exact(target: str, key: tuple) -> tuple[dict, dict]:
    """(arrays on the grid: inputs and y, aux) of ``target`` on the grid ``key``, from the target's
    ``exact_grid`` (or the family's exact BRDF for :data:`BRDF`); cached, read-only."""
    axes = {name: np.array(values) for name, values in key}
    if target == BRDF:
        grid = _brdf_grid()[1]
    else:
        grid = get_target(target).exact_grid
        if grid is None:
            raise ValueError(f"residuals: no exact values on grids for target {target!r}")
    inputs, y, aux = grid(axes)
    values = {k: np.array(v, dtype=float) for k, v in inputs.items()}
    values["y"] = np.array(y, dtype=float)
    return _readonly(values), _readonly({k: np.array(v, dtype=float) for k, v in aux.items()})


def approximations(target: str, fits_dir: Path | None = None) -> dict:
    """Every approximation of ``target`` there is, keyed by the label :func:`residuals` gives it:
    its published presets as (form, preset) ("hapke / paper"), then every fit of it saved in
    ``fits_dir`` (None: the packaged fits), loaded: TARGET.json first, then TARGET.*.json by name, whatever made them
    (``fitlab refit``, ``fitlab discover``): "hapke (H0.json)", "hapke_rational (H0.hapke_rational.json)".
    """
    t = get_target(target)
    found = {_label(p): p for p in t.published}
    for path in fit_files(fits_folder(fits_dir), target):
        fit = load(path)
        if fit.target != target:
            raise ValueError(f"{path} holds a fit of {fit.target}, not {target}: rename or remove it")
        found[_label(fit)] = fit
    return found


def _label(approx) -> str:
    if isinstance(approx, tuple):
        return f"{approx[0]} / {approx[1]}"
    if isinstance(approx, FitFunction):
        return approx.form + (f" ({approx.path.name})" if approx.path is not None else " (fit)")
    return getattr(approx, "name", None) or getattr(approx, "__name__", None) or repr(approx)


def _evaluate(target: str, approx, inputs: dict, names, shape) -> np.ndarray:
    args = [inputs[n] for n in names]
    if isinstance(approx, tuple):
        if len(approx) != 2:
            raise TypeError("a published preset is given as (form, preset), e.g. ('hapke', 'paper')")
        form, preset = approx
        out = get_form(target, form)(preset, *args)
    elif callable(approx):
        out = approx(*args)
    else:
        raise TypeError(f"approx must be callable or (form, preset), not {type(approx).__name__}")
    out = np.asarray(out, dtype=float)
    if out.shape != shape:
        out = np.broadcast_to(out, shape)
    return out.copy()


def residuals(target: str, approx, *, label: str | None = None, **axes) -> Residuals:
    """``approx`` of ``target`` against the exact values on the tensor grid of ``axes``.

    >>> r = residuals("H0", ("hapke", "paper"), mu=np.linspace(0, 1, 5), c=[0.5, 1.0])
    >>> r.shape
    (5, 2)
    """
    t = get_target(target)
    axes = _check_axes(target, axes)
    values, aux = _exact(target, _key(axes))
    inputs = {n: values[n] for n in values if n != "y"}
    exact = values["y"]
    approx_values = _evaluate(target, approx, inputs, t.inputs, exact.shape)
    flat = Dataset({k: v.ravel() for k, v in inputs.items()}, exact.ravel(), "residual grid",
                   {k: v.ravel() for k, v in aux.items()})  # fmt: skip
    scale = np.asarray(t.scale(flat), dtype=float).reshape(exact.shape)
    return Residuals(label or _label(approx), target, axes, inputs, exact, approx_values, scale, t.error_measure,
                     published=isinstance(approx, tuple))  # fmt: skip


def brdf_residuals(model, *, label: str | None = None, **axes) -> Residuals:
    """``model(*axes)`` (e.g. a RuntimeModel of (mu_i, mu_o, phi, c)) against the exact BRDF of the family
    registering one (its :class:`fitlab.core.HasBrdfGrid`: fitlab.families.lambert_sphere.exact.brdf) on the grid of
    ``axes``, relative to |exact|."""
    names, _, measure = _brdf_grid()
    axes = _check_axes(BRDF, axes)
    values, _ = _exact(BRDF, _key(axes))
    inputs = {n: values[n] for n in names}
    exact = values["y"]
    approx_values = _evaluate(BRDF, model, inputs, names, exact.shape)
    return Residuals(label or _label(model), BRDF, axes, inputs, exact, approx_values, np.abs(exact), measure)


def heatmap(res: Residuals, x: str, y: str, ax=None, vmin: float = 1e-6, vmax: float | None = None,
            cmap: str = "viridis", colorbar: bool = True):  # fmt: skip
    """Draw ``res.error`` over two axes (x across, y up) on a log colour scale; returns the QuadMesh.

    Errors below ``vmin`` (exact zeros included) are drawn at ``vmin``;
    infinite errors (a missed exact zero, a non-finite value) in magenta.
    ``res`` must have exactly the two axes x and y: slice others with ``res.at(...)``.
    """
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    if set(res.axes) != {x, y} or x == y:
        raise ValueError(
            f"a heat map needs exactly the axes {x!r} and {y!r}; this grid has {', '.join(res.axes)} "
            "(slice the others with .at(name=value))"
        )
    err = res.error if list(res.axes) == [x, y] else res.error.T  # rows along x
    finite = err[np.isfinite(err)]
    if vmax is None:
        vmax = max(float(finite.max()) if finite.size else vmin, 10 * vmin)
    shown = np.ma.masked_invalid(np.where(np.isfinite(err), np.maximum(err, vmin), np.nan))
    ax = ax if ax is not None else plt.gca()
    mesh = ax.pcolormesh(res.axes[x], res.axes[y], shown.T, shading="nearest",
                         norm=LogNorm(vmin=vmin, vmax=vmax), cmap=plt.get_cmap(cmap).with_extremes(bad="magenta"))  # fmt: skip
    ax.set_xlabel(x)
    ax.set_ylabel(y)
    worst = float(err.max())
    title = f"{res.label}\nmax {worst:.2e}"
    if res.fixed:
        title += " at " + ", ".join(f"{k} = {v:.3g}" for k, v in res.fixed.items())
    ax.set_title(title, fontsize="medium")
    if colorbar:
        ax.figure.colorbar(mesh, ax=ax, label="error")
    return mesh
