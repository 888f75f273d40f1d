r"""Multiple-scattering lobes by scattering order, and analytic lobes fitted to them (after the blog
in the seeds: its steps "analyse the shape of the lobe each order leaves", "fit a simple analytical lobe",
"fit its parameters as functions of roughness", "evaluate the fitted lobes at runtime").

Modules:

* :mod:`.tables`: the lobes of diffuse facets (albedo 1) and F = 1 conductors on GGX microsurfaces, by order
  (2, 3, 4 and the tail above 4, with order 1), simulated by the random walk of :mod:`..mc` on a
  training grid and an interleaved validation grid of (alpha, mu_i), tabulated with their standard errors
  (``fitlab tabulate``; fitlab/data/microfacet_energy/lobes_*.csv);
* :mod:`.shapes`: the lobe shapes, each one sympy expression: the blog's 5-parameter lobe, its final
  (undeviated, isotropic) form, and the tilted lobe that does better;
* :mod:`.fitting`: a shape fitted to one simulated lobe with optimistix (the chi-square of the bins and of
  the albedo);
* :mod:`.params`: the per-lobe fits of every lobe, tabulated (lobe_params_*.csv): the exact values of the
  lobe-parameter targets;

Elsewhere in the family, by job: those targets (ms_blog_*, ms_tilt_*: functions of alpha, mu_i and the order)
in :mod:`..targets.lobes`, their forms with the blog's published expressions as presets
(docs/blog_lobe_model.md) in :mod:`..forms.lobes`; each model's lobes from its parameters' forms (presets or
fits) in :mod:`..program.runtime`, and the family's program (``fitlab codegen --family microfacet_energy``: the
fitted albedos and the runtime lobes, fitlab/fits/generated/microfacet_energy.*) in :mod:`..program.spec`;
docs/microsurface_lobes.md, every model against the simulated lobes with energy and cost, from
``studies.microfacet_energy.microsurface_lobes``.
"""
