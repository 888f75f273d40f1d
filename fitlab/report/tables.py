r"""The tables of data/ with interpolation: moved to the family that owns the tables,
:mod:`fitlab.families.lambert_sphere.interpolation`; these names remain here for old imports."""

from fitlab.families.lambert_sphere.interpolation import (
    c_of_kd_interpolant,
    constant_interpolant,
    h_interpolant,
    kd_interpolant,
    table_brdf,
)

__all__ = ["h_interpolant", "constant_interpolant", "kd_interpolant", "c_of_kd_interpolant", "table_brdf"]
