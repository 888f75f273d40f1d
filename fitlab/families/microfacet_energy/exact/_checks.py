"""Argument checks of the public functions: those of :mod:`fitlab.numerics`, shared by every family."""

from fitlab.numerics import choice, real_array, working_dtype

__all__ = ["real_array", "choice", "working_dtype"]
