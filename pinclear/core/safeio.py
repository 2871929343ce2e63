"""Link-safe writes into a results folder (docs/security.md, "Writing into a folder").

A results folder may come from someone else (a received run, a sweep folder, a folder in /tmp)
and may hold symbolic links planted where pinclear writes: ``R/.lock -> ../victim`` made a run
truncate ``victim``. Every file pinclear creates, truncates or replaces goes through this module:

* the folder the user named (``root``) is the only path followed through links; every component
  below it is opened one at a time with ``O_NOFOLLOW`` relative to its parent's descriptor
  (``dir_fd``), so a link or a swapped folder below the root is refused, never followed, and a
  write never leaves the root;
* a file is written to a new temporary name created with ``O_CREAT | O_EXCL | O_NOFOLLOW`` in the
  target's folder and renamed over the target (``rename(2)`` replaces a link itself, never what it
  points to): a reader never sees half a file and nothing outside the folder is touched;
* the lock file, the only file opened in place, is opened with ``O_NOFOLLOW`` and refused unless
  it is a regular file with one link (a hard link to another file would be truncated).

A failed write (a full disk, a target that is a folder) is an ``OSError`` naming the target;
:func:`write_or_fallback` then writes a copy beside it or in the user cache folder and names both.
"""
from __future__ import annotations

import contextlib
import errno
import os
import secrets
import stat
import time
from pathlib import Path

_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
_CLOEXEC = getattr(os, "O_CLOEXEC", 0)
_DIRECTORY = getattr(os, "O_DIRECTORY", 0)


class LinkRefused(OSError):
    """A component below the results folder is a link (or not a folder): refused, not followed."""


def _split(path, root):
    """(root, [components below root]) for ``path`` inside ``root`` (default: its parent)."""
    path = Path(path)
    root = Path(root) if root is not None else path.parent
    try:
        rel = path.relative_to(root)
    except ValueError:
        raise LinkRefused(errno.EXDEV, f"{path} is not inside the folder {root}", str(path)) from None
    parts = rel.parts
    if not parts or any(p in ("", ".", "..") for p in parts):
        raise LinkRefused(errno.EINVAL, f"{path}: not a file name inside {root}", str(path))
    return root, list(parts)


def _open_root(root: Path) -> int:
    """The folder the user named, created if missing (links in its own path are the user's)."""
    root.mkdir(parents=True, exist_ok=True)
    return os.open(root, os.O_RDONLY | _DIRECTORY | _CLOEXEC)


def _descend(fd: int, parts, where: Path, create=True) -> int:
    """The descriptor of the folder ``parts`` below ``fd``, each component opened without
    following links (created when missing and ``create``). Closes ``fd``."""
    for part in parts:
        where = where / part
        try:
            try:
                nfd = os.open(part, os.O_RDONLY | _DIRECTORY | _NOFOLLOW | _CLOEXEC, dir_fd=fd)
            except FileNotFoundError:
                if not create:
                    raise
                with contextlib.suppress(FileExistsError):
                    os.mkdir(part, 0o777, dir_fd=fd)
                nfd = os.open(part, os.O_RDONLY | _DIRECTORY | _NOFOLLOW | _CLOEXEC, dir_fd=fd)
        except OSError as exc:
            os.close(fd)
            if exc.errno in (errno.ELOOP, errno.ENOTDIR):
                raise LinkRefused(exc.errno, "is a link or not a folder: refused (pinclear never follows a link "
                                  "inside a results folder)", str(where)) from None
            raise
        os.close(fd)
        fd = nfd
    return fd


@contextlib.contextmanager
def folder_fd(path, root=None):
    """(descriptor of ``path``'s folder, reached link-safely from ``root``, file name)."""
    root, parts = _split(path, root)
    fd = _descend(_open_root(root), parts[:-1], root)
    try:
        yield fd, parts[-1]
    finally:
        os.close(fd)


def make_dirs(folder, root=None) -> Path:
    """Create ``folder`` (below ``root``, default its parent) without following links."""
    folder = Path(folder)
    root, parts = _split(folder, root)
    os.close(_descend(_open_root(root), parts, root))
    return folder


def write_atomic(path, write, root=None, binary=True) -> Path:
    """``write(fh)`` fills a new temporary file beside ``path`` (inside ``root``, default the
    target's folder), which is then renamed over ``path``. Returns ``Path(path)``. An OSError
    (full disk, a folder at ``path``, a link below ``root``) leaves no temporary behind."""
    path = Path(path)
    with folder_fd(path, root) as (dfd, name):
        tmp = f".{name}.{secrets.token_hex(4)}.tmp"
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | _NOFOLLOW | _CLOEXEC, 0o666, dir_fd=dfd)
        try:
            with os.fdopen(fd, "wb" if binary else "w", **({} if binary else {"encoding": "utf-8", "newline": ""})) as fh:
                write(fh)
            os.replace(tmp, name, src_dir_fd=dfd, dst_dir_fd=dfd)
        except BaseException as exc:
            with contextlib.suppress(OSError):
                os.unlink(tmp, dir_fd=dfd)
            if isinstance(exc, OSError) and exc.filename == tmp:
                # the error names the target, never the temporary name (which no longer exists)
                raise OSError(exc.errno, exc.strerror, str(path)) from None
            raise
    return path


def write_bytes(path, data: bytes, root=None) -> Path:
    return write_atomic(path, lambda fh: fh.write(data), root)


def write_text(path, text: str, root=None) -> Path:
    return write_atomic(path, lambda fh: fh.write(text), root, binary=False)


def savez(path, arrays: dict, root=None) -> Path:
    """``np.savez_compressed`` through :func:`write_atomic`."""
    import numpy as np

    return write_atomic(path, lambda fh: np.savez_compressed(fh, **arrays), root)


def savefig(fig, path, root=None, **kw) -> Path:
    """``fig.savefig`` through :func:`write_atomic` (the format from the suffix, png by default)."""
    kw.setdefault("format", Path(path).suffix[1:].lower() or "png")
    return write_atomic(path, lambda fh: fig.savefig(fh, **kw), root)


def open_lock(path, root=None):
    """The lock file ``path`` opened read-write in place (created if missing) without following a
    link; refused (OSError naming it) unless a regular file with a single link."""
    with folder_fd(path, root) as (dfd, name):
        try:
            fd = os.open(name, os.O_RDWR | os.O_CREAT | _NOFOLLOW | _CLOEXEC | getattr(os, "O_NONBLOCK", 0),
                         0o666, dir_fd=dfd)
        except OSError as exc:
            if exc.errno == errno.ELOOP:
                raise LinkRefused(exc.errno, "is a link: refused (pinclear never follows a link inside a results "
                                  "folder); remove it", str(path)) from None
            raise
    st = os.fstat(fd)
    if not stat.S_ISREG(st.st_mode) or st.st_nlink != 1:
        os.close(fd)
        raise LinkRefused(errno.EPERM, "is not a regular file of its own (a device, a FIFO or a hard link to "
                          "another file): refused; remove it", str(path))
    os.set_blocking(fd, True)
    return os.fdopen(fd, "r+")


@contextlib.contextmanager
def folder_lock(folder, option="--out"):
    """Hold FOLDER/.lock (fcntl.flock, exclusive, not waiting) for the whole command: a second run
    or sweep into the same folder is refused at once, naming the folder and the process holding
    it, so two runs never mix their files. The lock file is opened by :func:`open_lock` (never
    through a link). A no-op where fcntl is missing."""
    from pinclear.core.errors import InputError

    try:
        import fcntl
    except ImportError:            # pragma: no cover - Windows
        yield
        return
    folder = Path(folder)
    lock = folder / ".lock"
    try:
        fh = open_lock(lock)
    except OSError as exc:
        raise InputError(f"{option} {str(folder)!r}: cannot create the lock file {str(lock)!r} ({exc.strerror})") from None
    with fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            fh.seek(0)
            holder = " ".join(fh.read(200).split())
            raise InputError(f"{option} {str(folder)!r} is in use by another pinclear run "
                             f"({holder or 'process unknown'}); wait for it to end or choose another {option}") from None
        fh.seek(0)
        fh.truncate()
        fh.write(f"pid {os.getpid()}, started {time.strftime('%Y-%m-%d %H:%M:%S')}\n")
        fh.flush()
        try:
            yield
        finally:
            fh.seek(0)
            fh.truncate()
            fcntl.flock(fh, fcntl.LOCK_UN)


def probe_writable(folder) -> None:
    """Create and remove a new file in ``folder`` (OSError when it cannot be written)."""
    write_bytes(Path(folder) / f".pinclear-write-test-{os.getpid()}", b"")
    os.unlink(Path(folder) / f".pinclear-write-test-{os.getpid()}")


def _free_name(dfd: int, name: str) -> str:
    """``name``, or ``name.1``, ``name.2``, ... : the first that does not exist in the folder
    ``dfd`` (a link counts as existing)."""
    for i in range(10_000):
        cand = name if i == 0 else f"{name}.{i}"
        try:
            os.stat(cand, dir_fd=dfd, follow_symlinks=False)
        except FileNotFoundError:
            return cand
    raise OSError(errno.EEXIST, f"{name}: 10000 files of that name already kept aside", name)


def move_aside(path, new_name: str) -> Path:
    """Rename ``path`` to ``new_name`` in the same folder (a link is renamed, never followed),
    never over a file already there: a second file moved aside under the same name becomes
    ``new_name.1``, ``.2``, ... (what was kept aside is evidence; it is never overwritten).
    Returns the path it now has."""
    path = Path(path)
    with folder_fd(path) as (dfd, name):
        while True:
            dest = _free_name(dfd, new_name)
            try:
                # link(2) fails when dest exists: no window in which another file could be replaced
                os.link(name, dest, src_dir_fd=dfd, dst_dir_fd=dfd, follow_symlinks=False)
            except FileExistsError:
                continue                      # taken meanwhile: the next free name
            except OSError as exc:
                if exc.errno not in (errno.EPERM, errno.EMLINK, errno.ENOTSUP, errno.EXDEV):
                    raise
                # a folder (no hard links) or a file system without them: rename to a name just
                # found free
                os.rename(name, dest, src_dir_fd=dfd, dst_dir_fd=dfd)
                return path.with_name(dest)
            os.unlink(name, dir_fd=dfd)
            return path.with_name(dest)


def fallback_paths(target: Path) -> list[tuple[Path, Path]]:
    """(path, root) pairs where a file goes when its own path cannot be written: beside it,
    else the user cache folder (``unsaved-runs/STAMP/NAME``)."""
    from pinclear.core.jit import cache_dir

    target = Path(target)
    stamp = f"{time.strftime('%Y%m%d-%H%M%S')}-{os.getpid()}"
    cache = cache_dir()
    beside = target.with_name(f"{target.stem}.fallback-{stamp}{target.suffix}")
    # two fallbacks in one second of one process (a run's summary and its trajectory both
    # failing) must not replace each other: the first free name
    for i in range(1, 10_000):
        if not (beside.exists() or beside.is_symlink()):
            break
        beside = target.with_name(f"{target.stem}.fallback-{stamp}-{i}{target.suffix}")
    cached = cache / "unsaved-runs" / stamp / target.name
    for i in range(1, 10_000):
        if not (cached.exists() or cached.is_symlink()):
            break
        cached = cache / "unsaved-runs" / f"{stamp}-{i}" / target.name
    return [(beside, target.parent), (cached, cache)]


def write_or_fallback(write, target, root=None):
    """``write(path, root)`` to ``target``; if that fails, to a fallback path. Returns (the path
    written or None, None or a message naming the target, the copy and the reason)."""
    target = Path(target)
    try:
        return write(target, root), None
    except OSError as exc:
        why = exc.strerror or str(exc)
    tried = []
    for alt, alt_root in fallback_paths(target):
        tried.append(str(alt))
        try:
            write(alt, alt_root)
        except OSError:
            continue
        return alt, f"could not write {target} ({why}); saved it as {alt} instead"
    return None, f"could not write {target} ({why}), nor a copy at {' or '.join(tried)}"
