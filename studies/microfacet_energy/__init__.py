r"""The studies of the microfacet_energy family that write docs/ (each ``python -m MODULE --out docs``).

* :mod:`.energy_compensation`: docs/energy_compensation.md, how well, at what memory and at what cost a
  renderer can know E(mu, alpha) for Kulla-Conti energy compensation.
* :mod:`.microsurface_lobes`: docs/microsurface_lobes.md, the simulated multiple-scattering lobes against every way to
  model them.
* :mod:`.microsurface_validation`: the microsurface walk against its deterministic references at large
  budgets.
"""
