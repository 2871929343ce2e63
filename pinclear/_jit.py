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


#: bump when the compile options of the kernels change (names the cache folder, see below)
KERNEL_OPTIONS = "npfloat1"


def njit(*args, **options):
    """numba.njit with NumPy's floating-point semantics (``error_model="numpy"``): x / 0 gives
    inf or nan as in NumPy, which the formulations report as non-finite so the integrator
    rejects the trial step. With numba's default ("python") a too-long trial step into a stiff
    contact raised ZeroDivisionError from inside a kernel and ended the whole run at t = 0."""
    options.setdefault("error_model", "numpy")
    return numba.njit(*args, **options)


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
    # numba's index keys a cached kernel on its source file, not on the compile options: a
    # change of options (as error_model above) needs a new folder, or stale kernels load
    numba.config.CACHE_DIR = str(cache_dir() / f"numba-{KERNEL_OPTIONS}")
