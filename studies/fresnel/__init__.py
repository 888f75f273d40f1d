"""The Fresnel family's study: :mod:`.fresnel_study` writes docs/fresnel.md (``python -m studies.fresnel.fresnel_study
--out docs``)."""
