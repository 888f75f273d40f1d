"""``fitlab export``: write the families' tables as the image files engines load (OpenEXR, KTX2, 16-bit PNG, a C
header, GLSL constants), each stating its layout and row order (docs/tables.md)."""

from __future__ import annotations

from fitlab.cli._common import (
    RunFailure,
    UsageError,
    add_quiet,
    describe,
    integer,
    output_folder,
    require_extra,
    write_files,
)

__all__ = ["add_arguments", "run", "listing_text"]


def add_arguments(p) -> None:
    from fitlab.export import FORMATS, ORIGINS

    describe(p, "Write tables as the files engines load: the split-sum DFG tables of GGX (Karis's and Filament's "
                "channels), the albedo tables E, 1 - E, E_avg of each microfacet model, the Lambert sphere's "
                "texture, the Fresnel presets; as OpenEXR or KTX2 (float or half), 16-bit PNG, a C header or GLSL "
                "constants, every file written as one unit with its layout stated inside (axes, addressing, "
                "channels, row order, linear). --list shows the tables, their sizes and formats.",
             "fitlab export dfg_karis dfg_filament --format exr --format png --size 64 --out tables")  # fmt: skip
    p.add_argument("tables", nargs="*", metavar="TABLE", help="the tables to write (--list names them)")
    p.add_argument("--list", action="store_true", help="list the tables, their sizes and formats, and stop")
    p.add_argument(
        "--format",
        action="append",
        choices=list(FORMATS),
        default=None,
        dest="formats",
        help="a file format, repeatable (default: exr)",
    )
    p.add_argument(
        "--size",
        type=integer(1),
        default=None,
        help="texels a side (a DFG or albedo table) or nodes per axis (the Lambert sphere's texture); "
        "default: each table's own",
    )
    p.add_argument(
        "--origin",
        choices=ORIGINS,
        default="top",
        help="where the table's row 0 (its smallest y: roughness, alpha, the first material) is stored: "
        "top, the first row of every file, the top of the picture (default); or bottom, the last "
        "row, the rows stored in reverse (Filament's baked DFG images; loaders that put an "
        "image's bottom row at t = 0). docs/tables.md gives the shader line for each",
    )
    p.add_argument("--out", default=None, help="the folder the files go to")
    add_quiet(p)


def _offered() -> dict:
    """table name -> (family, ImageSpec), over every family that is a :class:`fitlab.core.HasImages`."""
    from fitlab.core import HasImages, offering

    found = {}
    for family, having in offering(HasImages).items():
        for name, spec in having.images().items():
            found[name] = (family, spec)
    return found


def _sizes_text(sizes) -> str:
    sizes = list(sizes)
    contiguous = sizes == list(range(sizes[0], sizes[-1] + 1))
    return f"{sizes[0]} to {sizes[-1]}" if contiguous and len(sizes) > 5 else ", ".join(map(str, sizes))


def listing_text() -> str:
    """What ``fitlab export --list`` prints: every table, its family, sizes, formats and description (the families'
    images, imported; cached by fitlab's code, :func:`fitlab.cache.cached_text`)."""
    return "".join(
        f"{name:24s} {family:18s} size {spec.default_size} ({_sizes_text(spec.sizes)}); "
        f"{', '.join(spec.formats)}; {spec.description}\n"
        for name, (family, spec) in _offered().items()
    )


def _check(args, offered: dict) -> tuple[list, list]:
    """Every refusal before any work: (tables [(name, spec, size)], formats)."""
    if not args.tables:
        raise UsageError("name at least one table (fitlab export --list shows them)")
    formats = list(dict.fromkeys(args.formats or ["exr"]))
    chosen = []
    for name in dict.fromkeys(args.tables):
        if name not in offered:
            from fitlab.core import did_you_mean

            raise UsageError(f"no table {name!r}{did_you_mean(name, offered, '--list names them')}")
        _, spec = offered[name]
        size = spec.default_size if args.size is None else args.size
        if size not in spec.sizes:
            raise UsageError(f"--size {size}: {name} takes {_sizes_text(spec.sizes)}")
        for fmt in formats:
            if fmt not in spec.formats:
                raise UsageError(f"{name} is not written as {fmt} ({', '.join(spec.formats)} keep its values)")
        chosen.append((name, spec, size))
    from fitlab.export import EXTRA

    for fmt in formats:
        if fmt in EXTRA:
            require_extra(*EXTRA[fmt])
    return chosen, formats


#: a build projected to take longer than this (seconds) is named in a warning on stderr
SLOW_EXPORT_SECONDS = 60.0


def _paced(bar, total: int, what: str):
    """The ``tick`` of the builds: it moves ``bar`` and, once two steps are done, projects the whole build from
    the pace of the steps after the first (which also compiles), saying in one warning line on stderr, once, when
    it will take longer than :data:`SLOW_EXPORT_SECONDS`."""
    import sys
    import time

    from fitlab._montecarlo import duration

    stamps: list[float] = []
    start = time.monotonic()
    said = False

    def tick() -> None:
        nonlocal said
        bar.update(1)
        stamps.append(time.monotonic())
        if said or len(stamps) < 2:
            return
        pace = (stamps[-1] - stamps[0]) / (len(stamps) - 1)
        projected = stamps[-1] - start + pace * max(0, total - len(stamps))
        if projected > SLOW_EXPORT_SECONDS:
            bar.write(
                f"fitlab export: warning: {what} will take about {duration(projected)} ({total} steps, "
                f"{pace:.2g} s each so far); Ctrl-C stops it with nothing written",
                file=sys.stderr,
            )
            said = True

    return tick


def run(args) -> int:
    if args.list:
        from fitlab.cache import cached_text

        print(cached_text("listing-export", listing_text), end="")
        return 0
    chosen, formats = _check(args, _offered())
    from fitlab.export import encode, file_name

    names = [file_name(name, fmt) for name, _, _ in chosen for fmt in formats]
    out = output_folder(args.out, "--out", files=names)
    from tqdm import tqdm

    files = {}
    total = sum(spec.steps(size) for _, spec, size in chosen)
    with tqdm(total=total, desc="tables", unit="step", disable=args.quiet) as bar:
        tick = _paced(bar, total, ", ".join(f"{name} at size {size}" for name, _, size in chosen))
        for name, spec, size in chosen:
            try:
                image = spec.build(size, tick=tick).with_origin(args.origin)
                for fmt in formats:
                    files[file_name(name, fmt)] = encode(image, fmt)
            except (ArithmeticError, ValueError) as exc:
                raise RunFailure(f"table {name} could not be written: {exc}") from None
    return write_files(args, out, files)
