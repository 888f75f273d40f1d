r"""Symbolic regression with pysindy: new forms for fitlab's targets.

library (candidate terms) -> regression (pysindy STLSQ sweep + FROLS path on
the linearised model) -> refine (each sparse model as a Form, refitted with
optimistix, validated) -> search (the Pareto front) -> output (table, plot,
fits/ JSON).  ``fitlab discover --target H0`` runs it all.
"""

from fitlab.discover.library import HasLibraries, Library, get_libraries, get_library, libraries_of, products
from fitlab.discover.output import save, save_from_front, write_outputs
from fitlab.discover.regression import Candidate, SparseRegression
from fitlab.discover.search import Discovery, discover, pareto_front

__all__ = [
    "HasLibraries",
    "Library",
    "get_libraries",
    "get_library",
    "libraries_of",
    "products",
    "Candidate",
    "SparseRegression",
    "Discovery",
    "discover",
    "pareto_front",
    "save",
    "save_from_front",
    "write_outputs",
]
