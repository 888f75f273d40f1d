r"""The microfacet_energy family's runtime models and generated program.

* :mod:`.spec`: the family's ``codegen`` (:data:`.spec.PROGRAM`, ``fitlab codegen --family
  microfacet_energy``): every fitted albedo and lobe parameter as a routine, the multiple-scattering lobes
  and Kulla-Conti's f_ms composed of them.
* :mod:`.runtime`: the runtime multiple-scattering lobes, each model's lobe of every order as one sympy
  expression built from the lobe-parameter targets' forms.
"""
