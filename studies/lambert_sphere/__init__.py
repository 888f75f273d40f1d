"""The Lambert-sphere family's studies: the scripts that write docs/ (each runs as ``python -m``).

* :mod:`.table_study`: what the exported tables store, and at what resolution (docs/table_export.md);
* :mod:`.error_budget`: the runtime model's error part by part (docs/error_budget.md);
* :mod:`.sampling_variance`: the variance of the fitted importance sampler against cosine sampling
  (docs/sampling.md).

Each computes its numbers as data and writes its files as one unit at the end.
"""
