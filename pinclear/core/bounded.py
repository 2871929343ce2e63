"""Reading a user's file with a bound: regular files only, at most ``limit`` bytes read.

A size check on ``stat().st_size`` bounds nothing for a FIFO (open blocks until a writer comes,
forever if none does) or a device (``/dev/zero`` reports size 0 and never ends), so every file a
user names (sidecar, URDF, sweep index and point files, a reference run) is opened without
blocking, checked on the open descriptor (no window between the check and the read) and read
for at most ``limit + 1`` bytes: one byte more than allowed says the file is too large.
"""
from __future__ import annotations

import os
import stat
from pathlib import Path

from pinclear.core.errors import ModelFileError

_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


#: the most digits an integer written in a file may have: 2**63 has 19, so no count, index or
#: seed pinclear uses needs more, and a 5000-digit literal made Python's int() refuse (4300-digit
#: limit) or float() overflow deep inside a reader, as a traceback
MAX_INT_DIGITS = 19


def shown(x, limit: int = 60) -> str:
    """``repr(x)`` cut to ``limit`` characters for an error message; never raises (repr of an int
    with more than 4300 digits does) and never prints a whole huge value."""
    if isinstance(x, int) and not isinstance(x, bool) and abs(x).bit_length() > 64 * 4:
        return f"an integer of about {int(abs(x).bit_length() * 0.30103) + 1} digits"
    try:
        text = repr(x)
    except (ValueError, RecursionError):
        return f"a {type(x).__name__}"
    return text if len(text) <= limit else text[:limit - 3] + "..."


def bounded_int_text(text: str) -> bool:
    """Whether an integer literal (``+12_345``, ``0x1F``) has at most MAX_INT_DIGITS digits,
    judged on its text before any conversion."""
    digits = text.strip().lstrip("+-").replace("_", "")
    if digits[:2].lower() in ("0x", "0o", "0b"):
        base = {"x": 16, "o": 8, "b": 2}[digits[1].lower()]
        return len(digits) - 2 <= {16: 16, 8: 21, 2: 64}[base]
    return len(digits) <= MAX_INT_DIGITS


def _kind(mode) -> str:
    return next((name for test, name in _KINDS if test(mode)), "not a regular file")


def check_regular(path, key="path", what="file"):
    """Refuse anything but an existing regular file (symbolic links are followed), naming the
    file and what it is instead. Returns its size in bytes."""
    file = str(path)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise ModelFileError(file, key, "no such file") from None
    except OSError as exc:
        raise ModelFileError(file, key, f"cannot be read: {exc.strerror}") from None
    if not stat.S_ISREG(st.st_mode):
        raise ModelFileError(file, key, f"is {_kind(st.st_mode)}, not a regular {what} file")
    return st.st_size


def read_bounded(path, limit: int, key="path", what="file") -> bytes:
    """The bytes of the regular file ``path``, refused (naming the file and the limit) when it
    holds more than ``limit`` bytes or is not a regular file."""
    file = str(Path(path))
    try:
        # O_NONBLOCK: a FIFO swapped in after a stat() must not block the open; the mode is
        # checked again on the descriptor itself
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    except FileNotFoundError:
        raise ModelFileError(file, key, "no such file") from None
    except IsADirectoryError:
        raise ModelFileError(file, key, f"is a folder, not a regular {what} file") from None
    except OSError as exc:
        raise ModelFileError(file, key, f"cannot be read: {exc.strerror}") from None
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise ModelFileError(file, key, f"is {_kind(mode)}, not a regular {what} file")
        chunks, left = [], limit + 1
        while left > 0:
            b = os.read(fd, min(left, 1 << 20))
            if not b:
                break
            chunks.append(b)
            left -= len(b)
    except OSError as exc:
        raise ModelFileError(file, key, f"cannot be read: {exc.strerror}") from None
    finally:
        os.close(fd)
    data = b"".join(chunks)
    if len(data) > limit:
        raise ModelFileError(file, key, f"more than {limit} bytes: too large for a {what} file (at most {limit})")
    return data


def read_text_bounded(path, limit: int, key="path", what="file") -> str:
    """:func:`read_bounded` decoded as UTF-8 (an error names the byte where decoding failed)."""
    data = read_bounded(path, limit, key, what)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ModelFileError(str(path), key, f"not UTF-8 text ({exc.reason} at byte {exc.start})") from None
