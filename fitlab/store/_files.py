"""Fit files: reading and writing them (one :class:`FitFileError` line for every refusal), and where they live
(fits/TARGET[.FORM].json, a ``--fits`` folder overlaying the packaged fits)."""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Mapping
from pathlib import Path

import sympy as sp

from fitlab._io import InputFileError, atomic_write_many, atomic_write_text, read_regular_file
from fitlab.core import get_target, target_names
from fitlab.resources import packaged_fits
from fitlab.store._check import FitFileError, check_fit, checked_fit
from fitlab.store._json import refuse_constant, strict_json

__all__ = [
    "MAX_FIT_BYTES",
    "read_fit",
    "read_checked_fit",
    "write_fit",
    "write_fits",
    "fits_folder",
    "fit_path",
    "fit_source",
    "fit_origin",
    "fit_files",
    "fit_sha256",
]

#: the largest fit file read, in bytes
MAX_FIT_BYTES = 1_000_000


def read_fit(path: Path, target: str | None = None) -> dict:
    """:func:`read_checked_fit` without the expression."""
    return read_checked_fit(path, target)[0]


def read_checked_fit(path: Path, target: str | None = None) -> tuple[dict, sp.Expr]:
    """Read and check a fit file (:func:`check_fit`); every failure is one :class:`FitFileError` line.

    ``target``: the target the caller expects.  A file named after a registered target
    (TARGET.json, TARGET.FORM.json) must hold a fit of that target and form, so that a fit saved
    under another target's name is never taken for it."""
    path = Path(path)
    try:  # a regular file of at most MAX_FIT_BYTES, checked before it is opened: a FIFO or a device never blocks
        data = read_regular_file(path, MAX_FIT_BYTES)
    except InputFileError as exc:
        raise FitFileError(
            {
                "missing": f"{path}: no such fit file; run `fitlab refit --target NAME` to create it",
                "folder": f"{path}: a folder, not a fit file",
                "too_large": f"{path}: larger than {MAX_FIT_BYTES} bytes; not a fit file",
            }.get(exc.kind, f"{path}: {exc.refusal('fit file')}")
        ) from None
    try:
        record = json.loads(data.decode("utf-8"), parse_constant=refuse_constant)
    except json.JSONDecodeError as exc:
        raise FitFileError(
            f"{path}: corrupt JSON (line {exc.lineno}, column {exc.colno}: {exc.msg}); "
            "regenerate it with `fitlab refit`"
        ) from None
    except (ValueError, RecursionError, UnicodeDecodeError) as exc:
        raise FitFileError(f"{path}: not a fit file ({str(exc)[:120] or type(exc).__name__})") from None
    record, expr = checked_fit(record, str(path))
    named = path.name.split(".")
    if len(named) in (2, 3) and named[-1] == "json" and named[0] in target_names():
        default = get_target(named[0]).default_form
        form = named[1] if len(named) == 3 else default
        if (record["target"], record["form"]) != (named[0], form):
            raise FitFileError(f"{path}: holds a fit of {record['target']}/{record['form']}, not {named[0]}/{form}")
    if target is not None and record["target"] != target:
        raise FitFileError(f"{path}: holds a fit of {record['target']}, not {target}")
    return record, expr


def write_fits(records: Mapping[Path, Mapping]) -> list[Path]:
    """Write several fit records ({path: record}) as one unit: all or none (see fitlab._io.atomic_write_many)."""
    texts = {Path(p): strict_json(dict(check_fit(dict(r), str(p)))).encode() for p, r in records.items()}
    atomic_write_many(texts)
    return list(texts)


def write_fit(path: Path, record: Mapping) -> None:
    """Check ``record`` (:func:`check_fit`: what fitlab writes, it can read back) and write it as JSON
    atomically (a temporary file, then a rename)."""
    path = Path(path)
    atomic_write_text(path, strict_json(dict(check_fit(dict(record), str(path)))))


def fits_folder(fits_dir: Path | str | None = None) -> Path:
    """The folder fits are written to and read from first: ``fits_dir`` when given, else the fits packaged with
    fitlab (:func:`fitlab.resources.packaged_fits`).  Reading goes through :func:`fit_source`, which falls back
    to the packaged fits for what ``fits_dir`` lacks."""
    return Path(fits_dir) if fits_dir is not None else packaged_fits()


def fit_path(out: Path, target: str, form: str) -> Path:
    """fits/NAME.json for a target's default form, fits/NAME.FORM.json otherwise."""
    default = get_target(target).default_form
    return Path(out) / (f"{target}.json" if form == default else f"{target}.{form}.json")


def fit_sha256(path: Path) -> str:
    """The sha256 of a fit file's bytes (what generated code's banner names its sources by)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def fit_source(fits_dir: Path | str | None, target: str, form: str, packaged_folder: str = "") -> Path:
    """The file a fit of ``target`` in ``form`` is read from: ``fits_dir`` overlays the packaged fits, so it is
    fits_dir/NAME when anything of that name exists there (a folder or a FIFO too, which reading then refuses,
    rather than passing it over), else the packaged fit of that name (:func:`fit_path` names it); when neither
    exists, the path in ``fits_dir`` (whose reading then fails naming it).  ``fits_dir`` None: the packaged fits.

    ``packaged_folder``: a subfolder that overlays each folder in turn (a model's, :attr:`fitlab.codegen.Model.folder`:
    the packaged fits hold the parts fitted to the true BRDF in ``true/``): fits_dir/FOLDER/NAME, fits_dir/NAME,
    then the packaged FOLDER/NAME and NAME, the first there."""
    folders = [Path(fits_dir)] if fits_dir is not None else []
    folders.append(packaged_fits())
    if packaged_folder:
        folders = [f for folder in folders for f in (folder / packaged_folder, folder)]
    own = len(folders) - (2 if packaged_folder else 1)  # how many of them are the user's
    for k, folder in enumerate(folders):
        path = fit_path(folder, target, form)
        if os.path.lexists(path) if k < own else path.is_file():
            return path
    return fit_path(folders[0] if own else packaged_fits(), target, form)


def fit_origin(path: Path) -> str:
    """Where a fit file lies, as generated banners say it: "packaged" (the fits shipped with fitlab, wherever
    they are installed, or one of their subfolders: "packaged (true)") or "--fits" (a folder of the user's)."""
    try:
        folder, root = Path(path).resolve().parent, packaged_fits().resolve()
    except OSError:
        return "--fits"
    if folder == root:
        return "packaged"
    return f"packaged ({folder.name})" if folder.parent == root else "--fits"


def fit_files(fits_dir: Path | None, target: str) -> list[Path]:
    """Every saved fit of ``target`` in the folder ``fits_dir`` (None: the packaged fits): TARGET.json first, then
    TARGET.*.json by name.  A listing of one folder (what an inventory shows); a part a program needs is read
    through :func:`fit_source`, which overlays the folder on the packaged fits."""
    fits_dir = packaged_fits() if fits_dir is None else Path(fits_dir)
    return [p for p in (fits_dir / f"{target}.json",) if p.exists()] + sorted(fits_dir.glob(f"{target}.*.json"))
