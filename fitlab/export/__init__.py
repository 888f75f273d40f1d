r"""Tables as the image files engines load (``fitlab export``): a family's :class:`ImageSpec` builds an
:class:`Image` (float64 texels, what each channel holds, how it is addressed, where its row 0 is stored), and
:func:`encode` writes it as OpenEXR (float or half), KTX 2.0 (float or half), 16-bit PNG, a C header or GLSL
constants (:data:`FORMATS`), each file stating its layout where the format has room for it.  :func:`tolerance` is
what each format keeps of a value: what a reader of the file must find.  Families offer their tables through
the :class:`fitlab.core.HasImages` capability; docs/tables.md describes every table and format.
"""

from fitlab.export._formats import EXTRA, FORMATS, PNG_LEVELS, encode, file_name, tolerance
from fitlab.export._image import CHANNEL_NAMES, ORIGINS, Image, ImageSpec, texel_centres

__all__ = [
    "Image",
    "ImageSpec",
    "texel_centres",
    "CHANNEL_NAMES",
    "ORIGINS",
    "FORMATS",
    "EXTRA",
    "PNG_LEVELS",
    "encode",
    "file_name",
    "tolerance",
]
