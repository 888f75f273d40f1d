"""The studies: the scripts that write pages of docs/, one package per family, each run from the repository's root as
``python -m studies.FAMILY.NAME --out docs``.  They use fitlab as any user's code does; they are not part of the
fitlab package (nor of its wheel), and fitlab imports none of them."""
