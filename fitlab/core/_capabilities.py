r"""The capabilities of a family, each with its service's type, but for those whose services are of the
generic packages that use the registry, declared beside their types (an import of the registry's package from
here would be a circle): :class:`fitlab.codegen.program.HasProgram`, :class:`fitlab.discover.library.HasLibraries`
and :class:`fitlab.report.methods.HasReport`.  A service is most often a module, checked against its protocol
by basedpyright where the family's method returns it.  A protocol's constants are read-only properties (a
module's tuple meets ``Sequence[str]``); a method's leading arguments are positional-only, its options
keyword-only, as the generic commands call them.
"""

from __future__ import annotations

import abc
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple, Protocol

import numpy as np

from fitlab.core._family import Capability

if TYPE_CHECKING:  # packages that import nothing of fitlab.core
    from fitlab.export import ImageSpec
    from fitlab.scenes import Simulation

__all__ = ["Outputs", "Tables", "HasTables", "HasAudit", "Render", "HasRender", "Benchmarks",
           "HasBenchmarks", "TableExport", "HasTableExport", "BrdfGrid", "HasBrdfGrid", "MeasuredMaterial",
           "HasMaterials", "HasMonteCarlo", "HasImages"]  # fmt: skip


class Outputs(NamedTuple):
    """What a service computed, for the caller to write: ``summary`` (JSON-ready data the command prints) and
    ``files`` (file name -> bytes), written by the command, all or nothing."""

    summary: Any
    files: Mapping[str, bytes]


class Tables(Protocol):
    """The family's exact tables, written and checked (``fitlab tabulate``)."""

    @property
    def FAMILY_NAME(self) -> str:
        """The family's folder under the data folder."""
        ...

    @property
    def TABLE_FILES(self) -> Collection[str]:
        """The files of that folder."""
        ...

    def write_tables(self, out: Path, /, *, show_progress: bool = True) -> Mapping[str, str]:
        """Write every table into ``out``, all or nothing; {file name: sha256}."""
        ...

    def check_tables(self, folder: Path, /, *, show_progress: bool = True) -> Sequence[str]:
        """The tables of ``folder`` checked against the exact engine: the failures, one line each."""
        ...


class HasTables(Capability):
    noun = "tables"

    @abc.abstractmethod
    def tables(self) -> Tables: ...


class HasAudit(Capability):
    noun = "audit"

    @abc.abstractmethod
    def audit(self, fits_dir: Path | None = None, *, show_progress: bool = False) -> Outputs:
        """The audit of the fits in ``fits_dir`` (None: the packaged fits) against the exact BRDF (``fitlab
        audit``): its summary and its files."""


class Render(Protocol):
    """A scene rendered with the generated BRDF and the exact one (``fitlab render``)."""

    @property
    def RenderError(self) -> type[Exception]:
        """What a failed render raises (one line)."""
        ...

    def check_generated(self, generated: Path, /) -> None:
        """Refuse (:attr:`RenderError`) a module that is not a generated BRDF."""
        ...

    def llvm_problem(self) -> str | None:
        """Why the LLVM variant does not run here, or None."""
        ...

    def render_comparison(self, *, generated: Path | None = None, kd: float = 0.8, size: int = 64, spp: int = 4,
                          lights: int = 3, show_progress: bool = True, variant: str = "auto") -> bytes:  # fmt: skip
        """The comparison rendered, as a PNG's bytes (the caller writes them)."""
        ...


class HasRender(Capability):
    noun = "render"

    @abc.abstractmethod
    def render(self) -> Render: ...


class QuickBench(Protocol):
    def __call__(self, *, quick: bool = False) -> Mapping[str, Any]: ...


class CodegenBench(Protocol):
    def __call__(self, fits_dir: Path | None = None, /, *, n: int = 1_000_000,
                 repeat: int = 5) -> Mapping[str, Any]: ...  # fmt: skip


class RenderBench(Protocol):
    def __call__(self, *, quick: bool = False, show_progress: bool = True) -> Mapping[str, Any]: ...


@dataclass(frozen=True)
class Benchmarks:
    """The family's benchmarks (``fitlab bench WHAT``), None where it has no such benchmark: the exact engine's
    speed and agreement between its methods, the generated code against a baseline, the Monte Carlo's
    throughput, a render's samples per second.  Each returns its results (JSON-ready)."""

    exact: QuickBench | None = None
    codegen: CodegenBench | None = None
    mc: QuickBench | None = None
    render: RenderBench | None = None


class HasBenchmarks(Capability):
    noun = "benchmarks"

    @abc.abstractmethod
    def benchmarks(self) -> Benchmarks: ...


class TableExport(Protocol):
    """The exact tables as a texture and the program that reads it (``fitlab codegen --tables``,
    :mod:`fitlab.codegen.texture`)."""

    @property
    def LANGUAGES(self) -> Sequence[str]: ...

    @property
    def NODES(self) -> Sequence[int]: ...

    @property
    def DEFAULT_NODES(self) -> int: ...

    @property
    def DEFAULT_LOOKUP(self) -> str: ...

    @property
    def GENERATE_STEPS(self) -> int:
        """The steps :meth:`generate` ticks."""
        ...

    def generate(self, lang: str, nodes: int, lookup: str, /, *,
                 tick: Callable[[], object] | None = None) -> Mapping[str, bytes]:  # fmt: skip
        """{file name: bytes}."""
        ...

    def check_tables(self, folder: Path, /) -> None:
        """Refuse (:class:`fitlab.store.TableError`) tables that cannot be exported."""
        ...

    def tables_dir(self, data_dir: Path | None = None, /) -> Path:
        """Where the family reads its tables."""
        ...


class HasTableExport(Capability):
    noun = "table export"

    @abc.abstractmethod
    def table_export(self) -> TableExport: ...


class BrdfGrid(NamedTuple):
    """The exact BRDF on residual grids (:func:`fitlab.residuals.brdf_residuals`)."""

    #: the grid's axes, in order
    axes: tuple[str, ...]
    #: ``exact_grid(axes) -> (inputs, y, aux)``, like :attr:`fitlab.core.Target.exact_grid`
    exact_grid: Callable[[Mapping[str, np.ndarray]], tuple]
    #: the error measure, in words
    measure: str


class HasBrdfGrid(Capability):
    noun = "exact BRDF grid"

    @abc.abstractmethod
    def brdf_grid(self) -> BrdfGrid: ...


@dataclass(frozen=True)
class MeasuredMaterial:
    """A measured material's reflectance, per linear sRGB channel: at normal incidence (``F0``) and its
    hemispherical average ``F_avg`` = 2 int_0^1 F(mu) mu dmu (exact)."""

    name: str
    kind: str  #: "conductor" or "dielectric"
    F0: np.ndarray
    F_avg: np.ndarray


class HasMaterials(Capability):
    noun = "measured materials"

    @abc.abstractmethod
    def materials(self) -> Mapping[str, MeasuredMaterial]:
        """{key: the material}."""


class HasMonteCarlo(Capability):
    noun = "Monte Carlo"

    @abc.abstractmethod
    def simulation(self) -> Simulation:
        """The family's scene schema and walk (``fitlab simulate``, :mod:`fitlab.scenes`)."""


class HasImages(Capability):
    noun = "images"

    @abc.abstractmethod
    def images(self) -> Mapping[str, ImageSpec]:
        """Table name -> the table as image files engines load (``fitlab export``, :mod:`fitlab.export`)."""
