r"""A real consumer of the generated code: Mitsuba 3 (scalar_rgb) renders spheres
with the generated Python BRDF, beside Lambert, Oren-Nayar and Chandrasekhar.

:class:`FunctionBSDF` is one small Mitsuba BSDF plugin around any function
``f(wi, wo) -> 1/sr`` of local-frame unit vectors (z the normal, both pointing
away from the surface): ``eval`` returns f cos(theta_o), ``sample`` draws
cosine-weighted directions.  The Lambert-sphere BRDF is the generated module
(``fits/generated/lambert_sphere.py``, loaded from its file: it needs only
numpy); the others are here for comparison:

* Lambert: Mitsuba's own ``diffuse`` with reflectance kd.
* Oren-Nayar (qualitative model, RTR ch. 9): f = kd/pi (A + B max(0, cos phi) sin(alpha) tan(beta)).
* Chandrasekhar's BRDF of sparse mirror spheres (isotropic scattering;
  docs/model.md, "Neighbouring models"):
  f = c H(mu_i) H(mu_o) / (4 pi (mu_i + mu_o)), H from :mod:`fitlab.families.lambert_sphere.exact`, c chosen so
  that its spherical albedo is kd.

Every material is given the same spherical albedo kd (for the Lambert sphere,
c = c_of_kd(kd) of the generated module), so differences are of shape only.
"""

from __future__ import annotations

import importlib.util
import io
from functools import lru_cache
from pathlib import Path

import numpy as np
from tqdm import tqdm

from fitlab._io import atomic_write_bytes
from fitlab.families.lambert_sphere.exact import gauss_legendre, isotropic_characteristic, solve_albedo, solve_h
from fitlab.families.lambert_sphere.forms.baselines import BASELINE_INPUTS
from fitlab.families.lambert_sphere.forms.baselines import oren_nayar as expression
from fitlab.forms.symbolic import lambdify_numpy, symbols

__all__ = ["RenderError", "load_generated", "FunctionBSDF", "render_sphere", "render_comparison", "MATERIALS",
           "chandrasekhar_albedo_c", "light_directions", "pixel_geometry", "material_function"]  # fmt: skip

MATERIALS = ("lambert_sphere", "lambert", "oren_nayar", "chandrasekhar")
OREN_NAYAR_SIGMA = 0.5  # radians of facet slope: a rough surface, as in RTR's figure


class RenderError(RuntimeError):
    pass


def _mitsuba():
    try:
        import mitsuba as mi
    except ImportError as exc:  # pragma: no cover - mitsuba is a dependency
        raise RenderError(f"mitsuba is not installed ({exc}); pip install mitsuba") from None
    if mi.variant() != "scalar_rgb":
        mi.set_variant("scalar_rgb")
    return mi


def load_generated(path: Path):
    """Import a generated Python module from its file (not via fitlab)."""
    path = Path(path)
    if not path.is_file():
        raise RenderError(f"{path}: no generated module; run `fitlab codegen --lang python` first")
    spec = importlib.util.spec_from_file_location(f"_fitlab_generated_{abs(hash(path.resolve()))}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    for name in ("brdf_local", "c_of_kd"):
        if not hasattr(module, name):
            raise RenderError(f"{path}: not a generated Lambert-sphere module (no {name})")
    return module


@lru_cache(maxsize=4)
def _oren_nayar_function(sigma: float):

    return lambdify_numpy(symbols(BASELINE_INPUTS), expression(sigma))


def oren_nayar(wi, wo, kd, sigma=OREN_NAYAR_SIGMA):
    """Qualitative Oren-Nayar BRDF (:func:`fitlab.families.lambert_sphere.forms.baselines.oren_nayar`) of local-frame unit vectors."""
    wi, wo = np.asarray(wi, float), np.asarray(wo, float)
    ring = np.sqrt((wi[..., 0] ** 2 + wi[..., 1] ** 2) * (wo[..., 0] ** 2 + wo[..., 1] ** 2))
    cos_phi = np.where(ring > 0, (wi[..., 0] * wo[..., 0] + wi[..., 1] * wo[..., 1]) / np.maximum(ring, 1e-30), 0.0)
    return _oren_nayar_function(sigma)(wi[..., 2], wo[..., 2], cos_phi, kd)


@lru_cache(maxsize=8)
def _isotropic_h_table(c: float):

    mu = np.linspace(0.0, 1.0, 1025)
    return mu, solve_h(isotropic_characteristic(c))(mu)


def chandrasekhar(wi, wo, c: float):
    """Chandrasekhar's BRDF, f = c H(mu_i) H(mu_o) / (4 pi (mu_i + mu_o)), isotropic H (exact, tabulated)."""
    mu, h = _isotropic_h_table(float(c))
    mi_, mo_ = float(wi[2]), float(wo[2])
    return c * np.interp(mi_, mu, h) * np.interp(mo_, mu, h) / (4.0 * np.pi * max(mi_ + mo_, 1e-6))


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


def _bsdf_class():
    mi = _mitsuba()

    class FunctionBSDF(mi.BSDF):
        """A Mitsuba BSDF from f(wi, wo) of local-frame unit vectors (1/sr), one-sided, diffuse lobe."""

        def __init__(self, props, function=None):
            mi.BSDF.__init__(self, props)
            self.function = function
            self.m_flags = mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide
            self.m_components = [self.m_flags]

        def _f(self, wi, wo):
            if wi.z <= 0 or wo.z <= 0:
                return 0.0
            return float(self.function(np.array([wi.x, wi.y, wi.z]), np.array([wo.x, wo.y, wo.z])))

        def sample(self, ctx, si, sample1, sample2, active=True):
            wo = mi.warp.square_to_cosine_hemisphere(sample2)
            bs = mi.BSDFSample3f()
            bs.wo = wo
            bs.pdf = mi.warp.square_to_cosine_hemisphere_pdf(wo)
            bs.eta = 1.0
            bs.sampled_type = int(mi.BSDFFlags.DiffuseReflection)
            bs.sampled_component = 0
            if si.wi.z <= 0 or bs.pdf <= 0:
                return bs, mi.Color3f(0.0)
            return bs, mi.Color3f(self._f(si.wi, wo) * np.pi)  # f cos / pdf, pdf = cos / pi

        def eval(self, ctx, si, wo, active=True):
            return mi.Color3f(self._f(si.wi, wo) * max(float(wo.z), 0.0))

        def pdf(self, ctx, si, wo, active=True):
            return mi.warp.square_to_cosine_hemisphere_pdf(wo) if si.wi.z > 0 else 0.0

        def eval_pdf(self, ctx, si, wo, active=True):
            return self.eval(ctx, si, wo, active), self.pdf(ctx, si, wo, active)

        def traverse(self, callback):
            pass

        def to_string(self):
            return "FunctionBSDF[]"

    return FunctionBSDF


def FunctionBSDF(function):  # noqa: N802 (reads as the class it builds)
    """A Mitsuba BSDF object evaluating ``function(wi, wo)``."""
    mi = _mitsuba()
    return _bsdf_class()(mi.Properties(), function)


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


def material_function(material: str, kd: float, generated):
    """(bsdf dict or None, function or None) for a material at spherical albedo kd."""
    if material == "lambert_sphere":
        c = float(generated.c_of_kd(kd))
        return lambda wi, wo: generated.brdf_local(wi, wo, c)
    if material == "oren_nayar":
        return lambda wi, wo: oren_nayar(wi, wo, kd)
    if material == "chandrasekhar":
        c = chandrasekhar_albedo_c(kd)
        return lambda wi, wo: chandrasekhar(wi, wo, c)
    if material == "lambert":
        return None
    raise ValueError(f"unknown material {material!r}; choose from {', '.join(MATERIALS)}")


def _scene(bsdf, emitter, size, spp, integrator="direct"):
    mi = _mitsuba()
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


def render_sphere(material: str, kd: float, light: np.ndarray | None, size: int, spp: int, generated=None,
                  seed: int = 0) -> np.ndarray:  # fmt: skip
    """Radiance image (size x size, one channel) of a unit sphere seen from +z
    (orthographic, frame [-1.05, 1.05]^2), lit by a directional light of unit
    irradiance toward ``light`` (a unit vector), or, with light None, by a
    white furnace (constant environment of radiance 1)."""
    mi = _mitsuba()
    if size < 1 or spp < 1:
        raise ValueError("size and spp must be positive")
    func = material_function(material, kd, generated)
    bsdf = {"type": "diffuse", "reflectance": {"type": "rgb", "value": [kd] * 3}} if func is None else FunctionBSDF(func)
    if light is None:
        emitter = {"type": "constant", "radiance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}}
    else:
        emitter = {"type": "directional", "direction": (-np.asarray(light, float)).tolist(),
                   "irradiance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}}  # fmt: skip
    scene = _scene(bsdf, emitter, size, spp, integrator="direct" if light is not None else "path")
    img = np.array(mi.render(scene, seed=seed))
    return img[..., 0]


def pixel_geometry(size: int, extent: float = 1.05):
    """Normals (size x size x 3, NaN off the sphere) at pixel centres of :func:`render_sphere`'s camera."""
    x = (np.arange(size) + 0.5) / size * 2 * extent - extent
    X, Y = np.meshgrid(x, -x)  # image columns run toward +x, rows toward -y (checked by tests/test_render.py)
    Z = np.sqrt(np.maximum(0.0, 1 - X * X - Y * Y))
    n = np.stack([X, Y, Z], axis=-1)
    n[X * X + Y * Y >= 1] = np.nan
    return n


def render_comparison(out: Path, generated: Path, kd: float = 0.8, size: int = 64, spp: int = 4, lights: int = 3,
                      show_progress: bool = True) -> Path:  # fmt: skip
    """Render every material under ``lights`` directions to one PNG (rows: materials)."""
    from matplotlib.figure import Figure  # not pyplot: rendering leaves the caller's backend alone


    if not 0.0 < kd < 1.0:
        raise ValueError("--kd must lie in (0, 1)")
    if size < 8 or spp < 1:
        raise ValueError("--size must be at least 8 and --spp at least 1")
    gen = load_generated(generated)
    dirs = light_directions(lights)
    jobs = [(m, d) for m in MATERIALS for d in dirs]
    images = {}
    for m, d in tqdm(jobs, desc="render", unit="image", disable=not show_progress):
        images[(m, tuple(d))] = render_sphere(m, kd, d, size, spp, generated=gen)
    vmax = max(float(np.nanmax(im)) for im in images.values())
    fig = Figure(figsize=(2.2 * len(dirs), 2.2 * len(MATERIALS)))
    axes = fig.subplots(len(MATERIALS), len(dirs), squeeze=False)
    for i, m in enumerate(MATERIALS):
        for j, d in enumerate(dirs):
            ax = axes[i, j]
            ax.imshow(images[(m, tuple(d))] / vmax, cmap="gray", vmin=0, vmax=1)
            ax.set_xticks([]), ax.set_yticks([])
            if j == 0:
                ax.set_ylabel(m.replace("_", " "))
            if i == 0:
                ax.set_title(f"phase {np.degrees(np.arccos(d[2])):.0f} deg", fontsize=9)
    fig.suptitle(f"spherical albedo kd = {kd} for every material; one exposure for all", fontsize=9)
    fig.tight_layout()

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    atomic_write_bytes(Path(out), buf.getvalue())
    return Path(out)
