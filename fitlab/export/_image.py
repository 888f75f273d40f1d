"""What an exported table is (:class:`Image`) and how a family offers one (:class:`ImageSpec`)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Image", "ImageSpec", "texel_centres", "CHANNEL_NAMES"]

#: the channel names image files give channels 0, 1, 2, 3 (what engines bind as .r .g .b .a)
CHANNEL_NAMES = ("R", "G", "B", "A")


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
    Row 0 is the first row of the file.
    """

    name: str
    data: np.ndarray
    channels: tuple[str, ...]
    layout: tuple[str, ...]

    def __post_init__(self):
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

    def description(self) -> list[str]:
        """The lines every file states: name, size, channels, colour space, then the layout."""
        lines = [f"fitlab table {self.name}: {self.width} x {self.height} texels (width x height), "
                 f"{len(self.channels)} channel(s), row 0 first",
                 "colour space: linear (the values are data, not gamma-encoded)"]
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
    formats: tuple[str, ...] = field(default=("exr", "exr-half", "png", "c", "glsl"))
