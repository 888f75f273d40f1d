"""``fitlab refit``: refit a published form (or a richer one) to the exact data, and write the fit files.

:func:`fitlab.fit.refit.refit` reads and writes nothing: this module resolves the
form, reads a start (``--init``) and the origin of a discovered form, and writes
the fits only after every fit is done and validated.
"""

from __future__ import annotations

import sys
from pathlib import Path

from tqdm import tqdm

from fitlab.core import get_target, targets
from fitlab.fit.refit import default_jobs, table, timed_refit
from fitlab.fit.solver import FitError
from fitlab.store import FitFileError, TableError, fit_path, read_fit, resolve_form, write_fit

__all__ = ["HELP", "add_arguments", "run", "parse_domain"]

HELP = "refit a published form (or a richer one) to the exact data"


def add_arguments(p) -> None:
    p.add_argument("--target", help=f"what to fit: {', '.join(targets())}")
    p.add_argument("--form", help="which form of the target (default: the published shape; see --list)")
    p.add_argument("--all", action="store_true", help="refit every target (every form marked for it)")
    p.add_argument("--out", default="fits", help="folder for the fit JSON (default: fits)")
    p.add_argument("--fits", default="fits",
                   help="folder the forms saved by `fitlab discover` are read from (default: fits)")
    p.add_argument("--domain", action="append", metavar="NAME=LO:HI", help="restrict an input, e.g. c=0.5:1")
    p.add_argument("--init", type=Path, help="start from a saved fit of the same target and form")
    p.add_argument("--no-minimax", action="store_true", help="least squares only, no minimax refinement")
    p.add_argument("--compare-scipy", action="store_true", help="also solve the least-squares stage with scipy")
    p.add_argument("--list", action="store_true", help="list targets and forms")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args) -> int:
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
