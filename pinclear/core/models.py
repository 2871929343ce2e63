"""Where the mechanism files are: one function for every module, test and example.

The ``urdf/`` folder of the repository is installed as the package ``pinclear.urdf`` (see
pyproject.toml), so a non-editable ``pip install .`` finds the models by name from anywhere.
"""
from __future__ import annotations

import functools
import importlib.util
from pathlib import Path

from pinclear.core.errors import ModelFileError


def models_dir() -> Path:
    """The folder holding the bundled URDF trees and sidecars."""
    # pinclear.urdf is a data folder without __init__.py, i.e. a namespace package: its
    # location comes from the import system's search locations (importlib.resources would hand
    # back a MultiplexedPath, whose str() is not a path)
    try:
        spec = importlib.util.find_spec("pinclear.urdf")
    except ModuleNotFoundError:
        spec = None
    for loc in (spec.submodule_search_locations or []) if spec is not None else []:
        if any(Path(loc).glob("*.yaml")):
            return Path(loc)
    # an editable install maps the package folder only: the models are then the repository's
    # own urdf/ beside it
    return Path(__file__).resolve().parents[2] / "urdf"


def available() -> list[str]:
    """Names of the bundled mechanisms (sidecar stems)."""
    return sorted(p.stem for p in models_dir().glob("*.yaml"))


def model_path(name) -> Path:
    """A sidecar (or URDF) path from a bundled mechanism's name (``"four_bar"``) or any path.

    An existing file is returned as it is; a bare name is looked up among the bundled models
    (before a folder of that name in the working directory: an output folder named after its
    mechanism must not hide the mechanism); any other existing path is returned for the loader
    to refuse with its reason.
    """
    p = Path(name)
    if p.is_file():
        return p
    if p.suffix in ("", ".yaml", ".urdf") and len(p.parts) == 1:
        cand = models_dir() / (p.name if p.suffix else p.name + ".yaml")
        if cand.exists():
            return cand
    if p.exists():
        return p
    raise ModelFileError(str(name), "path", "no such file, and no bundled mechanism of that name",
                         choices=available())


@functools.lru_cache(maxsize=1)
def example_robot_data_dir() -> Path | None:
    """The folder holding example-robot-data's robots (``.../share/example-robot-data/robots``),
    found through the installed distribution's file list (it ships no importable module). Looked
    up once per process: the file list costs ~0.1 s and every load() asks (sidecar.allowed_roots)."""
    import importlib.metadata

    try:
        files = importlib.metadata.files("example-robot-data") or []
    except importlib.metadata.PackageNotFoundError:
        return None
    for f in files:
        parts = Path(str(f)).parts
        if "robots" in parts and str(f).endswith(".urdf"):
            located = Path(f.locate()).resolve()
            depth = len(parts) - parts.index("robots") - 1
            return located.parents[depth - 1]
    return None
