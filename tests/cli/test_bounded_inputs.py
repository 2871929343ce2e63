"""Every file pinclear reads is a bounded regular file, whatever option names it (issue 53, item 5).

The options are found by walking the command-line parsers (pinclear.cli): every positional or
option that takes a free string must be listed below as a file read, a file written or not a
path, so a new option cannot escape the test. Each option that reads is then given a FIFO (an
open for reading blocks until a writer comes), a folder, /dev/zero (size 0, never ends) and a
5 GiB sparse file (no disk used; a reader without a bound would read or allocate it), and must
answer with exit 2 and one line naming the path, within a time bound. A FIFO a reader blocks on
is released after the bound by opening it for writing, so a failure is a failure, not a hang."""
from __future__ import annotations

import argparse
import importlib
import os
import signal
import time

import pytest

from pinclear.cli.commands import COMMANDS, build_parser

#: seconds one refusal may take (the first call of a command imports its modules; under the
#: shared machine's load that is the bulk)
BOUND_S = 60.0

# How each option that reads a file is given the hostile path P: argv with P placed. A folder
# option (--resume DIR, --wear OUT) reads fixed names inside it: the hostile entry is made there.
READS = {
    ("simulate", "file"): lambda p, d: ["simulate", p, "--t-end", "0.01", "--out", d],
    ("simulate", "--start"): lambda p, d: ["simulate", "four_bar", "--t-end", "0.01", "--start", "state", p,
                                           "--out", d],
    # the first file --resume reads (then checkpoint.npz, through read_npz's checks)
    ("simulate", "--resume"): "folder:run.json",
    ("sweep", "file"): lambda p, d: ["sweep", p, "--vary", "crank.mu=0.1,0.2", "--t-end", "0.01", "--out", d],
    ("info", "file"): lambda p, d: ["info", p],
    ("bench", "file"): lambda p, d: ["bench", "runs", p, "--out", d],
    ("warmup", "files"): lambda p, d: ["warmup", p],
    ("view", "file"): lambda p, d: ["view", p, "--html", os.path.join(d, "v.html")],
    ("view", "--mech"): "run:view",
    ("view", "--wear"): "folder:profile.csv",
    ("reproduce", "--from"): "folder:004/report.json",
    ("plot", "file"): lambda p, d: ["plot", p, "--out", d],
    ("plot", "--ref"): "run:plot-ref",
    ("plot", "--mech"): "run:plot",
    ("inverse-dynamics", "sidecar"): lambda p, d: ["inverse-dynamics", p, "--out", d],
    ("analyse bifurcation", "file"): lambda p, d: ["analyse", "bifurcation", p, "--param", "crank.mu",
                                                    "--values", "0.1,0.2", "--signal", "crank_joint", "--period", "0.1", "--out", d],
    ("analyse bifurcation", "--mech"): lambda p, d: ["analyse", "bifurcation", "--mech", p, "--param", "crank.mu",
                                                      "--values", "0.1,0.2", "--signal", "crank_joint", "--period", "0.1", "--out", d],
    ("analyse poincare", "trajectory"): lambda p, d: ["analyse", "poincare", p, "--signal", "crank_joint", "--period", "0.1",
                                                              "--out", d],
    ("analyse poincare", "--mech"): "run:poincare",
    ("import", "file"): lambda p, d: ["import", p, "--out", d],
    ("export", "file"): lambda p, d: ["export", p, "--mjcf", os.path.join(d, "o.xml")],
    ("export-run", "run"): lambda p, d: ["export-run", p, "--csv", os.path.join(d, "o.csv")],
    ("wear", "file"): lambda p, d: ["wear", p, "--clearance", "B", "--cycles", "10", "--period", "0.1",
                                    "--out", d],
}
#: options naming what pinclear writes (tests/core/test_security_links.py covers those)
WRITES = {"--out", "--html", "--screenshot", "--mjcf", "--csv", "--mat"}
#: free-string options that are not paths
NOT_PATHS = {"--clearance", "--set", "--option", "--vary", "--scheduler", "--methods", "--integrators", "rest",
             "--size", "--zmq-url", "--frame", "--law", "--param", "--values", "--signal", "--cut", "--fix",
             "--name"}


def _parsers():
    yield "", build_parser()
    for name in COMMANDS:
        mod = importlib.import_module(COMMANDS[name].target.split(":")[0])
        yield name, getattr(mod, {"view": "build_view_parser", "plot": "build_plot_parser"}.get(name, "build_parser"))()


def string_options():
    """(command, option) of every action taking a free string, over all parsers and subparsers."""
    def walk(p, prefix):
        for a in p._actions:
            if isinstance(a, argparse._SubParsersAction):
                for name, sp in a.choices.items():
                    yield from walk(sp, f"{prefix} {name}".strip())
            elif a.type is None and a.nargs != 0 and not a.choices and "-h" not in a.option_strings:
                yield prefix, (a.option_strings[-1] if len(a.option_strings) == 1 else a.option_strings[0]) \
                    if a.option_strings else a.dest

    for prefix, parser in _parsers():
        yield from walk(parser, prefix)


def test_every_string_option_is_classified():
    found = set(string_options())
    unknown = {(c, o) for c, o in found if (c, o) not in READS and o not in WRITES | NOT_PATHS}
    assert not unknown, f"classify these options in READS, WRITES or NOT_PATHS: {sorted(unknown)}"
    stale = set(READS) - found
    assert not stale, f"no longer options of pinclear: {sorted(stale)}"


def _hostile(kind: str, where: str) -> str:
    if kind == "dev_zero":
        return "/dev/zero"
    if kind == "fifo":
        os.mkfifo(where)
    elif kind == "folder":
        os.mkdir(where)
    elif kind == "oversize":
        with open(where, "wb") as fh:
            fh.truncate(5 << 30)
    return where


@pytest.fixture(scope="module")
def saved_run(tmp_path_factory):
    """A short run of the four-bar, saved as the command line saves it."""
    from pinclear.cli import commands

    out = tmp_path_factory.mktemp("run")
    assert commands.main(["simulate", "four_bar", "--t-end", "0.02", "--dt-out", "0.01", "--out", str(out),
                          "--progress", "off"]) == 0
    return out / "trajectory.npz"


def _argv(cmd_opt, path_kind, tmp_path, saved_run):
    """The command line for ``cmd_opt`` with a hostile entry of ``path_kind``, and the path named."""
    how = READS[cmd_opt]
    out = str(tmp_path / "out")
    if callable(how):
        p = _hostile(path_kind, str(tmp_path / "hostile.yaml"))
        if cmd_opt in {("view", "file"), ("plot", "file"), ("analyse poincare", "trajectory")} and path_kind != "dev_zero":
            os.rename(p, str(tmp_path / "hostile.npz"))
            p = str(tmp_path / "hostile.npz")
        return how(p, out), p
    kind, _, arg = how.partition(":")
    if kind == "folder":
        folder = tmp_path / "folder"
        folder.mkdir()
        target = str(folder / arg)
        os.makedirs(os.path.dirname(target), exist_ok=True)
        if path_kind == "dev_zero":
            os.symlink("/dev/zero", target)
        else:
            _hostile(path_kind, target)
        if cmd_opt == ("simulate", "--resume"):
            return ["simulate", "four_bar", "--t-end", "0.02", "--resume", str(folder), "--out", str(folder)], target
        if cmd_opt == ("reproduce", "--from"):
            return ["reproduce", "claims", "--from", str(folder), "--out", str(tmp_path / "claims.md")], target
        return ["view", "four_bar", "--wear", str(folder), "--html", str(tmp_path / "v.html")], target
    p = _hostile(path_kind, str(tmp_path / "hostile.yaml"))
    run = str(saved_run)
    return {"view": ["view", run, "--mech", p, "--html", str(tmp_path / "v.html")],
            "plot": ["plot", run, "--mech", p, "--out", out],
            "plot-ref": ["plot", run, "--ref", p, "--out", out],
            "poincare": ["analyse", "poincare", run, "--mech", p, "--signal", "crank_joint", "--period", "0.1",
                         "--out", out]}[arg], p


@pytest.mark.slow
@pytest.mark.parametrize("path_kind", ["fifo", "folder", "dev_zero", "oversize"])
@pytest.mark.parametrize("cmd_opt", sorted(READS), ids=lambda c: f"{c[0]} {c[1]}".replace(" ", "-"))
def test_a_hostile_file_is_one_line_at_once(cmd_opt, path_kind, tmp_path, saved_run, capsys, monkeypatch):
    from pinclear.cli import commands

    monkeypatch.setenv("PINCLEAR_TRUST", "0")
    argv, named = _argv(cmd_opt, path_kind, tmp_path, saved_run)
    result = {}

    def alarm(signum, frame):
        raise TimeoutError(f"still running after {BOUND_S:g} s")

    # the command runs in this thread (it installs its own signal handlers); SIGALRM interrupts a
    # blocking open of a FIFO or a long read
    previous = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, BOUND_S)
    t0 = time.monotonic()
    try:
        result["code"] = commands.main(argv)
    except SystemExit as exc:
        result["code"] = exc.code
    except TimeoutError as exc:
        result["hung"] = str(exc)
    except Exception as exc:  # noqa: BLE001 (reported below)
        result["exc"] = exc
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    elapsed = time.monotonic() - t0
    err = capsys.readouterr().err.strip()
    assert "hung" not in result, f"{argv} {result['hung']}"
    assert "exc" not in result, f"{argv}: {result.get('exc')!r}"
    assert result.get("code") == 2, (argv, result, err)
    assert "Traceback" not in err, err
    # progress lines (warmup's "warmup: NAME") may come first; one error line, naming the path
    lines = [ln for ln in err.splitlines() if not ln.startswith(("warmup:", "pinclear: compiling"))]
    assert len(lines) == 1 and lines[0].startswith("pinclear: error:"), err
    assert os.path.basename(named) in lines[0] or named in lines[0], (named, lines[0])
    assert elapsed < BOUND_S


@pytest.mark.parametrize("kind", ["fifo", "folder", "dev_zero", "oversize"])
def test_the_bounded_reader_refuses_each_kind_at_once(kind, tmp_path):
    """The one reader all of the above go through (pinclear.core.bounded)."""
    from pinclear.core.bounded import read_bounded
    from pinclear.core.errors import ModelFileError

    p = _hostile(kind, str(tmp_path / "x"))
    t0 = time.monotonic()
    with pytest.raises(ModelFileError, match="x" if kind != "dev_zero" else "zero") as e:
        read_bounded(p, 1 << 20, "path", "test")
    assert time.monotonic() - t0 < 2.0
    assert "\n" not in str(e.value)
