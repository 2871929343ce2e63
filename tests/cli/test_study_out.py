"""`pinclear study`'s output folder is checked and locked before the study computes (as
`pinclear simulate` does): an unusable --out is one line and exit 2 at once, and a second study
into a folder in use is refused."""
from __future__ import annotations

import pytest

from pinclear.cli import commands
from pinclear.core import safeio


@pytest.fixture
def calls(monkeypatch):
    """The study replaced by a recorder: these tests are about the folder, not the study."""
    import pinclear.studies.wear as wear

    seen = []

    def fake(out, quick=False, smoke=False):
        seen.append((out, quick, smoke))
        return [{"ok": True}]
    monkeypatch.setattr(wear, "paper002", fake)
    return seen


def _bad_outs(tmp_path):
    afile = tmp_path / "a_file"
    afile.write_text("x")
    return {"an existing file": afile, "under a file": afile / "sub", "/proc": "/proc/self/x"}


@pytest.mark.parametrize("case", ["an existing file", "under a file", "/proc"])
def test_an_unusable_out_fails_at_once_in_one_line(tmp_path, capsys, calls, case):
    out = _bad_outs(tmp_path)[case]
    assert commands.main(["study", "paper002", "--smoke", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("pinclear: error: --out") and not calls


def test_a_second_study_into_a_folder_in_use_is_refused(tmp_path, capsys, calls):
    out = tmp_path / "S"
    out.mkdir()
    with safeio.folder_lock(out):                     # another run holds the folder
        assert commands.main(["study", "paper002", "--smoke", "--out", str(out)]) == 2
    assert "in use by another pinclear run" in capsys.readouterr().err and not calls
    assert commands.main(["study", "paper002", "--smoke", "--out", str(out)]) == 0   # released: it runs
    assert calls == [(out, True, True)]
