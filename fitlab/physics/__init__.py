"""The physics fitlab's families share, each formula written once against an array namespace (numpy, jax.numpy or
sympy, chosen by the arguments): Fresnel (:mod:`.fresnel`), microfacet distributions and Smith masking
(:mod:`.microfacet`), Oren-Nayar (:mod:`.oren_nayar`) and the Lambert sphere's phase function
(:mod:`.lambert_sphere`).  docs/architecture.md, "One physics", states the design."""

from __future__ import annotations

from pathlib import Path

from fitlab.physics._namespace import NUMPY, Namespace, jax_namespace, namespace, sympy_namespace

__all__ = ["NUMPY", "Namespace", "jax_namespace", "namespace", "sources", "sympy_namespace"]

_HERE = Path(__file__).resolve().parent


def sources(*modules: str) -> tuple[Path, ...]:
    """The files of the physics ``modules`` (names such as "fresnel") and of the namespaces they are written against:
    part of the key of whatever an engine caches from them (:func:`fitlab.cache.cached_arrays`)."""
    names = {"_namespace", *modules}
    files = tuple(_HERE / f"{m}.py" for m in sorted(names))
    missing = [f.name for f in files if not f.is_file()]
    if missing:
        raise ValueError(f"no physics module {', '.join(missing)}")
    return files
