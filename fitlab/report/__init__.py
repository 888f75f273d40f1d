r"""The accuracy-vs-cost report: ``fitlab report``.

For every way fitlab can evaluate the Lambert-sphere BRDF and its parts (the
exact engine and its methods, the tables with interpolation, the published
presets, the refits, the richer and the discovered forms, the fast variant,
Monte Carlo at several path counts, and Lambert / Oren-Nayar as yardsticks) it
measures

* accuracy against the exact values on fixed validation sets: max and RMS
  relative error of the BRDF on uniform points, and its max on a grazing set
  (mu_i, mu_o down to 1e-6) that uniform points never reach (:mod:`.validation`,
  :mod:`.accuracy`), and of H0,
  H1, the constants, the albedo maps and fm1 on their targets' sets;
* cost: ns per evaluation of the generated C (:mod:`.programs`, through the one
  harness of :mod:`fitlab.codegen.bench`), numpy ns and JAX throughput
  (:mod:`.cost`), the exact engine's set-up and time to reach an error
  and Monte Carlo's error and time against path count (measured by the
  family, through its report: :func:`fitlab.report.methods.brdf_report`),
  and the one-off cost of each refit (:mod:`.refits`);

and writes docs/report.md, docs/accuracy_vs_cost.png (with the Pareto front,
:mod:`.pareto`, :mod:`.plot`) and docs/report.csv (:mod:`.write`).  The
catalogue of methods is :mod:`.methods` (each family adds its own through its
:class:`~fitlab.report.methods.Report`, for the Lambert sphere
:mod:`fitlab.families.lambert_sphere.program.report.methods`); the sizes are :mod:`.settings`
(``FULL``, and ``QUICK`` for the test); :func:`build_report` runs it all.
"""

from fitlab.report.methods import ReportError
from fitlab.report.pareto import pareto_front, recommend
from fitlab.report.run import Report, build_report
from fitlab.report.settings import FULL, QUICK, Settings
from fitlab.report.write import COLUMNS, TIMING_COLUMNS, write_outputs

__all__ = [
    "COLUMNS",
    "FULL",
    "QUICK",
    "Report",
    "ReportError",
    "Settings",
    "TIMING_COLUMNS",
    "build_report",
    "pareto_front",
    "recommend",
    "write_outputs",
]
