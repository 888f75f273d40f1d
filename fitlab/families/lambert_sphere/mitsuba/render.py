r"""A real consumer of the generated code: Mitsuba 3 renders spheres with the registered ``lambert_sphere``
plugin (:mod:`.plugin`, the generated Dr.Jit module), beside Lambert, Oren-Nayar and Chandrasekhar.

Every material is vectorised with Dr.Jit, so that a render runs in ``llvm_ad_rgb`` (one kernel for the whole
image) where Dr.Jit's LLVM backend works, and in ``scalar_rgb`` otherwise (:func:`resolve_variant`):

* Lambert sphere: the plugin, ``{"type": "lambert_sphere", "reflectance": kd}``.
* Lambert: Mitsuba's own ``diffuse`` with reflectance kd.
* Oren-Nayar (qualitative model, RTR ch. 9): f = kd/pi (A + B max(0, cos phi) sin(alpha) tan(beta)), printed
  in Dr.Jit from its sympy expression (:mod:`fitlab.families.lambert_sphere.forms.baselines`).
* Chandrasekhar's BRDF of sparse mirror spheres (isotropic scattering; docs/model.md, "Neighbouring models"):
  f = c H(mu_i) H(mu_o) / (4 pi (mu_i + mu_o)), H from :mod:`fitlab.families.lambert_sphere.exact` on a table
  (linear interpolation), c chosen so that its spherical albedo is kd.

The last two are :func:`function_bsdf` objects: f(wi, wo) of local-frame vectors, cosine-weighted sampling.
Every material is given the same spherical albedo kd, so differences are of shape only.
"""

from __future__ import annotations

import io
import subprocess
import sys
import types
from functools import lru_cache
from pathlib import Path

import numpy as np
from tqdm import tqdm

from fitlab._io import import_generated
from fitlab.families.lambert_sphere.exact import gauss_legendre, isotropic_characteristic, solve_albedo, solve_h
from fitlab.families.lambert_sphere.mitsuba.plugin import PluginError, load_drjit_module, register

__all__ = ["RenderError", "load_generated", "check_generated", "function_bsdf", "sphere_scene", "render_bsdf", "render_sphere",
           "render_comparison", "resolve_variant", "llvm_problem", "use_variant", "MATERIALS", "chandrasekhar_albedo_c",
           "light_directions", "pixel_geometry", "material_function", "oren_nayar"]  # fmt: skip

MATERIALS = ("lambert_sphere", "lambert", "oren_nayar", "chandrasekhar")
OREN_NAYAR_SIGMA = 0.5  # radians of facet slope: a rough surface, as in RTR's figure


class RenderError(RuntimeError):
    pass


def load_generated(path: Path):
    """Import a generated Python (numpy) module from its file (not via fitlab)."""
    path = Path(path)
    if not path.is_file():
        raise RenderError(f"{path}: no generated module; run `fitlab codegen --lang python` first")
    module = import_generated(path)
    for name in ("brdf_local", "c_of_kd"):
        if not hasattr(module, name):
            raise RenderError(f"{path}: not a generated Lambert-sphere module (no {name})")
    return module


def check_generated(path: Path) -> None:
    """Refuse (RenderError, one line) a file that is not a generated Lambert-sphere Dr.Jit module (what the
    renderer's plugin runs; ``fitlab codegen --lang drjit``)."""
    try:
        load_drjit_module(path)
    except PluginError as exc:
        raise RenderError(str(exc)) from None


# -- the variant -----------------------------------------------------------------------------------------
_PROBE = ("import mitsuba as mi, drjit as dr; mi.set_variant('llvm_ad_rgb'); "
          "x = dr.maximum(mi.Float([1.0, 2.0]), mi.Float([1.5, 0.5])); dr.eval(x); print(x)")  # fmt: skip


@lru_cache(maxsize=1)
def llvm_problem() -> str | None:
    """None when Mitsuba's llvm_ad_rgb variant runs a kernel here, else why not (one line).  Tried in a
    subprocess: Dr.Jit loads the system's libLLVM, and one too old to compile its code aborts the process
    (tools/install-system-packages.sh installs a recent one)."""
    try:
        done = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True, timeout=300)
    except subprocess.TimeoutExpired:
        return "a test kernel in llvm_ad_rgb did not finish in 300 s"
    if done.returncode == 0:
        return None
    lines = done.stderr.strip().splitlines() or [f"exit status {done.returncode}"]
    return lines[-1]


def resolve_variant(variant: str = "auto") -> str:
    """The Mitsuba variant to render in: ``variant`` (a Mitsuba variant's name), or for "auto" llvm_ad_rgb when
    :func:`llvm_problem` finds none, else scalar_rgb."""
    if variant == "auto":
        return "llvm_ad_rgb" if llvm_problem() is None else "scalar_rgb"
    return variant


def use_variant(variant: str | None = None, generated: Path | None = None):
    """(mitsuba, drjit) with ``variant`` set (None: the current one, else scalar_rgb) and the ``lambert_sphere``
    plugin registered there, running the generated Dr.Jit module ``generated`` (None: the packaged one)."""
    try:
        import drjit as dr
        import mitsuba as mi
    except ImportError as exc:  # pragma: no cover - mitsuba is a dependency
        raise RenderError(f"mitsuba is not installed ({exc}); pip install mitsuba") from None
    variant = variant or mi.variant() or "scalar_rgb"
    if mi.variant() != variant:
        mi.set_variant(variant)
    key = (variant, str(Path(generated).resolve()) if generated is not None else None)
    if key not in _REGISTERED:
        try:
            register(generated)
        except PluginError as exc:
            raise RenderError(str(exc)) from None
        _REGISTERED.add(key)
    return mi, dr


_REGISTERED: set = set()


# -- the comparison materials, vectorised ----------------------------------------------------------------
def _cos_phi(wi, wo, dr):
    """cos of the azimuth between local-frame vectors (0 where either is along the normal)."""
    ring = dr.sqrt((wi[0] * wi[0] + wi[1] * wi[1]) * (wo[0] * wo[0] + wo[1] * wo[1]))
    return dr.select(ring > 0, (wi[0] * wo[0] + wi[1] * wo[1]) / dr.maximum(ring, 1e-30), 0.0)


@lru_cache(maxsize=1)
def _baselines():
    """The baselines' routines (Lambert, Oren-Nayar at sigma = 0.5) printed as Dr.Jit functions from their sympy
    expressions by the code generator (:mod:`..program.baselines`, as :mod:`..program.bench` prints them in C)."""
    from fitlab.codegen import emit
    from fitlab.families.lambert_sphere.program.baselines import baseline_program

    program = baseline_program()
    ((name, text),) = emit(program, "drjit").items()
    module = types.ModuleType(f"_fitlab_{Path(name).stem}")
    exec(compile(text, f"<fitlab codegen --lang drjit: {name}>", "exec"), module.__dict__)  # our own printed code
    return module


def oren_nayar(wi, wo, kd):
    """Qualitative Oren-Nayar BRDF (sigma = 0.5; :func:`fitlab.families.lambert_sphere.forms.baselines.oren_nayar`)
    of local-frame unit vectors: Dr.Jit arrays, or sequences of Python floats."""
    import drjit as dr

    return _baselines().baseline_oren_nayar(wi[2], wo[2], _cos_phi(wi, wo, dr), kd)


@lru_cache(maxsize=8)
def _isotropic_h_table(c: float):

    mu = np.linspace(0.0, 1.0, 1025)
    return mu, solve_h(isotropic_characteristic(c))(mu)


def _chandrasekhar_kd(c: float) -> float:
    mu, h = _isotropic_h_table(float(c))

    x, w = gauss_legendre(64)
    hx = np.interp(x, mu, h)
    f = c * hx[:, None] * hx[None, :] / (4 * np.pi * (x[:, None] + x[None, :]))
    return float(2.0 * np.pi * 2.0 * np.einsum("i,j,ij,i,j->", w, w, f, x, x))


@lru_cache(maxsize=16)
def chandrasekhar_albedo_c(kd: float) -> float:
    """The single-scattering albedo c whose Chandrasekhar BRDF has spherical albedo kd
    (:func:`fitlab.families.lambert_sphere.exact.solve_albedo`)."""

    if not 0.0 < kd < 1.0:
        raise ValueError("kd must lie in (0, 1)")
    return solve_albedo(_chandrasekhar_kd, kd, 1e-9, 1.0 - 1e-12, xtol=1e-12)


def _chandrasekhar(c: float, mi, dr):
    """f(wi, wo) = c H(mu_i) H(mu_o) / (4 pi (mu_i + mu_o)), H linearly interpolated on its table (Dr.Jit arrays:
    a gather from the table; Python floats: numpy)."""
    mu, h = _isotropic_h_table(float(c))
    n = len(mu)
    table = None if mi.variant().startswith("scalar") else mi.Float(h)

    def h_of(x):
        if table is None:
            return float(np.interp(x, mu, h))
        t = dr.clip(x, 0.0, 1.0) * (n - 1)
        i = mi.UInt32(dr.minimum(dr.floor(t), n - 2))
        return dr.lerp(dr.gather(mi.Float, table, i), dr.gather(mi.Float, table, i + 1), t - mi.Float(i))

    return lambda wi, wo: c * h_of(wi[2]) * h_of(wo[2]) / (4.0 * np.pi * dr.maximum(wi[2] + wo[2], 1e-6))


def function_bsdf(function, mi=None, dr=None):
    """A Mitsuba BSDF object (of the current variant) evaluating ``function(wi, wo)`` (1/sr, grey) of local-frame
    Dr.Jit vectors or Python floats: one-sided, a diffuse lobe, cosine-weighted sampling."""
    if mi is None:
        mi, dr = use_variant()
    flags = mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide

    class FunctionBSDF(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            self.m_flags = flags
            self.m_components = [flags]

        def _value(self, si, wo, active):
            ok = active & (mi.Frame3f.cos_theta(si.wi) > 0) & (mi.Frame3f.cos_theta(wo) > 0)
            return dr.select(ok, mi.Spectrum(function(si.wi, wo) * mi.Frame3f.cos_theta(wo)), 0.0)

        def _pdf(self, si, wo, active):
            ok = active & (mi.Frame3f.cos_theta(si.wi) > 0)
            return dr.select(ok, mi.warp.square_to_cosine_hemisphere_pdf(wo), 0.0)

        def sample(self, ctx, si, sample1, sample2, active=True):
            bs = dr.zeros(mi.BSDFSample3f)
            bs.wo = mi.warp.square_to_cosine_hemisphere(sample2)
            bs.pdf = self._pdf(si, bs.wo, active)
            bs.eta = 1.0
            bs.sampled_type = mi.UInt32(+mi.BSDFFlags.DiffuseReflection)
            bs.sampled_component = mi.UInt32(0)
            ok = bs.pdf > 0
            return bs, dr.select(ok, self._value(si, bs.wo, active) / dr.select(ok, bs.pdf, 1.0), 0.0)

        def eval(self, ctx, si, wo, active=True):
            return self._value(si, wo, active)

        def pdf(self, ctx, si, wo, active=True):
            return self._pdf(si, wo, active)

        def eval_pdf(self, ctx, si, wo, active=True):
            return self._value(si, wo, active), self._pdf(si, wo, active)

        def traverse(self, callback):
            pass

        def to_string(self):
            return "FunctionBSDF[]"

    return FunctionBSDF(mi.Properties())


def material_function(material: str, kd: float, mi=None, dr=None):
    """The BSDF (a dict for :func:`mitsuba.load_dict`, or a :func:`function_bsdf` object) of a material at
    spherical albedo kd, in the current variant."""
    if material == "lambert_sphere":
        return {"type": "lambert_sphere", "reflectance": {"type": "rgb", "value": [kd] * 3}}
    if material == "lambert":
        return {"type": "diffuse", "reflectance": {"type": "rgb", "value": [kd] * 3}}
    if mi is None:
        mi, dr = use_variant()
    if material == "oren_nayar":
        return function_bsdf(lambda wi, wo: oren_nayar(wi, wo, kd), mi, dr)
    if material == "chandrasekhar":
        return function_bsdf(_chandrasekhar(chandrasekhar_albedo_c(kd), mi, dr), mi, dr)
    raise ValueError(f"unknown material {material!r}; choose from {', '.join(MATERIALS)}")


def light_directions(n: int) -> list[np.ndarray]:
    """Unit vectors toward the light: from behind the viewer (phase 0) round to grazing side light."""
    if not 1 <= n <= 5:
        raise ValueError("lights must be between 1 and 5")
    angles = np.radians([0.0, 45.0, 90.0, 135.0, 30.0][:n])
    out = []
    for k, a in enumerate(angles):
        tilt = np.radians(20.0) if k == 4 else 0.0
        d = np.array([np.sin(a) * np.cos(tilt), np.sin(tilt), np.cos(a) * np.cos(tilt)])
        out.append(d / np.linalg.norm(d))
    return out


def sphere_scene(bsdf, light, size, spp, mi=None):
    """A unit sphere seen from +z (orthographic, frame [-1.05, 1.05]^2, box filter), lit by a directional light
    of unit irradiance toward ``light`` (direct illumination), or with light None by a white furnace (a
    constant environment of radiance 1; path tracing), in the current variant."""
    if mi is None:
        mi, _ = use_variant()
    if light is None:
        emitter, integrator = {"type": "constant", "radiance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}}, "path"
    else:
        emitter = {"type": "directional", "direction": (-np.asarray(light, float)).tolist(),
                   "irradiance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}}  # fmt: skip
        integrator = "direct"
    return mi.load_dict({
        "type": "scene",
        "integrator": {"type": integrator},
        "sensor": {
            "type": "orthographic",
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 5], target=[0, 0, 0], up=[0, 1, 0])
            @ mi.ScalarTransform4f().scale([1.05, 1.05, 1.0]),
            "film": {"type": "hdrfilm", "width": size, "height": size, "rfilter": {"type": "box"},
                     "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "sphere": {"type": "sphere", "bsdf": bsdf},
        "light": emitter,
    })  # fmt: skip


def render_bsdf(bsdf, light: np.ndarray | None, size: int, spp: int, seed: int = 0, variant: str | None = None,
                generated: Path | None = None) -> np.ndarray:  # fmt: skip
    """RGB radiance image (size x size x 3) of a unit sphere of ``bsdf`` (a dict for :func:`mitsuba.load_dict`
    or a BSDF object) seen from +z (orthographic, frame [-1.05, 1.05]^2), lit by a directional light of unit
    irradiance toward ``light`` (a unit vector), or, with light None, by a white furnace (constant environment
    of radiance 1).  ``variant``: the Mitsuba variant (None: the current one, else scalar_rgb), where the
    ``lambert_sphere`` plugin evaluates the generated Dr.Jit module ``generated`` (None: the packaged one)."""
    if size < 1 or spp < 1:
        raise ValueError("size and spp must be positive")
    mi, _ = use_variant(variant, generated)
    return np.array(mi.render(sphere_scene(bsdf, light, size, spp, mi), seed=seed))


def render_sphere(material: str, kd: float, light: np.ndarray | None, size: int, spp: int, seed: int = 0,
                  variant: str | None = None, generated: Path | None = None) -> np.ndarray:  # fmt: skip
    """One channel (size x size) of :func:`render_bsdf` for one of :data:`MATERIALS` at spherical albedo kd."""
    mi, dr = use_variant(variant, generated)
    return render_bsdf(material_function(material, kd, mi, dr), light, size, spp, seed, variant, generated)[..., 0]


def pixel_geometry(size: int, extent: float = 1.05):
    """Normals (size x size x 3, NaN off the sphere) at pixel centres of :func:`render_sphere`'s camera."""
    x = (np.arange(size) + 0.5) / size * 2 * extent - extent
    X, Y = np.meshgrid(x, -x)  # image columns run toward +x, rows toward -y (checked by tests/test_mitsuba_plugin.py)
    Z = np.sqrt(np.maximum(0.0, 1 - X * X - Y * Y))
    n = np.stack([X, Y, Z], axis=-1)
    n[X * X + Y * Y >= 1] = np.nan
    return n


def render_comparison(generated: Path | None = None, kd: float = 0.8, size: int = 64, spp: int = 4,
                      lights: int = 3, show_progress: bool = True, variant: str = "auto") -> bytes:  # fmt: skip
    """Every material rendered under ``lights`` directions, as one PNG's bytes (rows: materials; the caller
    writes them), in ``variant`` (:func:`resolve_variant`), the plugin running the generated Dr.Jit module
    ``generated``."""
    from matplotlib.figure import Figure  # not pyplot: rendering leaves the caller's backend alone

    if not 0.0 < kd < 1.0:
        raise ValueError("--kd must lie in (0, 1)")
    if size < 8 or spp < 1:
        raise ValueError("--size must be at least 8 and --spp at least 1")
    check_generated(generated)
    variant = resolve_variant(variant)
    dirs = light_directions(lights)
    jobs = [(m, d) for m in MATERIALS for d in dirs]
    images = {}
    for m, d in tqdm(jobs, desc=f"render ({variant})", unit="image", disable=not show_progress):
        images[(m, tuple(d))] = render_sphere(m, kd, d, size, spp, variant=variant, generated=generated)
    vmax = max(float(np.nanmax(im)) for im in images.values())
    fig = Figure(figsize=(2.2 * len(dirs), 2.2 * len(MATERIALS)))
    axes = fig.subplots(len(MATERIALS), len(dirs), squeeze=False)
    for i, m in enumerate(MATERIALS):
        for j, d in enumerate(dirs):
            ax = axes[i, j]
            ax.imshow(images[(m, tuple(d))] / vmax, cmap="gray", vmin=0, vmax=1)
            ax.set_xticks([])
            ax.set_yticks([])
            if j == 0:
                ax.set_ylabel(m.replace("_", " "))
            if i == 0:
                ax.set_title(f"phase {np.degrees(np.arccos(d[2])):.0f} deg", fontsize=9)
    fig.suptitle(f"spherical albedo kd = {kd} for every material; one exposure for all (Mitsuba {variant})", fontsize=9)
    fig.tight_layout()

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    return buf.getvalue()
