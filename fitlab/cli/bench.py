"""``fitlab bench``: benchmarks (not tests) of the exact engine, the generated code and the Monte Carlo."""

from __future__ import annotations

from fitlab.codegen.bench import bench_codegen
from fitlab.families.lambert_sphere.bench import bench_exact

__all__ = ["HELP", "add_arguments", "run"]

HELP = "benchmarks (not tests): speed and accuracy"


def add_arguments(p) -> None:
    p.add_argument("what", choices=["exact", "codegen", "mc"], help="what to benchmark")
    p.add_argument("--quick", action="store_true", help="smaller sizes")


def run(args) -> int:
    if args.what == "exact":
        bench_exact(quick=args.quick)
    elif args.what == "codegen":
        bench_codegen(n=100_000 if args.quick else 1_000_000, repeat=3 if args.quick else 5)
    elif args.what == "mc":
        from fitlab.families.lambert_sphere.mc.bench import bench_mc  # JAX

        bench_mc(quick=args.quick)
    return 0
