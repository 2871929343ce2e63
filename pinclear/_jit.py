"""The one place pinclear imports numba.

Compiled kernels are cached on disk so a new process does not recompile them, and that cache
lives in the user's cache folder, never inside the installed package: files written next to the
sources of a non-editable install outlive an uninstall and can shadow a later install (a
leftover ``site-packages/pinclear/contact/__pycache__`` acted as a namespace package).
``PINCLEAR_CACHE_DIR`` or ``NUMBA_CACHE_DIR`` override the folder.
"""
from __future__ import annotations

import os
from pathlib import Path

import numba
from numba import njit  # noqa: F401  (re-exported: kernels import it from here)


def cache_dir() -> Path:
    """User cache folder of pinclear (XDG on Linux, the platform's convention elsewhere)."""
    env = os.environ.get("PINCLEAR_CACHE_DIR")
    if env:
        return Path(env)
    if os.name == "nt":
        base = Path(os.environ.get("LOCALAPPDATA", Path.home() / "AppData" / "Local"))
    elif os.uname().sysname == "Darwin":
        base = Path.home() / "Library" / "Caches"
    else:
        base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base / "pinclear"


if not os.environ.get("NUMBA_CACHE_DIR"):
    # numba reads this setting when a cached function is first compiled, so setting it before
    # any kernel module is imported is enough
    numba.config.CACHE_DIR = str(cache_dir() / "numba")
