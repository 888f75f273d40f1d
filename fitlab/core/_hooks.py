r"""The family hooks' contracts (issue 32, item 3): what each hook returns, as a :class:`typing.Protocol`, and
the check of a service against its protocol when the hook is resolved (:func:`fitlab.core.family_service`,
:func:`fitlab.core.resolve_hook`), with a one-line TypeError naming the family, the hook and the first missing
member.

A hook is a zero-argument callable of :attr:`fitlab.core.Family.hooks`; what it returns (a module, most often)
is the service.  The ``simulate`` hook's protocol is :class:`fitlab.scenes.SimulateHook` (checked by
:func:`fitlab.scenes.check_simulate_hook`); the others are here:

========================  ======================================================================
hook                      protocol
========================  ======================================================================
``tables``                :class:`TablesHook`
``audit``                 :class:`AuditHook`
``render``                :class:`RenderHook`
``bench``                 :class:`BenchHook` (at least one of its members)
``report``                :class:`ReportHook`; the family whose whole BRDF the report measures (its
                          service has ``exact_brdf``) also :class:`BrdfReportHook`
``table_export``          :class:`TableExportHook`
``brdf_grid``             :class:`BrdfGridHook` (:class:`BrdfGrid` is one)
``images``                :class:`ImagesHook`
========================  ======================================================================
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple, Protocol, runtime_checkable

__all__ = ["Outputs", "TablesHook", "AuditHook", "RenderHook", "BenchHook", "ReportHook", "BrdfReportHook",
           "TableExportHook", "ImagesHook", "BrdfGridHook", "BrdfGrid", "ModelContract", "ProgramContract",
           "missing_member", "check_hook", "BENCHES"]  # fmt: skip


def _members(protocol) -> list[str]:
    names = list(getattr(protocol, "__annotations__", {}))
    names += [n for n, v in vars(protocol).items() if callable(v) and not n.startswith("_") and n not in names]
    return names


def missing_member(obj, protocol) -> str | None:
    """The first member of ``protocol`` that ``obj`` lacks (a method must be callable), else None."""
    for name in _members(protocol):
        if not hasattr(obj, name):
            return name
        if callable(vars(protocol).get(name)) and not callable(getattr(obj, name)):
            return name
    return None


def _fail(family: str, hook: str, member: str, protocol) -> TypeError:
    return TypeError(f"family {family}: its {hook} hook lacks {member!r} (fitlab.core.{protocol.__name__})")


@runtime_checkable
class TablesHook(Protocol):
    """``tables`` (``fitlab tabulate``): the family's exact tables, written and checked."""

    #: the family's folder under --data
    FAMILY_NAME: str
    #: the files of that folder
    TABLE_FILES: Sequence[str]

    def write_tables(self, out: Path, show_progress: bool = True) -> Mapping[str, str]:
        """Write every table into ``out``; {file name: sha256}."""
        ...

    def check_tables(self, folder: Path, show_progress: bool = True) -> list:
        """The tables of ``folder`` checked against the exact engine: the failures (empty: all pass)."""
        ...


class Outputs(NamedTuple):
    """What a hook computed, for the caller to write: ``summary`` (JSON-ready data the command prints) and
    ``files`` (file name -> bytes), written by the command that called the hook, all or nothing."""

    summary: Any
    files: Mapping[str, bytes]


@runtime_checkable
class AuditHook(Protocol):
    """``audit`` (``fitlab audit``)."""

    def audit(self, fits_dir: Path | None = None, show_progress: bool = True) -> Outputs:
        """The audit of the fits in ``fits_dir`` (None: the packaged fits): its summary and its files (the
        caller writes them)."""
        ...


@runtime_checkable
class RenderHook(Protocol):
    """``render`` (``fitlab render``): a scene rendered with the generated BRDF and the exact one."""

    #: what a failed render raises (one line)
    RenderError: type

    def check_generated(self, generated: Path) -> None:
        """Refuse (RenderError) a module that is not a generated BRDF."""
        ...

    def llvm_problem(self) -> str | None:
        """Why the LLVM variant does not run here, or None."""
        ...

    def render_comparison(self, **options) -> bytes:
        """The comparison rendered, as a PNG's bytes (the caller writes them)."""
        ...


#: the members a ``bench`` service may have (``fitlab bench WHAT`` calls ``bench_WHAT``)
BENCHES = ("bench_exact", "bench_codegen", "bench_mc", "bench_render")


class BenchHook(Protocol):
    """``bench`` (``fitlab bench``): at least one of :data:`BENCHES`, each a callable."""

    bench_exact: Callable
    bench_codegen: Callable
    bench_mc: Callable
    bench_render: Callable


@runtime_checkable
class ReportHook(Protocol):
    """``report`` (``fitlab report``): the family's methods in the report's catalogue
    (:mod:`fitlab.report.methods`)."""

    #: targets whose default fit the family's BRDF-level methods need
    REQUIRED_FITS: Sequence[str]
    #: targets measured at part level
    PARTS: Sequence[str]
    #: name -> the published runtime presets' parts
    PRESET_VARIANTS: Mapping[str, Any]

    def tables_dir(self, data_dir: Path | None = None) -> Path: ...

    def brdf_methods(self, *args, **kwargs) -> list: ...

    def part_extras(self, *args, **kwargs) -> list: ...

    def preset_records(self, variant: str) -> dict: ...

    def check_tables(self, folder: Path) -> None: ...


@runtime_checkable
class BrdfReportHook(ReportHook, Protocol):
    """The ``report`` hook of the family whose whole BRDF the report measures (its service has
    ``exact_brdf``): the BRDF's signature and material, the report's family settings, the measurements of
    the family's own engines and report.md's words on them."""

    #: the BRDF's inputs, in the order every method's ``evaluate`` takes them: the incident and outgoing
    #: cosines, the azimuth, the material, and the material's second parameter (0 where a method ignores it)
    BRDF_INPUTS: Sequence[str]
    #: the inputs that name a point of the validation set (the second parameter follows from the material)
    BRDF_POINT: Sequence[str]
    #: the material's inputs: all 0 is the black material, whose BRDF is exactly 0
    BRDF_MATERIAL: Sequence[str]
    #: the BRDF's name in report.md's title and the plot's
    BRDF_TITLE: str
    #: report.md's sentences on the material ("material": how the second parameter is set; "black": what the
    #: black material's column measures) and on the parts ("parts": what they are measured on)
    REPORT_TEXT: Mapping[str, str]
    #: the family's settings of the report, by the generic settings' name ("full", "quick")
    REPORT_SETTINGS: Mapping[str, Any]
    SOURCES: Mapping[str, str]
    EXACT_SOURCES: Mapping[str, str]

    def exact_brdf(self, *args, **kwargs) -> Any: ...

    def exact_kd(self, *args, **kwargs) -> Any: ...

    def exact_albedo(self, *args, **kwargs) -> Any: ...

    def directional_albedo(self, *args, **kwargs) -> Any: ...

    def validation_materials(self, *args, **kwargs) -> Any:
        """``validation_materials(family_settings)`` -> (values, what they are): the materials of the validation
        and grazing sets (the Lambert sphere's albedos c)."""
        ...

    def fresh_materials(self, *args, **kwargs) -> Any:
        """``fresh_materials(rng, family_settings)`` -> (values, what they are): the independent set's materials,
        the first draws of its generator."""
        ...

    def energy_materials(self, *args, **kwargs) -> Any:
        """``energy_materials(family_settings)`` -> (values, what they are): where the energy is checked."""
        ...

    def measure_engines(self, *args, **kwargs) -> Any:
        """``measure_engines(settings, family_settings, inputs, progress)`` -> (rows, context): the family's own
        engines (exact, Monte Carlo) measured, as the report's rows and the context its sections read; ``inputs``
        the numpy timing inputs by name; ``progress.stage(name, steps)`` and ``progress.tick()`` show the stages."""
        ...

    def timing_inputs(self, *args, **kwargs) -> Any:
        """Seeded random inputs by argument name, ``timing_inputs(n, data_dir)``: what the timings evaluate."""
        ...

    def baseline_program(self, *args, **kwargs) -> Any:
        """The program of the baselines whose C the report times beside the family's."""
        ...

    def engine_sections(self, *args, **kwargs) -> Any:
        """report.md's sections on the family's own engines (exact, Monte Carlo): markdown lines, from the report."""
        ...


@runtime_checkable
class TableExportHook(Protocol):
    """``table_export`` (``fitlab codegen --tables``): the exact tables as a texture and the program that reads
    it (:mod:`fitlab.codegen.texture`)."""

    LANGUAGES: Sequence[str]
    NODES: Sequence[int]
    DEFAULT_NODES: int
    DEFAULT_LOOKUP: str
    #: the steps :meth:`generate` ticks
    GENERATE_STEPS: int

    def generate(self, lang: str, nodes: int, lookup: str, tick=None) -> Mapping[str, bytes]:
        """{file name: bytes}."""
        ...

    def check_tables(self, folder: Path) -> None: ...

    def tables_dir(self, data_dir: Path | None = None) -> Path: ...


@runtime_checkable
class ImagesHook(Protocol):
    """``images`` (``fitlab export``): the family's tables as image files engines load (:mod:`fitlab.export`)."""

    #: table name -> :class:`fitlab.export.ImageSpec`
    IMAGES: Mapping[str, Any]


@runtime_checkable
class BrdfGridHook(Protocol):
    """``brdf_grid`` (:func:`fitlab.residuals.brdf_residuals`): the exact BRDF on residual grids."""

    #: the grid's axes, in order
    axes: tuple[str, ...]
    #: ``exact_grid(axes) -> (inputs, y, aux)``, like :attr:`fitlab.core.Target.exact_grid`
    exact_grid: Callable
    #: the error measure, in words
    measure: str


class BrdfGrid(NamedTuple):
    """A :class:`BrdfGridHook` (a tuple: ``axes, exact_grid, measure = hook()``)."""

    axes: tuple[str, ...]
    exact_grid: Callable
    measure: str


class ModelContract(Protocol):
    """What :meth:`ProgramContract.model` gives (:class:`fitlab.codegen.Model`): a named choice of fits."""

    name: str
    forms: Mapping[str, str]
    description: str
    folder: str
    physics: str | None


@runtime_checkable
class ProgramContract(Protocol):
    """What :attr:`fitlab.core.Family.codegen` is: a program the code generator prints
    (:class:`fitlab.codegen.ProgramSpec` is the one implementation), or None."""

    name: str
    fits: tuple[str, ...]
    parts: tuple[str, ...]
    terms: tuple[str, ...]
    optional: tuple[str, ...]
    #: the cancellation-free rewrites of its routines (``sympy.codegen.rewriting`` optimisations)
    rewrites: tuple

    def model(self, name: str | None = None) -> ModelContract: ...

    def model_names(self) -> tuple[str, ...]: ...

    def rewrite(self, expr): ...


_PROTOCOLS = {"tables": TablesHook, "audit": AuditHook, "render": RenderHook, "report": ReportHook,
              "table_export": TableExportHook, "images": ImagesHook, "brdf_grid": BrdfGridHook}  # fmt: skip


def check_hook(service, family: str = "?", hook: str = "?"):
    """``service`` (what ``family``'s hook ``hook`` returned) when it meets the hook's protocol; else TypeError,
    one line naming the family, the hook and the first missing member.  A hook without a protocol here passes."""
    if hook == "bench":
        if not any(callable(getattr(service, b, None)) for b in BENCHES):
            raise TypeError(
                f"family {family}: its bench hook lacks every one of {', '.join(map(repr, BENCHES))} "
                "(fitlab.core.BenchHook)"
            )
        return service
    protocol = _PROTOCOLS.get(hook)
    if protocol is None:
        return service
    name = missing_member(service, protocol)
    if name:
        raise _fail(family, hook, name, protocol)
    if hook == "report" and hasattr(service, "exact_brdf"):
        name = missing_member(service, BrdfReportHook)
        if name:
            raise _fail(family, hook, name, BrdfReportHook)
    return service


def check_program(codegen, family: str = "?"):
    """``codegen`` (a family's :attr:`~fitlab.core.Family.codegen`) when it is None or meets
    :class:`ProgramContract`; else TypeError, one line naming the family and the missing member."""
    if codegen is None:
        return codegen
    name = missing_member(codegen, ProgramContract)
    if name:
        raise TypeError(
            f"family {family}: its codegen lacks {name!r} (fitlab.core.ProgramContract: a fitlab.codegen.ProgramSpec)"
        )
    return codegen
