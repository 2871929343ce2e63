"""Hostile round 4 (issue 42), the kernel cache: what is in it runs (numba unpickles its index
files, pinclear imports its generated stage modules), so a cache folder another user can write
is refused with one line, and a new one is created 0700. The planted index files carry a pickle
that writes a marker file and ends the process: the control run (a private folder holding the
same planted files) shows that the route is real, so the refusals are what keeps the marker out."""
from __future__ import annotations

import os
import pickle
import shutil
import subprocess
import sys
from pathlib import Path

import numba
import pytest

import pinclear
from pinclear.core.jit import (
    KERNEL_OPTIONS,
    KERNELS_DIGEST,
    CacheFolderError,
    private_folder,
)

ROOT = Path(__file__).resolve().parents[2]


class _Payload:
    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        code = f"open({str(self.marker)!r}, 'w').write('ran'); import os; os._exit(0)"
        return exec, (code,)


def _plant(cache: Path, marker: Path) -> int:
    """Copy the names of this process's cached kernel index files into ``cache`` (same layout),
    each holding the payload, under the folder a child with PINCLEAR_CACHE_DIR=cache reads
    (pinclear.core.jit: numba-<options>-<digest>; this process's own folder has another name when
    the suite runs with NUMBA_CACHE_DIR set, which _run removes from the child's environment).
    Returns how many were planted."""
    pinclear.simulate(pinclear.load("four_bar"), 0.01)          # the four-bar's kernels are cached
    real = Path(numba.config.CACHE_DIR)
    child = cache / f"numba-{KERNEL_OPTIONS}-{KERNELS_DIGEST.hex()[:12]}"
    blob = pickle.dumps(_Payload(marker))
    n = 0
    for f in real.rglob("*.nbi"):
        dst = child / f.relative_to(real)
        dst.parent.mkdir(parents=True, exist_ok=True)
        dst.write_bytes(blob)
        n += 1
    return n


def _run(cache: Path, out: Path):
    env = dict(os.environ, PINCLEAR_CACHE_DIR=str(cache), PYTHONPATH=str(ROOT))
    env.pop("NUMBA_CACHE_DIR", None)
    return subprocess.run([sys.executable, "-m", "pinclear.cli", "simulate", "four_bar", "--t-end", "0.01",
                           "--out", str(out), "--progress", "off"], capture_output=True, text=True, env=env,
                          timeout=900)


@pytest.mark.skipif(not hasattr(os, "getuid"), reason="POSIX permissions")
def test_a_planted_kernel_index_runs_only_from_a_private_folder(tmp_path):
    marker = tmp_path / "MARKER"
    shared = tmp_path / "shared"
    shared.mkdir()
    assert _plant(shared, marker) > 0
    shared.chmod(0o777)                                   # the audit's world-writable folder
    r = _run(shared, tmp_path / "o1")
    assert r.returncode == 2 and not marker.exists(), r.stderr
    line = r.stderr.strip()
    assert len(line.splitlines()) == 1 and str(shared) in line and "writable by group or others" in line
    shared.chmod(0o700)                                   # control: the user's own folder is used
    r = _run(shared, tmp_path / "o2")
    assert marker.exists(), "the planted index was never read: this test would not catch the attack"


@pytest.mark.skipif(not hasattr(os, "getuid"), reason="POSIX permissions")
def test_cache_folder_rules(tmp_path):
    new = private_folder(tmp_path / "a" / "cache")
    assert (new.stat().st_mode & 0o777) == 0o700
    g = tmp_path / "g"
    g.mkdir(mode=0o770)
    g.chmod(0o770)
    with pytest.raises(CacheFolderError, match="writable by group or others.*770"):
        private_folder(g)
    loose = tmp_path / "loose"                               # a folder above it others may change
    loose.mkdir()
    loose.chmod(0o777)
    with pytest.raises(CacheFolderError, match="above the kernel cache folder"):
        private_folder(loose / "cache")
    sticky = tmp_path / "sticky"                              # /tmp's sticky bit protects it
    sticky.mkdir()
    sticky.chmod(0o1777)
    assert private_folder(sticky / "cache").is_dir()
    f = tmp_path / "file"
    f.write_text("")
    with pytest.raises(CacheFolderError, match="not a folder|cannot create"):
        private_folder(f)


@pytest.mark.skipif(not hasattr(os, "getuid") or os.getuid() != 0, reason="needs root to give a folder away")
def test_a_cache_folder_of_another_user_is_refused(tmp_path):
    other = tmp_path / "other"
    other.mkdir(mode=0o700)
    os.chown(other, 12345, 12345)
    with pytest.raises(CacheFolderError, match="owned by user id 12345"):
        private_folder(other)
    shutil.rmtree(other)
