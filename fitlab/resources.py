r"""Where fitlab finds its files: what ships inside the package, and the user's data folder.

Shipped inside the package (read-only; found with :mod:`importlib.resources`, so a wheel install works
from any directory):

* ``fitlab/data/FAMILY/``: each family's exact tables (``fitlab tabulate`` writes the same files) and,
  under ``scenes/``, its example Monte Carlo scenes;
* ``fitlab/fits/``: the committed fits (one JSON per target and form) and, under ``generated/``, the
  code generated from them.

The user's data folder holds the tables ``fitlab tabulate`` computes, in the same layout
(``DATA/FAMILY/*.csv``): ``$FITLAB_DATA`` when set (the commands' ``--data`` sets it), else
``$XDG_DATA_HOME/fitlab``, else ``~/.local/share/fitlab``.  A family's tables are read from there when
that folder holds every one of the family's tables, and from the package when it holds none of them (the
fallback); a folder that holds some but not all is refused, naming the first one missing, so that a set
is never read half from one tabulation and half from another.

Nothing fitlab computes is ever written into the package: every command writes to its ``--out``
folder, by default below the current directory.
"""

from __future__ import annotations

import os
from importlib.resources import files
from pathlib import Path

from fitlab._io import TableError

__all__ = [
    "package_folder",
    "packaged_fits",
    "packaged_tables",
    "packaged_scenes",
    "data_root",
    "tables_folder",
    "find_scene",
    "DATA_ENV",
]

#: the environment variable that names the user's data folder (``--data`` sets it)
DATA_ENV = "FITLAB_DATA"


def package_folder(*parts: str) -> Path:
    """A folder or file shipped inside the installed fitlab package (a path on disk: pip unpacks wheels)."""
    return Path(str(files("fitlab").joinpath(*parts)))


def packaged_fits() -> Path:
    """The committed fits shipped with fitlab (``generated/`` below holds the code generated from them)."""
    return package_folder("fits")


def packaged_exact_values() -> Path:
    """The exact values shipped with fitlab (``fitlab/data/exact_values``): the entries of :mod:`fitlab.cache` that a
    fresh install's commands would compute first (``fitlab codegen``'s validation sets and the true BRDF it measures
    its model against), read when the cache lacks them (written by ``tools/seed_test_cache.py``)."""
    return package_folder("data", "exact_values")


def packaged_tables(family: str) -> Path:
    """The exact tables of ``family`` shipped with fitlab."""
    return package_folder("data", family)


def packaged_scenes(family: str) -> Path:
    """The example Monte Carlo scenes of ``family`` shipped with fitlab."""
    return package_folder("data", family, "scenes")


def data_root() -> Path:
    """The user's data folder: ``$FITLAB_DATA``, else ``$XDG_DATA_HOME/fitlab``, else ``~/.local/share/fitlab``."""
    if os.environ.get(DATA_ENV):
        return Path(os.environ[DATA_ENV])
    base = os.environ.get("XDG_DATA_HOME") or Path.home() / ".local" / "share"
    return Path(base) / "fitlab"


def tables_folder(family: str, files_needed=(), root: Path | str | None = None) -> Path:
    """The folder ``family``'s tables are read from: ``ROOT/FAMILY`` (``root``, else :func:`data_root`)
    when it holds every name in ``files_needed`` (any CSV when none is named), the packaged tables when it
    holds none of them (or is no folder).  A folder that holds some of ``files_needed`` but not all is
    refused with one :class:`fitlab.store.TableError` line naming the first one missing.  A name counts as
    held whatever it is (a FIFO, a folder), so that reading it refuses it rather than passing it over."""
    user = Path(root if root is not None else data_root()) / family
    if user.is_dir():
        if files_needed:
            missing = [name for name in files_needed if not os.path.lexists(user / name)]
            if not missing:
                return user
            if len(missing) < len(files_needed):
                raise TableError(f"{user}: {missing[0]} is missing (the folder holds {len(files_needed) - len(missing)} "
                                 f"of the {len(files_needed)} tables of {family}); run `fitlab tabulate` to write them "
                                 "all, or remove the folder to read the packaged tables")  # fmt: skip
        elif any(user.glob("*.csv")):
            return user
    return packaged_tables(family)


def find_scene(name_or_path, families) -> Path | None:
    """A scene file: ``name_or_path`` itself when it exists and is no folder (a FIFO too, which reading a scene
    then refuses), else the packaged scene of that name (with or without ``.toml``) among ``families``' scenes;
    None when there is none."""
    p = Path(name_or_path)
    if os.path.lexists(p) and not p.is_dir():
        return p
    if p.parent != Path("."):
        return None
    for family in families:
        folder = packaged_scenes(family)
        for candidate in (folder / p.name, folder / f"{p.name}.toml"):
            if candidate.is_file():
                return candidate
    return None
