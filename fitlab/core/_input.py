"""An input of a target: its name, its domain and its meaning, defined once."""

from __future__ import annotations

import math
from dataclasses import dataclass

import sympy as sp

__all__ = ["Input"]


@dataclass(frozen=True)
class Input:
    """One input variable: the same definition gives the sympy symbol and the numeric domain.

    name: the identifier forms, fit files and generated code use.
    domain: closed interval (lo, hi) on which the exact values, fits and claims hold.
    description: the meaning in words.
    """

    name: str
    domain: tuple[float, float]
    description: str = ""

    def __post_init__(self):
        if not self.name.isidentifier():
            raise ValueError(f"input name {self.name!r} is not an identifier")
        lo, hi = (float(x) for x in self.domain)
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise ValueError(f"input {self.name}: domain {self.domain} is not a finite interval lo < hi")
        object.__setattr__(self, "domain", (lo, hi))

    @property
    def symbol(self) -> sp.Symbol:
        return sp.Symbol(self.name, real=True)
