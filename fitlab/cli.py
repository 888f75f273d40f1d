"""The ``fitlab`` command."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


def _cmd_tabulate(args) -> int:
    from fitlab.families.lambert_sphere.tabulate import check_tables, write_tables
    from fitlab.store import TableError

    if args.check:
        try:
            failures = check_tables(Path(args.out), show_progress=not args.quiet)
        except TableError as exc:
            print(f"fitlab tabulate --check: {exc}", file=sys.stderr)
            return 1
        if failures:
            for f in failures:
                print(f"fitlab tabulate --check: {f}", file=sys.stderr)
            return 1
        print(f"fitlab tabulate --check: {args.out} agrees with the independent recomputation")
        return 0
    t0 = time.perf_counter()
    digests = write_tables(Path(args.out), show_progress=not args.quiet)
    dt = time.perf_counter() - t0
    for name, digest in digests.items():
        print(f"  {Path(args.out) / name}  sha256:{digest}")
    print(f"wrote {len(digests)} tables in {dt:.1f} s")
    return 0


def _cmd_bench(args) -> int:
    from fitlab.families.lambert_sphere.bench import bench_exact

    if args.what == "exact":
        bench_exact(quick=args.quick)
    elif args.what == "codegen":
        from fitlab.codegen.bench import bench_codegen

        bench_codegen(n=100_000 if args.quick else 1_000_000, repeat=3 if args.quick else 5)
    elif args.what == "mc":
        from fitlab.families.lambert_sphere.mc.bench import bench_mc

        bench_mc(quick=args.quick)
    return 0


def _cmd_refit(args) -> int:
    from fitlab.fit.refit import default_jobs, table, timed_refit
    from fitlab.core import get_target, targets
    from fitlab.store import FitFileError, fit_path, read_fit
    from fitlab.fit.solver import FitError
    from fitlab.store import TableError

    if args.list:
        for t in targets().values():
            forms = ", ".join(f + (" (default)" if f == t.default_form else "") for f in t.forms)
            print(f"{t.name:<10} {t.description}\n{'':<10} forms: {forms}")
        return 0
    if args.all == bool(args.target):
        print("fitlab refit: error: give --target NAME (see --list) or --all", file=sys.stderr)
        return 2
    if args.all and (args.form or args.domain or args.init):
        print("fitlab refit: error: --form, --domain and --init go with --target, not --all", file=sys.stderr)
        return 2
    from fitlab.store import form_from_fit, resolve_form

    try:
        if args.all:
            jobs = [(get_target(t), get_target(t).forms[f], None, None) for t, f in default_jobs()]
        else:
            target = get_target(args.target)
            form = resolve_form(target.name, args.form, Path(args.fits or args.out))
            origin = None
            saved = fit_path(Path(args.fits or args.out), target.name, form.name)
            if form.name not in target.forms and saved.exists():
                origin = read_fit(saved).get("origin")  # a discovered form stays one
            start = None
            if args.init is not None:
                prior = read_fit(args.init)
                if (prior["target"], prior["form"]) != (target.name, form.name):
                    raise ValueError(f"--init {args.init}: a fit of {prior['target']}/{prior['form']}, not {form.key}")
                start = prior["params"]
            jobs = [(target, form, start, origin)]
            domain = parse_domain(args.domain, target)
        results, walls = [], []
        from tqdm import tqdm

        for target, form, start, origin in tqdm(jobs, desc="refit", unit="fit", disable=args.quiet or len(jobs) == 1):
            res, wall = timed_refit(
                target, form, domain=None if args.all else domain, start=start, origin=origin,
                minimax=False if args.no_minimax else None, compare_scipy=args.compare_scipy,
            )
            results.append(res)
            walls.append(wall)
    except (KeyError, ValueError, FitError, FitFileError, TableError) as exc:
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else str(exc)
        print(f"fitlab refit: error: {msg}", file=sys.stderr)
        return 2
    # all fits done and validated: only now write (each file atomically)
    from fitlab.store import write_fit

    paths = []
    for res in results:
        path = fit_path(Path(args.out), res.record["target"], res.record["form"])
        write_fit(path, res.record)
        paths.append(path)
    print(table(results, walls))
    for path in paths:
        print(f"wrote {path}")
    return 0


def parse_domain(items, target) -> dict:
    """``["c=0.5:1", ...]`` -> {"c": (0.5, 1.0), ...}, checked against the target's domain."""
    inputs = target.inputs
    domain = dict(target.domain)
    for item in items or ():
        name, sep, rng = item.partition("=")
        lo, sep2, hi = rng.partition(":")
        if not sep or not sep2:
            raise ValueError(f"--domain {item!r}: write NAME=LO:HI, e.g. c=0.5:1")
        if name not in domain:
            raise ValueError(f"--domain {item!r}: this target's inputs are {', '.join(inputs)}")
        try:
            lo_f, hi_f = float(lo), float(hi)
        except ValueError:
            raise ValueError(f"--domain {item!r}: LO and HI must be numbers") from None
        full_lo, full_hi = target.domain[name]
        if not (full_lo <= lo_f < hi_f <= full_hi):
            raise ValueError(f"--domain {item!r}: need {full_lo:g} <= LO < HI <= {full_hi:g} for {name}")
        domain[name] = (lo_f, hi_f)
    return domain



def _cmd_audit(args) -> int:
    from fitlab.families.lambert_sphere.audit import run_audit
    from fitlab.store import TableError

    t0 = time.perf_counter()
    try:
        result = run_audit(Path(args.out), Path(args.fits))
    except (TableError, ValueError) as exc:
        print(f"fitlab audit: error: {exc}", file=sys.stderr)
        return 2
    for r in result["runtime"]:
        print(f"{r['model']:<45} max rel* {r['max_rel_nonzero']:.3e}  RMS {r['rms_rel_nonzero']:.3e}  "
              f"away from grazing: max {r['max_rel_away']:.3e}  RMS {r['rms_rel_away']:.3e}")
    for r in result["furnace"]:
        print(f"white furnace c=1, {r['model']:<45} max |a - 1| = {r['max_abs_deviation']:.2e}")
    for m in result["missing_fits"]:
        print(f"not measured: {m}")
    print(f"wrote {Path(args.out) / 'audit.md'} and audit.json in {time.perf_counter() - t0:.1f} s")
    return 0


def _cmd_codegen(args) -> int:
    from fitlab.codegen import generate, parse_forms, write_generated
    from fitlab.store import FitFileError

    try:
        files = generate(args.lang, Path(args.fits), args.terms, parse_forms(args.form))
    except (ValueError, KeyError, FitFileError) as exc:
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else str(exc)
        print(f"fitlab codegen: error: {msg}", file=sys.stderr)
        return 2
    for path in write_generated(files, Path(args.out)):
        print(f"wrote {path}")
    return 0


def _cmd_render(args) -> int:
    from fitlab.families.lambert_sphere.render import RenderError, render_comparison

    try:
        path = render_comparison(
            Path(args.out), generated=Path(args.generated), kd=args.kd, size=args.size, spp=args.spp,
            lights=args.lights, show_progress=not args.quiet,
        )
    except (RenderError, ValueError) as exc:
        print(f"fitlab render: error: {exc}", file=sys.stderr)
        return 2
    print(f"wrote {path}")
    return 0


def _cmd_simulate(args) -> int:
    from fitlab.families.lambert_sphere.mc.cli import run_simulate

    return run_simulate(args)


def _cmd_discover(args) -> int:
    from fitlab.discover.cli import run_discover

    return run_discover(args)


def _cmd_report(args) -> int:
    from fitlab.report.cli import run_report

    return run_report(args)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="fitlab", description="Fitting workbench for analytic BRDFs (Lambert-sphere BRDF).")
    sub = p.add_subparsers(dest="command", required=True)
    t = sub.add_parser("tabulate", help="write the exact tables to data/ (or check them)")
    t.add_argument("--out", default="data", help="folder for the CSV tables (default: data)")
    t.add_argument("--check", action="store_true", help="recompute a sample of rows by independent methods")
    t.add_argument("--quiet", action="store_true", help="no progress bar")
    t.set_defaults(func=_cmd_tabulate)
    r = sub.add_parser("refit", help="refit a published form (or a richer one) to the exact data")
    r.add_argument("--target", help="what to fit: H0, H1, l, m, B, C, D, F, kd_of_c, c_of_kd, fm1, fast_brdf")
    r.add_argument("--form", help="which form of the target (default: the published shape; see --list)")
    r.add_argument("--all", action="store_true", help="refit every target (every form marked for it)")
    r.add_argument("--out", default="fits", help="folder for the fit JSON (default: fits)")
    r.add_argument("--fits", default="fits",
                   help="folder the forms saved by `fitlab discover` are read from (default: fits)")
    r.add_argument("--domain", action="append", metavar="NAME=LO:HI", help="restrict an input, e.g. c=0.5:1")
    r.add_argument("--init", type=Path, help="start from a saved fit of the same target and form")
    r.add_argument("--no-minimax", action="store_true", help="least squares only, no minimax refinement")
    r.add_argument("--compare-scipy", action="store_true", help="also solve the least-squares stage with scipy")
    r.add_argument("--list", action="store_true", help="list targets and forms")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    r.set_defaults(func=_cmd_refit)
    a = sub.add_parser("audit", help="measure every published formula and the runtime model against the exact engine")
    a.add_argument("--out", default="docs", help="folder for audit.md and audit.json (default: docs)")
    a.add_argument("--fits", default="fits", help="folder of the refits to include (default: fits)")
    a.set_defaults(func=_cmd_audit)
    g = sub.add_parser("codegen", help="generate C, Python or GLSL source of the runtime BRDF from the fits")
    g.add_argument("--lang", required=True, choices=["c", "python", "glsl"], help="target language")
    g.add_argument("--fits", default="fits", help="folder of the fits JSON (default: fits)")
    g.add_argument("--out", default="fits/generated", help="output folder (default: fits/generated)")
    g.add_argument("--terms", help="terms of brdf to keep, comma-separated subset of single,m0,m1 (default: all)")
    g.add_argument("--form", action="append", metavar="TARGET=FORM",
                   help="use fits/TARGET.FORM.json for a part, e.g. H0=hapke_rational (repeatable)")
    g.set_defaults(func=_cmd_codegen)
    rr = sub.add_parser("render", help="render spheres with the generated BRDF in Mitsuba 3 beside Lambert, Oren-Nayar, Chandrasekhar")
    rr.add_argument("--out", default="docs/render.png", help="PNG to write (default: docs/render.png)")
    rr.add_argument("--generated", default="fits/generated/lambert_sphere.py", help="the generated Python BRDF module")
    rr.add_argument("--kd", type=float, default=0.8, help="spherical albedo of every material (default 0.8)")
    rr.add_argument("--size", type=int, default=64, help="image size per sphere in pixels (default 64)")
    rr.add_argument("--spp", type=int, default=4, help="samples per pixel (default 4)")
    rr.add_argument("--lights", type=int, default=3, help="number of light directions, 1-5 (default 3)")
    rr.add_argument("--quiet", action="store_true", help="no progress bar")
    rr.set_defaults(func=_cmd_render)
    s = sub.add_parser("simulate", help="Monte Carlo: simulate only the effects a scene asks for (data/scenes/)")
    s.add_argument("scene", help="scene file (.toml or .json), e.g. data/scenes/order1_normalisation.toml")
    s.add_argument("--out", help="output folder (default: mc_out/<scene name>)")
    s.add_argument("--target-se", type=float, help="override every effect's standard-error target")
    s.add_argument("--max-paths", type=int, help="override the path budget per job")
    s.add_argument("--seed", type=int, help="override the scene's seed")
    s.add_argument("--no-plots", action="store_true", help="CSV only")
    s.add_argument("--quiet", action="store_true", help="no progress bar")
    s.set_defaults(func=_cmd_simulate)
    dd = sub.add_parser("discover", help="symbolic regression (pysindy): a Pareto front of new forms for a target")
    from fitlab.discover.cli import add_arguments as _discover_arguments

    _discover_arguments(dd)
    dd.set_defaults(func=_cmd_discover)
    rp = sub.add_parser("report", help="accuracy vs cost of every way to evaluate the BRDF: docs/report.md and a plot")
    from fitlab.report.cli import add_arguments as _report_arguments

    _report_arguments(rp)
    rp.set_defaults(func=_cmd_report)
    b = sub.add_parser("bench", help="benchmarks (not tests): speed and accuracy")
    b.add_argument("what", choices=["exact", "codegen", "mc"], help="what to benchmark")
    b.add_argument("--quick", action="store_true", help="smaller sizes")
    b.set_defaults(func=_cmd_bench)
    return p


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
