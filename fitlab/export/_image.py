"""What an exported table is (:class:`Image`) and how a family offers one (:class:`ImageSpec`)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Image", "ImageSpec", "texel_centres", "CHANNEL_NAMES", "ORIGINS"]

#: the channel names image files give channels 0, 1, 2, 3 (what engines bind as .r .g .b .a)
CHANNEL_NAMES = ("R", "G", "B", "A")
#: where the table's row 0 lies in the picture: "top", the first row stored, or "bottom", the last
ORIGINS = ("top", "bottom")


def texel_centres(n: int, lo: float = 0.0, hi: float = 1.0) -> np.ndarray:
    """The coordinates of ``n`` texels covering [lo, hi] at their centres: lo + (hi - lo) (i + 1/2) / n, the
    addressing of a texture sampled with normalised coordinates (a bilinear fetch at u reads texel u n - 1/2)."""
    return lo + (hi - lo) * (np.arange(n) + 0.5) / n


@dataclass(frozen=True)
class Image:
    """A table as an engine loads it: ``data`` (height, width, channels), float64, finite.

    name: the file stem.  channels: one line per channel saying what it holds (channel k is image channel
    :data:`CHANNEL_NAMES` [k]).  layout: lines that say how the texels are addressed (axes, texel centres or
    nodes, what the values are); every format writes them with the channels, the size and the colour space
    (linear: the values are data, never gamma-encoded) where it can (:mod:`fitlab.export._formats`).
    origin: where the table's row 0 (the row j = 0 of the layout lines) is stored: "top", the first row of the
    file, which image formats show at the top; or "bottom", the last (``data`` is then the table's rows in
    reverse: row k of ``data`` is the table's row height - 1 - k).  :meth:`with_origin` turns one into the other.
    """

    name: str
    data: np.ndarray
    channels: tuple[str, ...]
    layout: tuple[str, ...]
    origin: str = "top"

    def __post_init__(self):
        if self.origin not in ORIGINS:
            raise ValueError(f"origin must be one of {', '.join(ORIGINS)}, not {self.origin!r}")
        data = np.array(self.data, dtype=np.float64)
        if data.ndim != 3 or not 1 <= data.shape[2] <= len(CHANNEL_NAMES):
            raise ValueError(f"an image is (height, width, 1 to 4 channels), not {data.shape}")
        if data.shape[2] != len(self.channels):
            raise ValueError(f"{data.shape[2]} channels, described by {len(self.channels)} lines")
        if not np.all(np.isfinite(data)):
            raise ValueError(f"image {self.name}: a value is not finite")
        data.setflags(write=False)
        object.__setattr__(self, "data", data)

    @property
    def height(self) -> int:
        return self.data.shape[0]

    @property
    def width(self) -> int:
        return self.data.shape[1]

    def with_origin(self, origin: str) -> Image:
        """The same table stored with its row 0 at ``origin`` (:data:`ORIGINS`): the rows reversed if it moves."""
        if origin not in ORIGINS:
            raise ValueError(f"origin must be one of {', '.join(ORIGINS)}, not {origin!r}")
        if origin == self.origin:
            return self
        return Image(self.name, self.data[::-1], self.channels, self.layout, origin)

    def table_rows(self) -> np.ndarray:
        """The data with the table's row 0 first, whatever the origin."""
        return self.data if self.origin == "top" else self.data[::-1]

    def description(self) -> list[str]:
        """The lines every file states: name, size, row order, colour space, channels, then the layout."""
        if self.origin == "top":
            order = (
                "origin top: the table's row 0 is the first row stored, the top of the picture, and its row j "
                "is stored as row j"
            )
        else:
            order = (
                f"origin bottom: the table's row 0 is the last row stored, the bottom of the picture, and its "
                f"row j is stored as row {self.height - 1} - j (the rows named below are the table's)"
            )
        lines = [
            f"fitlab table {self.name}: {self.width} x {self.height} texels (width x height), "
            f"{len(self.channels)} channel(s)",
            order,
            "colour space: linear (the values are data, not gamma-encoded)",
        ]
        lines += [f"channel {CHANNEL_NAMES[k]}: {text}" for k, text in enumerate(self.channels)]
        return lines + list(self.layout)


@dataclass(frozen=True)
class ImageSpec:
    """A table a family offers to ``fitlab export``.

    build(size, tick) -> :class:`Image`, ``tick()`` called :attr:`steps` (size) times; sizes: the sizes it takes
    (``size`` texels per axis, or per the axis the spec says); formats: the formats that hold its precision
    (a subset of :data:`fitlab.export.FORMATS`); value_range: (lo, hi) every value lies in, which decides
    whether a normalised format (16-bit PNG: [0, 1]) can hold it, before any work.
    """

    description: str
    build: Callable[..., Image]
    sizes: Sequence[int]
    default_size: int
    steps: Callable[[int], int]
    value_range: tuple[float, float] = (0.0, 1.0)
    formats: tuple[str, ...] = field(default=("exr", "exr-half", "ktx2", "ktx2-half", "png", "c", "glsl"))
