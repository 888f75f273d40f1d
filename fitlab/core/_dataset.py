"""A dataset: points (inputs by name) and the exact values there."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np

__all__ = ["Dataset", "data_hash"]


@dataclass(frozen=True, eq=False)
class Dataset:
    """Points (inputs by name, flat arrays of one length) and exact values y."""

    inputs: dict
    y: np.ndarray
    grid: str
    aux: dict | None = None  # other exact quantities at the same points (e.g. a scale)

    def __len__(self) -> int:
        return int(self.y.size)

    def select(self, mask) -> Dataset:
        aux = None if self.aux is None else {k: v[mask] for k, v in self.aux.items()}
        return Dataset({k: v[mask] for k, v in self.inputs.items()}, self.y[mask], self.grid, aux)

    def restricted(self, domain: dict) -> Dataset:
        """The points whose inputs lie in ``domain`` ({name: (lo, hi)}), edges included."""
        mask = np.ones(len(self), dtype=bool)
        for name, (lo, hi) in domain.items():
            if name in self.inputs:
                mask &= (self.inputs[name] >= lo) & (self.inputs[name] <= hi)
        return self.select(mask)

    def digest(self, h) -> None:
        for name in sorted(self.inputs):
            h.update(name.encode())
            h.update(np.ascontiguousarray(self.inputs[name], dtype="<f8").tobytes())
        h.update(np.ascontiguousarray(self.y, dtype="<f8").tobytes())
        aux = self.aux or {}
        for name in sorted(aux):
            h.update(name.encode())
            h.update(np.ascontiguousarray(aux[name], dtype="<f8").tobytes())


def data_hash(*datasets: Dataset) -> str:
    h = hashlib.sha256()
    for d in datasets:
        d.digest(h)
    return h.hexdigest()
