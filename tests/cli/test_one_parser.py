"""Every command's parser answers a bad argument the same way: one line ``pinclear: error: ...``
and exit 2 (no usage block), the delegated commands (wear, study) included."""
from __future__ import annotations

import pytest

from tests.helpers import run_cli

WEAR = ["wear", "nine_bar", "--clearance", "A", "--period", "1", "--out", "OUT"]


@pytest.mark.parametrize("argv, names", [
    (WEAR + ["--cycles", "many"], "--cycles"),
    (WEAR + ["--cycles", "nan"], "--cycles"),
    (WEAR + ["--cycles", "1e6", "--updates", "0"], "--updates"),
    (WEAR + ["--cycles", "1e6", "--scheme", "random"], "--scheme"),
    (["wear", "nine_bar", "--period", "1", "--out", "OUT"], "--cycles"),
    (["study", "no_such_study"], "name"),
    (["study", "paper002", "--quick", "--colour"], "--colour"),
    (["bench", "restitution", "--ce", "x"], "--ce"),
    (["bench", "contact-laws", "--v", "x"], "--v"),
])
def test_bad_argument_is_one_line(argv, names, capsys, tmp_path):
    argv = [str(tmp_path / a) if a == "OUT" else a for a in argv]
    with pytest.raises(SystemExit) as exc:
        run_cli(argv, capsys)
    err = capsys.readouterr().err
    assert exc.value.code == 2
    assert err.startswith("pinclear: error: ") and err.count("\n") == 1, err
    assert names in err and "usage:" not in err


def test_wear_with_fewer_cycles_than_updates_is_refused_before_it_runs(capsys, tmp_path):
    """--cycles 1 --updates 2 (factor scheme, one period a block): no trial fits in the life; this
    ended in an AttributeError after the first trial was skipped."""
    code, out, err = run_cli(WEAR[:-1] + [str(tmp_path / "w"), "--cycles", "1", "--updates", "2"], capsys)
    assert code == 2 and err.count("\n") == 1
    assert "--cycles" in err and "1 x 1" not in err and "2 x 1" in err
    assert not (tmp_path / "w").exists()
