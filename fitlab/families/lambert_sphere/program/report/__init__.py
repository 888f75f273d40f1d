"""The Lambert-sphere family's report methods and audit.

* :mod:`.methods`: the family's report (a :class:`fitlab.report.methods.BrdfReport`): the BRDF and part
  methods ``fitlab report`` measures, with :mod:`.settings` (sizes, albedos, the quick choices and the BRDF's
  signature), :mod:`.materials` (the albedos the BRDF is measured at), :mod:`.engine_rows` (the rows of the
  family's own engines, from :mod:`.exact_engine`'s measurements of the exact engine and :mod:`.montecarlo`'s
  at several path counts), :mod:`.spline_tables` (the exact tables read through scipy splines, the "tables"
  methods) and :mod:`.markdown` (report.md's prose of this BRDF and the sections on the family's engines);
* :mod:`.audit`: the family's audit, ``fitlab audit`` (docs/audit.md).
"""
