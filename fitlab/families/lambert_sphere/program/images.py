r"""The family's table as engines load it (its images for ``fitlab export``; docs/tables.md).

``lambert_sphere_texture``: the one float32 texture the generated "tables, three orders" BRDF reads
(:func:`.table_export.texture`: H_0, H_1, H_2 through their remainders, the constants, kd and the true-phase
correction, in the blocks its layout lines name; node addressing, read with ``texelFetch``), as a one-channel
float OpenEXR or KTX2 file, beside the raw ``.f32`` and the C array that ``fitlab codegen --tables`` writes.  Only
float: the remainders are read to float32's precision, which half floats and 16 bits do not keep.
"""

from __future__ import annotations

import numpy as np

from fitlab.export import Image, ImageSpec
from fitlab.families.lambert_sphere.program import table_export

__all__ = ["IMAGES", "texture_image"]


def texture_image(nodes: int, tick=lambda: None) -> Image:
    """The texture of ``nodes`` nodes per axis (:data:`.table_export.NODES`) as an image."""
    tex = table_export.texture(nodes)
    tick()
    blocks = tuple(f"rows {first} to {first + count - 1}: {what}" for first, count, what in tex.blocks)
    return Image(
        "lambert_sphere_texture",
        tex.data[:, :, None],
        ("the packed texture of the Lambert-sphere tables BRDF (float32 values, as generated)",),
        (*tex.layout, *blocks),
    )


#: the tables ``fitlab export`` writes for this family
IMAGES = {
    "lambert_sphere_texture": ImageSpec(
        "the Lambert sphere's three-order texture (H_m remainders, constants, kd, true-phase correction)",
        texture_image,
        table_export.NODES,
        table_export.DEFAULT_NODES,
        steps=lambda size: 1,
        value_range=(-np.inf, np.inf),
        formats=("exr", "ktx2"),
    ),
}
