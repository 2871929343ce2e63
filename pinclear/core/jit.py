"""The one place pinclear imports numba.

Compiled kernels are cached on disk so a new process does not recompile them, and that cache
lives in the user's cache folder, never inside the installed package: files written next to the
sources of a non-editable install outlive an uninstall and can shadow a later install (a
leftover ``site-packages/pinclear/contact/__pycache__`` acted as a namespace package).
``PINCLEAR_CACHE_DIR`` or ``NUMBA_CACHE_DIR`` override the folder.

Compiling is kept apart from running: the first run on a machine compiles the kernels it uses
(30-60 s), later processes load them from the cache (~0.3 s). :func:`compile_cpu` counts the CPU
seconds this process spent on both, so a run's ``cpu_s``, its ``max_cpu`` budget and the benchmarks
measure the run alone (pinclear.simulate subtracts it and reports it as ``compile_s``), and
the first compile prints one line on stderr saying what the wait is. ``pinclear warmup``
compiles everything ahead of time.
"""
from __future__ import annotations

import contextlib
import hashlib
import os
import stat
import sys
import threading
import time
from pathlib import Path

import numba
from numba.core import caching as _caching
from numba.core import config as _config
from numba.core import event as _event

from pinclear.core.errors import PinclearError

#: the installed package's root folder (the parent of core/)
PACKAGE = Path(__file__).resolve().parents[1]

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


def kernels_digest() -> bytes:
    """Digest of every pinclear module that defines compiled code, numba's version, Python's and
    the compile options. numba's cache index keys a cached function on its own source file only,
    while compiled code inlines what it calls from other files (the step logic inlines
    rk_step and rosenbrock_step, a contact kernel the helpers of forces.py): an edit there
    would leave stale code in the cache. The cache folder is named by this digest instead."""
    h = hashlib.sha1(f"{numba.__version__} {KERNEL_OPTIONS} {sys.version_info[:2]}".encode())
    for f in kernel_files():
        h.update(str(f.relative_to(PACKAGE)).encode() + f.read_bytes())
    return h.digest()


def kernel_files() -> list[Path]:
    """Every module of the package (all its subpackages) that defines compiled code, sorted."""
    return [f for f in sorted(PACKAGE.rglob("*.py")) if b"njit" in (t := f.read_bytes()) or b"cfunc" in t]


KERNELS_DIGEST = kernels_digest()


class CacheFolderError(PinclearError):
    """The kernel cache folder could be written by someone else: refused."""


def private_folder(path, what="kernel cache folder") -> Path:
    """``path``, created with mode 0700 when missing, refused (CacheFolderError, one line) when
    it is not a folder owned by the user, when group or others may write it, or when a folder
    above it may be changed by others (owned by another user than the user or root, or writable
    by others without the sticky bit /tmp has). What is in the kernel cache runs: numba unpickles
    its index files (``*.nbi``) and pinclear imports the generated stage modules (``stages/``),
    so a folder another user can write is a folder another user's code runs from."""
    path = Path(path)
    fix = "set PINCLEAR_CACHE_DIR to a folder of your own (docs/security.md)"
    try:
        if not path.is_dir():
            path.parent.mkdir(parents=True, exist_ok=True)
            with contextlib.suppress(FileExistsError):
                path.mkdir(mode=0o700)
        st = os.stat(path)
    except OSError as exc:
        raise CacheFolderError(f"{path}: cannot create the {what} ({exc.strerror}); {fix}") from None
    if not stat.S_ISDIR(st.st_mode):
        raise CacheFolderError(f"{path}: the {what} is not a folder; {fix}")
    if not hasattr(os, "getuid"):          # pragma: no cover - Windows: the ACLs of the profile folder
        return path
    me = os.getuid()
    if st.st_uid != me:
        raise CacheFolderError(f"{path}: the {what} is owned by user id {st.st_uid}, not by you ({me}): refused, "
                               f"its contents would run as code; {fix}")
    if st.st_mode & 0o022:
        raise CacheFolderError(f"{path}: the {what} is writable by group or others (mode {stat.S_IMODE(st.st_mode):o}): "
                               f"refused, its contents would run as code; chmod go-w it or {fix}")
    for up in path.resolve().parents:
        try:
            a = os.stat(up)
        except OSError as exc:
            raise CacheFolderError(f"{path}: cannot check the folder {up} above the {what} ({exc.strerror}); {fix}") from None
        if a.st_uid not in (0, me) or (a.st_mode & 0o002 and not a.st_mode & stat.S_ISVTX):
            raise CacheFolderError(f"{path}: the folder {up} above the {what} can be changed by other users "
                                   f"(owner id {a.st_uid}, mode {stat.S_IMODE(a.st_mode):o}): refused; {fix}")
    return path


# the folder numba reads cached kernels from (its own NUMBA_CACHE_DIR when set) is checked before
# any kernel is compiled or loaded; numba reads CACHE_DIR when a cached function is first
# compiled, so setting it before any kernel module is imported is enough
class PackageLocator(_caching.UserProvidedCacheLocator):
    """Files a pinclear kernel under its folder's path inside the package (``pinclear_contact``),
    where numba's own locator hashes the absolute folder. The same sources installed twice
    (``pip install .`` into site-packages, then ``pip install -e .`` from the clone) then share one
    cache entry instead of compiling again into a second folder: the digest folder above already
    keys on every kernel file's content, and numba's source stamp is the file's own content hash,
    so a path adds nothing but a recompile."""

    @classmethod
    def get_suitable_cache_subpath(cls, py_file):
        return "_".join(Path(py_file).resolve().parent.relative_to(PACKAGE.parent).parts)

    @classmethod
    def from_function(cls, py_func, py_file):
        if not _config.CACHE_DIR.startswith(str(cache_dir())) or not Path(py_file).resolve().is_relative_to(PACKAGE):
            return None     # a user's own kernel, or the user's own NUMBA_CACHE_DIR: numba's locators
        return super().from_function(py_func, py_file)


if os.environ.get("NUMBA_CACHE_DIR"):
    private_folder(os.environ["NUMBA_CACHE_DIR"])
else:
    numba.config.CACHE_DIR = str(private_folder(cache_dir()) / f"numba-{KERNEL_OPTIONS}-{KERNELS_DIGEST.hex()[:12]}")
    if PackageLocator not in _caching.CacheImpl._locator_classes:
        _caching.CacheImpl._locator_classes.insert(0, PackageLocator)


#: the line printed (once per process, on stderr) when pinclear starts compiling kernels
COMPILE_NOTICE = "pinclear: compiling pinclear's kernels, once per machine, about 30-60 s"


class _CompileClock(_event.Listener):
    """CPU seconds spent inside numba's compiler lock, outermost entries only: compiling a kernel
    (with the kernels it calls) and loading one from the on-disk cache both happen there, calls
    of a kernel already loaded never enter it (loading ~20 cached kernels is most of a short
    run's first CPU second: benchmarks/kernel_choices.md)."""

    def __init__(self):
        self.cpu = 0.0
        self._depth = 0
        self._start = 0.0
        self._lock = threading.Lock()

    def on_start(self, ev):
        with self._lock:
            if self._depth == 0:
                self._start = time.process_time()
            self._depth += 1

    def on_end(self, ev):
        with self._lock:
            self._depth -= 1
            if self._depth == 0:
                self.cpu += time.process_time() - self._start


class _CompileNotice(_event.Listener):
    """Counts real compilations ("numba:compile": numba announces no cache loads) and prints
    COMPILE_NOTICE at the first of a pinclear kernel in this process."""

    def __init__(self):
        self.count = 0
        self.announced = False

    def on_start(self, ev):
        if not self.announced and _ours(ev.data.get("dispatcher")):
            self.announced = True
            if not os.environ.get("PINCLEAR_QUIET_COMPILE"):
                print(COMPILE_NOTICE, file=sys.stderr, flush=True)

    def on_end(self, ev):
        self.count += 1


def _ours(dispatcher) -> bool:
    """A pinclear kernel (the package's or a generated wrapper/loop in the cache folder)."""
    mod = getattr(getattr(dispatcher, "py_func", None), "__module__", "") or ""
    return mod.startswith("pinclear") or mod.startswith("_pinclear")


_CLOCK = _CompileClock()
_NOTICE = _CompileNotice()
_event.register("numba:compiler_lock", _CLOCK)
_event.register("numba:compile", _NOTICE)


def compile_cpu() -> float:
    """CPU seconds this process has spent preparing numba kernels so far: compiling them, or
    loading them from the cache (any kernel: a user's numba drive law compiled inside a run is
    not run time either)."""
    return _CLOCK.cpu


def compile_count() -> int:
    """numba compilations (not cache loads) in this process so far."""
    return _NOTICE.count
