r"""The Lambert-sphere BRDF as a registered Mitsuba 3 plugin, ``lambert_sphere``, vectorised with Dr.Jit.

::

    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")          # or scalar_rgb, cuda_ad_rgb, *_spectral, *_mono
    from fitlab.families.lambert_sphere.mitsuba.plugin import register
    register()                             # the plugin "lambert_sphere" in the current variant
    bsdf = mi.load_dict({"type": "lambert_sphere", "reflectance": {"type": "rgb", "value": [0.8, 0.5, 0.2]}})

or in XML, ``<bsdf type="lambert_sphere"><rgb name="reflectance" value="0.8, 0.5, 0.2"/></bsdf>`` (a
``<texture type="bitmap" name="reflectance">`` as well).  Parameters (one of the two, a texture or a
number or a colour, as Mitsuba's ``diffuse`` takes ``reflectance``):

* ``reflectance``: the spherical (Bond) albedo kd of the material in [0, 1], per channel, default 0.5 (what
  Mitsuba's ``diffuse`` calls its reflectance: the two have the same albedo under uniform light); the
  particle albedo of each channel is c = c_of_kd(kd) (docs/model.md, "kd");
* ``albedo``: the particle albedo c itself, per channel (a researcher's parameter).

Details: docs/mitsuba.md, section ``fitlab.families.lambert_sphere.mitsuba.plugin``."""

from __future__ import annotations

import types
from pathlib import Path

from fitlab._io import import_generated
from fitlab.resources import packaged_fits

__all__ = [
    "register",
    "load_drjit_module",
    "bsdf_class",
    "PluginError",
    "PLUGIN",
    "DRJIT_FILE",
    "REQUIRED",
    "PARAMETERS",
]

#: the name the plugin is registered under
PLUGIN = "lambert_sphere"

#: the generated Dr.Jit module's file name (``fitlab codegen --lang drjit``)
DRJIT_FILE = "lambert_sphere_drjit.py"

#: what the plugin calls in the generated module
REQUIRED = ("c_of_kd", "kd_of_c", "prepare", "prepare_c", "eval_local", "pdf", "sample")

#: the parameters, one of which may be given: (name, what it is)
PARAMETERS = {"reflectance": "the spherical albedo kd", "albedo": "the particle albedo c"}


class PluginError(RuntimeError):
    """The plugin cannot be registered or loaded (one line: what and why)."""


def load_drjit_module(path: Path | None = None):
    """The generated Dr.Jit module at ``path`` (default: the packaged one), imported from its file; it must
    define every name in :data:`REQUIRED`."""
    path = Path(path) if path is not None else packaged_fits() / "generated" / DRJIT_FILE
    if not path.is_file():
        raise PluginError(f"{path}: no generated Dr.Jit module; run `fitlab codegen --lang drjit` first")
    module = import_generated(path, "_fitlab_drjit")
    missing = [n for n in REQUIRED if not hasattr(module, n)]
    if missing:
        raise PluginError(f"{path}: not a generated Lambert-sphere Dr.Jit module (no {', '.join(missing)})")
    drjit = getattr(module, "dr", None)
    if not isinstance(drjit, types.ModuleType) or drjit.__name__ != "drjit":
        raise PluginError(
            f"{path}: not a generated Dr.Jit module (it does not compute with drjit; "
            "`fitlab codegen --lang drjit` makes one)"
        )
    return module


def _mitsuba():
    try:
        import drjit as dr
        import mitsuba as mi
    except ImportError as exc:  # pragma: no cover - mitsuba is the render extra
        raise PluginError(f"mitsuba is not installed ({exc}); pip install 'fitlab-brdf[render]'") from None
    if mi.variant() is None:
        raise PluginError("no Mitsuba variant is set: call mi.set_variant(...) before registering the plugin")
    if mi.is_polarized:
        raise PluginError(f"the {PLUGIN} plugin has no polarized form; use an unpolarized variant, not {mi.variant()}")
    return mi, dr


def bsdf_class(generated=None):
    """The BSDF class of the current Mitsuba variant, evaluating the generated Dr.Jit module ``generated``
    (a module from :func:`load_drjit_module`; default: the packaged one)."""
    mi, dr = _mitsuba()
    gen = generated if generated is not None else load_drjit_module()
    flags = mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide

    class LambertSphereBSDF(mi.BSDF):
        """The Lambert-sphere BRDF (d'Eon, EGSR 2021), fitlab's runtime model; see docs/mitsuba.md."""

        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            given = [name for name in PARAMETERS if name in props]
            if len(given) > 1:
                either = " or ".join(f"{name} ({what})" for name, what in PARAMETERS.items())
                raise ValueError(f"{PLUGIN}: give {either}, not both")
            self.parameter = given[0] if given else "reflectance"
            self.texture = props.get_texture(self.parameter, 0.5)
            self.m_flags = flags
            self.m_components = [flags]
            self.parameters_changed([])

        # -- the per-material set-up -------------------------------------------------------------------
        def parameters_changed(self, keys):
            """A uniform parameter is prepared here, once; a texture at every lookup (:meth:`materials`), and
            so is every parameter in the spectral variants (an RGB value is a spectrum, evaluated at each
            path's wavelengths)."""
            self.uniform = None
            if not self.texture.is_spatially_varying() and not mi.is_spectral:
                value = self.texture.eval(dr.zeros(mi.SurfaceInteraction3f))
                self.uniform = self._prepare(value)
                dr.make_opaque(self.uniform)

        def _prepare(self, value):
            """(material per channel, material of the sampler, kd) of a parameter value (a Spectrum)."""
            if self.parameter == "reflectance":
                kd = value
                return gen.prepare(kd), gen.prepare(dr.mean(kd)), kd
            return gen.prepare_c(value), gen.prepare_c(dr.mean(value)), gen.kd_of_c(value)

        def materials(self, si, active=True):
            """(material per channel, material of the sampler, kd) at the shading point ``si``."""
            if self.uniform is not None:
                return self.uniform
            return self._prepare(self.texture.eval(si, active))

        # -- the BSDF interface ------------------------------------------------------------------------
        def eval(self, ctx, si, wo, active=True):
            if not ctx.is_enabled(mi.BSDFFlags.DiffuseReflection):
                return dr.zeros(mi.Spectrum)
            material = self.materials(si, active)[0]
            ok = active & (mi.Frame3f.cos_theta(si.wi) > 0) & (mi.Frame3f.cos_theta(wo) > 0)
            value = gen.eval_local(material, si.wi, wo) * mi.Frame3f.cos_theta(wo)
            return dr.select(ok, mi.Spectrum(value), 0.0)

        def pdf(self, ctx, si, wo, active=True):
            if not ctx.is_enabled(mi.BSDFFlags.DiffuseReflection):
                return dr.zeros(mi.Float)
            sampler = self.materials(si, active)[1]
            ok = active & (mi.Frame3f.cos_theta(si.wi) > 0) & (mi.Frame3f.cos_theta(wo) > 0)
            return dr.select(ok, gen.pdf(sampler, si.wi, wo), 0.0)

        def eval_pdf(self, ctx, si, wo, active=True):
            if not ctx.is_enabled(mi.BSDFFlags.DiffuseReflection):
                return dr.zeros(mi.Spectrum), dr.zeros(mi.Float)
            material, sampler, _ = self.materials(si, active)
            ok = active & (mi.Frame3f.cos_theta(si.wi) > 0) & (mi.Frame3f.cos_theta(wo) > 0)
            value = gen.eval_local(material, si.wi, wo) * mi.Frame3f.cos_theta(wo)
            return dr.select(ok, mi.Spectrum(value), 0.0), dr.select(ok, gen.pdf(sampler, si.wi, wo), 0.0)

        def sample(self, ctx, si, sample1, sample2, active=True):
            bs = dr.zeros(mi.BSDFSample3f)
            if not ctx.is_enabled(mi.BSDFFlags.DiffuseReflection):
                return bs, dr.zeros(mi.Spectrum)
            material, sampler, _ = self.materials(si, active)
            wo, pdf = gen.sample(sampler, si.wi, sample2[0], sample2[1])
            ok = active & (mi.Frame3f.cos_theta(si.wi) > 0) & (pdf > 0)
            bs.wo = wo
            bs.pdf = dr.select(ok, pdf, 0.0)
            bs.eta = 1.0
            bs.sampled_type = mi.UInt32(+mi.BSDFFlags.DiffuseReflection)
            bs.sampled_component = mi.UInt32(0)
            # f cos / p; a lost sample (p = 0: drawn below the surface) weighs 0
            weight = gen.eval_local(material, si.wi, wo) * (mi.Frame3f.cos_theta(wo) / dr.select(ok, pdf, 1.0))
            return bs, dr.select(ok, mi.Spectrum(weight), 0.0)

        def eval_diffuse_reflectance(self, si, active=True):
            return mi.Spectrum(self.materials(si, active)[2])

        def traverse(self, callback):
            put = callback.put if hasattr(callback, "put") else callback.put_object  # Mitsuba < 3.7
            put(self.parameter, self.texture, mi.ParamFlags.Differentiable)

        def to_string(self):
            return (f"LambertSphereBSDF[\n  {self.parameter} = {self.texture},\n  sampler = the particle albedo "
                    f"of the mean {self.parameter}\n]")  # fmt: skip

    return LambertSphereBSDF


def register(generated: Path | None = None):
    """Register the plugin :data:`PLUGIN` in the current Mitsuba variant (call it again after
    ``mi.set_variant``), evaluating the generated Dr.Jit module at ``generated`` (default: the packaged one,
    :func:`load_drjit_module`).  Returns the BSDF class."""
    mi, _ = _mitsuba()
    cls = bsdf_class(load_drjit_module(generated))
    mi.register_bsdf(PLUGIN, lambda props: cls(props))
    return cls
