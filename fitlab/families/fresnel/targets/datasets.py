r"""The exact values the Fresnel targets are fitted to and validated on: F_c(mu) of one material and channel.

F is smooth in theta = arccos(mu) over the whole hemisphere, and what the approximations get wrong sits
at grazing (Schlick's missing dip near 80 degrees, the rise to 1 at 90): both sets are spaced evenly in
theta, which puts as many points between 60 and 90 degrees (mu < 1/2) as between 0 and 30.

* training: theta_j = (pi/2) j/64, j = 0..64 (65 points; mu = 1 and mu = 0 exactly at the ends);
* validation: the 1024 midpoints theta = (pi/2)(j + 1/2)/1024, with mu = 0, mu = 1 and mu = 1/7 (the
  angle of Hoffman's F82, where F82-tint is exact by construction) added: 1027 points, none of them a
  training point but the two ends.  Between validation points F and every approximation change by less
  than 3e-7 (their derivative in theta is at most 2), so the maximum of the error on the set is its
  maximum over the hemisphere to that.
"""

from __future__ import annotations

from functools import cache

import numpy as np

from fitlab.core import Dataset
from fitlab.families.fresnel.exact import CHANNELS, reflectance

__all__ = ["training", "validation", "grid", "TRAINING_GRID", "VALIDATION_GRID", "MU_BAR"]

#: Hoffman's angle of the F82 tint: mu = 1/7, theta = 81.79 degrees
MU_BAR = 1.0 / 7.0
TRAINING_GRID = "theta = (pi/2) j/64, j = 0..64 (mu = cos theta; mu = 0 at j = 64)"
VALIDATION_GRID = "theta = (pi/2)(j + 1/2)/1024, j = 0..1023, and mu = 0, 1/7, 1"


def _cosines_of(theta: np.ndarray) -> np.ndarray:
    mu = np.cos(theta)
    mu[theta == np.pi / 2] = 0.0  # cos(pi/2) rounds to 6e-17
    return np.clip(mu, 0.0, 1.0)


@cache
def _values(material: str, which: str) -> tuple[np.ndarray, np.ndarray]:
    if which == "training":
        mu = _cosines_of(np.pi / 2 * np.arange(65) / 64)
    else:
        mu = np.concatenate(([0.0, MU_BAR, 1.0], _cosines_of(np.pi / 2 * (np.arange(1024) + 0.5) / 1024)))
    f = reflectance(material, mu)
    for a in (mu, f):
        a.setflags(write=False)
    return mu, f


def _dataset(material: str, channel: str, which: str) -> Dataset:
    mu, f = _values(material, which)
    grid = TRAINING_GRID if which == "training" else VALIDATION_GRID
    return Dataset({"mu": mu.copy()}, f[:, CHANNELS.index(channel)].copy(), grid)


def training(material: str, channel: str) -> Dataset:
    return _dataset(material, channel, "training")


def validation(material: str, channel: str) -> Dataset:
    return _dataset(material, channel, "validation")


def grid(material: str, channel: str):
    """exact_grid of the target: ``axes`` {"mu": 1-D array} -> (inputs, F, None)."""

    def exact(axes):
        mu = np.asarray(axes["mu"], dtype=float)
        return {"mu": mu}, reflectance(material, mu)[..., CHANNELS.index(channel)], None

    return exact
