"""The Lambert-sphere family's report methods and audit.

* :mod:`.methods`: the family's ``report`` hook (a :class:`fitlab.core.BrdfReportHook`): the BRDF and part
  methods ``fitlab report`` measures, with :mod:`.settings` (sizes and the BRDF's signature),
  :mod:`.exact_engine` (the exact engine's own rows), :mod:`.montecarlo` (Monte Carlo at several path counts)
  and :mod:`.spline_tables` (the exact tables read through scipy splines, the "tables" methods), and
  :mod:`.markdown` (report.md's prose of this BRDF and the sections on the family's engines);
* :mod:`.audit`: the family's ``audit`` hook, ``fitlab audit`` (docs/audit.md).
"""
