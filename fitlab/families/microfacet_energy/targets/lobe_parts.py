"""The lobe-parameter targets' names and parts: which targets each lobe model has, in the order of its shape's
parameters (:mod:`.lobes` defines the targets; the program builds its lobes from them, :mod:`..program.runtime`)."""

from __future__ import annotations

__all__ = ["ENERGY_SCALE", "BLOG_PARTS", "TILT_PARTS", "target_name", "lobe_target_names"]

#: the tilted lobe's scale is not the per-lobe fit's but the energy-matching one (:func:`.lobes.energy_scales`)
ENERGY_SCALE = "energy_scale"

#: (parameter, table column, error measure, what, with order) of the blog's final lobe and of the tilted lobe
BLOG_PARTS = (
    ("eta", "blog_eta", "absolute", "exponent eta", False),
    ("flattening", "blog_sigma_n", "relative", "normal flattening sigma_n", False),
    ("scale", "blog_scale", "relative", "scale sigma (with the order-2 lobe's shape)", True),
)
TILT_PARTS = (
    ("sigma", ENERGY_SCALE, "relative", "scale sigma (the one that gives the fitted shape the simulated albedo)", True),
    ("eta", "tilt_eta", "absolute", "exponent eta", True),
    ("flattening", "tilt_sigma_n", "relative", "normal flattening sigma_n", True),
    ("b", "tilt_b", "absolute", "azimuthal tilt b (< 0: towards the mirror side)", True),
    ("k", "tilt_k", "absolute", "azimuthal narrowing k", True),
)


def target_name(model: str, param: str, kind: str) -> str:
    """``ms_{model}_{param}_{kind}``, model "blog" or "tilt"."""
    return f"ms_{model}_{param}_{kind}"


def lobe_target_names(model: str, kind: str) -> tuple[str, ...]:
    """The targets of ``model`` ("blog" or "tilt") and ``kind``, in the order of the shape's parameters."""
    parts = BLOG_PARTS if model == "blog" else TILT_PARTS
    return tuple(target_name(model, p[0], kind) for p in parts)
