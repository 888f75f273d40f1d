r"""The microfacet_energy family: Kulla-Conti energy compensation of single-scattering BRDFs (GGX with
separable or height-correlated Smith masking-shadowing, Oren-Nayar), after the blog article on
multiple-scattering BRDFs ("Energy Compensation") and Kulla and Conti (2017).

The exact engine is :mod:`.exact` (directional albedo E(mu, alpha), its average E_avg(alpha), the
compensation lobe f_ms, with F = 1); :mod:`.tabulate` writes its tables.  This package registers no
family yet: its targets and forms come in a later step.
"""
