"""The last round's classes, across readers and commands (issue 53, item 10): numbers bounded
before use, absurd but finite display options, nothing kept aside ever overwritten, and what
pinclear writes read back by its own readers. No input here may end in exit 3 (the catch-all)."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

import pinclear
from pinclear.core.errors import PinclearError
from tests.helpers import run_cli

HUGE = "9" * 5000          # past Python's 4300-digit int() limit
BIG = "9" * 400            # an int, but beyond the float range (1.8e308)


def _one_line(code, err, *words):
    assert code == 2, (code, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("pinclear: error:"), err
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert len(lines[0]) < 2000                 # the number itself is never printed whole


# ----------------------------------------------------------------------------- numbers
@pytest.mark.parametrize("digits", [HUGE, BIG, "-" + BIG, "0x" + "f" * 40, "1_" + "0" * 30],
                         ids=["5000 digits", "400 digits", "-400 digits", "hex 40", "underscores 31"])
def test_a_sidecar_integer_with_too_many_digits_is_refused_at_parse(digits, tmp_path):
    from pinclear.io.sidecar import read_yaml

    f = tmp_path / "m.yaml"
    f.write_text(f"name: m\nurdf: m.urdf\nbaumgarte:\n  alpha: {digits}\n")
    with pytest.raises(PinclearError, match=r"m\.yaml.*line 4.*at most 19 digits") as e:
        read_yaml(f)
    assert "\n" not in str(e.value) and len(str(e.value)) < 500


@pytest.mark.parametrize("digits", ["1" * 19, "-" + "9" * 18, "0x" + "f" * 16])
def test_integers_within_the_bound_still_read(digits, tmp_path):
    from pinclear.io.sidecar import read_yaml

    f = tmp_path / "m.yaml"
    f.write_text(f"a: {digits}\n")
    assert read_yaml(f)["a"] == int(digits.replace("_", ""), 0)


@pytest.mark.parametrize("x", [10 ** 400, -(10 ** 400), 10 ** 5000], ids=["1e400", "-1e400", "1e5000"])
@pytest.mark.parametrize("reader", ["values.number", "validate.number", "validate.number integer"])
def test_number_checkers_refuse_integers_beyond_the_float_range(reader, x):
    from pinclear.core import values
    from pinclear.dynamics import validate

    with pytest.raises(PinclearError) as e:
        if reader == "values.number":
            values.number(x, "f.yaml", "k")
        else:
            validate.number(x, "f.npz", "k", integer=reader.endswith("integer"))
    msg = str(e.value)
    assert "\n" not in msg and len(msg) < 300 and "digits" in msg or "not finite" in msg or "expected" in msg


def test_a_count_beyond_int64_in_run_metadata_is_refused():
    from pinclear.dynamics import validate

    with pytest.raises(PinclearError, match="non-negative integer"):
        validate.number(2 ** 63, "f.npz", "steps", integer=True)
    assert validate.number(2 ** 62, "f.npz", "steps", integer=True) == 2 ** 62


@pytest.mark.parametrize("how", ["set", "sidecar", "state json big", "state json huge"])
def test_long_integers_on_the_command_line_are_one_line(how, tmp_path, capsys):
    from pinclear.core.models import model_path

    out = str(tmp_path / "out")
    if how == "set":
        argv = ["info", "four_bar", "--set", f"gravity={HUGE}"]
    elif how == "sidecar":
        text = model_path("four_bar").read_text() + f"\nhuge_number: {HUGE}\n"
        f = tmp_path / "four_bar.yaml"
        f.write_text(text)
        argv = ["info", str(f)]
    else:
        f = tmp_path / "state.json"
        digits = BIG if how.endswith("big") else HUGE
        f.write_text(f'{{"q": [{digits}, 0, 0], "v": [0, 0, 0]}}')
        argv = ["simulate", "four_bar", "--t-end", "0.01", "--start", "state", str(f), "--out", out]
    code, _, err = run_cli(argv, capsys)
    _one_line(code, err)


# ----------------------------------------------------------------------------- display options
ABSURD = [("--fps", "1e6"), ("--fps", "1e300"), ("--fps", "1e-300"), ("--slowdown", "1e300"),
          ("--slowdown", "1e-300"), ("--ecc-scale", "1e300"), ("--force-scale", "1e300"), ("--wear-scale", "1e300"),
          ("--ecc-scale", "1e-300"), ("--max-frames", "1000000000"), ("--size", "100000x100000"),
          ("--size", "9" * 5000 + "x1"), ("--size", "8193x10")]


@pytest.mark.parametrize("opt, value", ABSURD, ids=[f"{o}={v[:12]}" for o, v in ABSURD])
def test_absurd_but_finite_display_options_are_one_line_before_anything_loads(opt, value, tmp_path, capsys,
                                                                           monkeypatch):
    from pinclear.io import sidecar

    def no_load(*a, **k):
        raise AssertionError("loaded the mechanism before checking the options")

    monkeypatch.setattr(sidecar, "load", no_load)
    code, _, err = run_cli(["view", "four_bar", "--html", str(tmp_path / "v.html"), opt, value], capsys)
    _one_line(code, err, opt)


@pytest.mark.parametrize("opt, value", [("--fps", "1000"), ("--slowdown", "1e6"), ("--size", "8192x8192"),
                                        ("--max-frames", "20000"), ("--ecc-scale", "1e12")])
def test_display_options_at_their_bounds_are_accepted(opt, value):
    from pinclear.cli.view import _checked_scene_args, build_view_parser

    a = build_view_parser().parse_args(["four_bar", opt, value])
    w, h = _checked_scene_args(a)
    assert w > 0 and h > 0


# ----------------------------------------------------------------------------- kept aside
def test_a_second_file_moved_aside_never_replaces_the_first(tmp_path):
    from pinclear.core import safeio

    kept = []
    for i in range(3):
        f = tmp_path / "p.npz"
        f.write_bytes(f"copy {i}".encode())
        kept.append(safeio.move_aside(f, "p.npz.corrupt"))
        assert not f.exists()
    assert [k.name for k in kept] == ["p.npz.corrupt", "p.npz.corrupt.1", "p.npz.corrupt.2"]
    assert [k.read_bytes() for k in kept] == [b"copy 0", b"copy 1", b"copy 2"]


def test_a_link_moved_aside_is_the_link_and_its_target_is_untouched(tmp_path):
    from pinclear.core import safeio

    victim = tmp_path / "victim"
    victim.write_bytes(b"keep")
    (tmp_path / "p.npz.corrupt").write_bytes(b"first")
    link = tmp_path / "p.npz"
    link.symlink_to(victim)
    moved = safeio.move_aside(link, "p.npz.corrupt")
    assert moved.name == "p.npz.corrupt.1" and moved.is_symlink()
    assert victim.read_bytes() == b"keep" and (tmp_path / "p.npz.corrupt").read_bytes() == b"first"


def test_two_fallback_copies_in_one_second_do_not_replace_each_other(tmp_path, monkeypatch):
    from pinclear.core import safeio

    monkeypatch.setenv("PINCLEAR_CACHE_DIR", str(tmp_path / "cache"))
    target = tmp_path / "blocked" / "trajectory.npz"
    (tmp_path / "blocked").mkdir()
    target.mkdir()                              # a folder where the file goes: the write fails
    written = []
    for i in range(2):
        def write(path, root, i=i):
            return safeio.write_bytes(path, f"run {i}".encode(), root)
        path, msg = safeio.write_or_fallback(write, target)
        assert path is not None and msg is not None
        written.append(path)
    assert written[0] != written[1]
    assert [Path(p).read_bytes() for p in written] == [b"run 0", b"run 1"]


def test_a_sweep_point_corrupt_twice_keeps_both(tmp_path, capsys):
    from pinclear.analysis import sweeps

    npz = tmp_path / "p0.npz"
    for i in range(2):
        npz.write_bytes(b"not a zip %d" % i)
        status, _, _ = sweeps._status_from_file(npz, tmp_path / "p0.json")
        assert status == "pending"
    assert (tmp_path / "p0.npz.corrupt").read_bytes() == b"not a zip 0"
    assert (tmp_path / "p0.npz.corrupt.1").read_bytes() == b"not a zip 1"
    err = capsys.readouterr().err
    assert "moved to p0.npz.corrupt.1" in err


# ----------------------------------------------------------------------------- read back
@pytest.fixture(scope="module")
def single_sample_failed_run(tmp_path_factory):
    """A failed run that kept a single sample, saved as the command line saves it."""
    from pinclear.cli import commands

    out = tmp_path_factory.mktemp("failed")
    code = commands.main(["simulate", "four_bar", "--t-end", "100", "--dt-out", "50", "--max-cpu", "1e-9",
                          "--out", str(out), "--progress", "off"])
    assert code == 1
    tr = pinclear.Trajectory.load(out / "trajectory.npz") if hasattr(pinclear, "Trajectory") else None
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "failed"
    if tr is not None:
        assert len(tr.t) == 1
    return out / "trajectory.npz"


@pytest.mark.slow
def test_a_failed_single_sample_run_is_viewed(single_sample_failed_run, tmp_path, capsys):
    code, _, err = run_cli(["view", str(single_sample_failed_run), "--html", str(tmp_path / "v.html")], capsys)
    assert code in (0, 2), (code, err)
    if code == 2:
        _one_line(code, err)
    else:
        assert (tmp_path / "v.html").stat().st_size > 0
