"""``fitlab render``: spheres rendered in Mitsuba 3 with the registered ``lambert_sphere`` plugin (the generated
Dr.Jit code), beside Lambert, Oren-Nayar and Chandrasekhar (Mitsuba is imported by the renderer, when :func:`run`
renders)."""

from __future__ import annotations

from fitlab._io import atomic_write_bytes
from fitlab.cli._common import (
    RunFailure,
    UsageError,
    add_family,
    add_quiet,
    describe,
    family_with,
    input_file,
    integer,
    number,
    one_line,
    output_folder,
    require_extra,
    say,
    write_failure,
)
from fitlab.resources import packaged_fits

__all__ = ["add_arguments", "run", "FILE", "VARIANTS"]

#: what the render writes into --out
FILE = "render.png"
#: the Mitsuba variants --variant takes
VARIANTS = ("auto", "scalar_rgb", "llvm_ad_rgb")


def add_arguments(p) -> None:
    describe(p, "Render spheres in Mitsuba 3 with the registered lambert_sphere plugin (the generated Dr.Jit code) "
                "beside Lambert, Oren-Nayar and Chandrasekhar's mirror-sphere BRDF, all at the same spherical albedo, "
                f"under several light directions, and write the comparison as {FILE} into --out.",
             "fitlab render --out /tmp/render --size 32 --spp 2")  # fmt: skip
    p.add_argument("--out", default=".", help=f"folder for {FILE} (default: the current folder)")
    p.add_argument(
        "--generated",
        default=None,
        help="the generated Dr.Jit module the plugin runs (default: the one packaged with fitlab, "
        "generated/lambert_sphere_drjit.py of its fits; `fitlab codegen --lang drjit` makes one)",
    )
    p.add_argument(
        "--kd",
        type=number(0.0, 1.0, open_lo=True, open_hi=True),
        default=0.8,
        help="spherical albedo of every material, in (0, 1) (default 0.8)",
    )
    p.add_argument(
        "--size", type=integer(8, 4096), default=64, help="image size per sphere in pixels, 8-4096 (default 64)"
    )
    p.add_argument("--spp", type=integer(1, 65536), default=4, help="samples per pixel, 1-65536 (default 4)")
    p.add_argument("--lights", type=integer(1, 5), default=3, help="number of light directions, 1-5 (default 3)")
    p.add_argument(
        "--variant",
        choices=VARIANTS,
        default="auto",
        help="the Mitsuba variant: auto (llvm_ad_rgb where Dr.Jit's LLVM backend runs here, else "
        "scalar_rgb; the default), scalar_rgb or llvm_ad_rgb",
    )
    add_family(p, "render")
    add_quiet(p)


def run(args) -> int:
    generated = input_file(
        args.generated if args.generated is not None else packaged_fits() / "generated" / "lambert_sphere_drjit.py",
        "--generated",
        hint="; run `fitlab codegen --lang drjit` first",
    )
    out = output_folder(args.out, "--out", files=(FILE,))
    require_extra("mitsuba", "render")
    from fitlab.core import HasRender

    render = family_with(HasRender, args.family).render()

    try:
        render.check_generated(generated)  # drjit only: a module that is not a generated BRDF is refused now
    except render.RenderError as exc:
        raise UsageError(one_line(exc)) from None
    except Exception as exc:  # noqa: BLE001 - the module failed to import
        raise UsageError(f"--generated {generated}: cannot load it ({type(exc).__name__}: {one_line(exc)})") from None
    if args.variant == "llvm_ad_rgb" and render.llvm_problem() is not None:
        raise UsageError(
            f"--variant llvm_ad_rgb does not run here ({one_line(render.llvm_problem())}); "
            "tools/install-system-packages.sh installs libLLVM, or use --variant scalar_rgb"
        )
    try:
        png = render.render_comparison(
            generated=generated,
            kd=args.kd,
            size=args.size,
            spp=args.spp,
            lights=args.lights,
            show_progress=not args.quiet,
            variant=args.variant,
        )
    except (render.RenderError, ValueError, ArithmeticError) as exc:
        raise RunFailure(one_line(exc)) from None
    try:
        atomic_write_bytes(out / FILE, png)
    except OSError as exc:
        raise write_failure(out, exc) from None
    say(args, f"wrote {out / FILE}")
    return 0
