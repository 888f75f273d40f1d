r"""The Lambert sphere's runtime models and the program generated from them.

* :mod:`.spec`: the family's ``codegen`` (:data:`.spec.PROGRAM`): the runtime BRDF assembled from its fitted
  parts, the sampling routines, the materials.
* :mod:`.runtime`: the runtime BRDF as JAX models (the published presets, the refits, the order-2 model) and
  its accuracy against the exact reference.
* :mod:`.rewrites`: the family's ``sympy.codegen.rewriting`` optimisations of the generated routines.
* :mod:`.true_refit`: the runtime parts fitted to the true BRDF (``python -m
  fitlab.families.lambert_sphere.program.true_refit --out DIR``).
* :mod:`.table_export`: the exact tables as engines ship them (``fitlab codegen --tables``).
* :mod:`.baselines`: Lambert and Oren-Nayar as a program, what the benchmarks and renders compare with.
"""
