"""The version of pinclear (the one place it is written besides pyproject.toml), and the
provenance every results folder records (:func:`provenance`)."""
from __future__ import annotations

import functools
import platform
import subprocess
from pathlib import Path

__version__ = "0.1.0"

#: the libraries whose versions a result depends on (recorded with pinclear's)
LIBRARIES = ("pinocchio", "numpy", "scipy", "numba")


@functools.lru_cache(maxsize=1)
def commit() -> dict:
    """The git commit pinclear was imported from, ``{"commit": sha or None, "dirty": bool or
    None}``: found only when the package's own folder is the top of a git work tree (an
    editable install or a checkout; a copy installed inside someone else's repository must not
    report that repository's commit); None when it is not, or git is missing. Asked once per
    process, with a time limit."""
    root = Path(__file__).resolve().parents[2]

    def git(*args):
        return subprocess.run(["git", "-C", str(root), *args], capture_output=True, text=True, timeout=10,
                              check=True).stdout.strip()
    try:
        if Path(git("rev-parse", "--show-toplevel")).resolve() != root:
            return {"commit": None, "dirty": None}
        sha = git("rev-parse", "HEAD")
        dirty = bool(git("status", "--porcelain", "--untracked-files=no", "--", "pinclear"))
    except (OSError, subprocess.SubprocessError):
        return {"commit": None, "dirty": None}
    return {"commit": sha, "dirty": dirty}


def provenance() -> dict:
    """How a result was made: pinclear's version and commit (:func:`commit`; ``dirty``: the
    package's tracked files differ from it), the versions of Pinocchio, NumPy, SciPy, Numba and
    Python. Recorded in every trajectory's metadata (``versions``), summary.json and sweep.json."""
    import numba
    import numpy
    import pinocchio
    import scipy

    out = {"pinclear": __version__, **commit()}
    out.update(zip(LIBRARIES, (pinocchio.__version__, numpy.__version__, scipy.__version__, numba.__version__)))
    out["python"] = platform.python_version()
    return out


#: the file a results folder without a summary of its own records its provenance in
PROVENANCE_FILE = "provenance.json"


def write_provenance(folder, **what) -> Path:
    """FOLDER/provenance.json: :func:`provenance` and ``what`` (e.g. the command and its inputs),
    written link-safely (pinclear.core.safeio) for the folders whose own files carry no versions
    (figures of `plot`, `analyse`)."""
    import json

    from pinclear.core import safeio
    from pinclear.core.jsonsafe import jsonable

    return safeio.write_text(Path(folder) / PROVENANCE_FILE,
                             json.dumps(jsonable({**what, "versions": provenance()}), indent=1) + "\n")
