"""The command line helps: --help on every subcommand, --version, the command list, help text
and defaults on every option, the registries' method and integrator names, and numeric options
that refuse nan/inf with a one-line error naming the option."""
from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import pytest

import pinclear
from pinclear.cli import analyse as analysis_cli
from pinclear.cli import commands as cli
from pinclear.cli import inverse_dynamics as screw_cli
from pinclear.cli import view as viz_cli
from pinclear.cli.reproduce import build_parser as reproduce_parser
from pinclear.dynamics.formulations import METHODS
from pinclear.dynamics.stepping import INTEGRATORS

ROOT = Path(__file__).resolve().parents[2]
COMMANDS = ["simulate", "sweep", "info", "bench", "warmup", "view", "plot", "inverse-dynamics", "analyse",
            "reproduce", "import", "export", "export-run", "wear", "study"]


def _main(argv):
    """cli.main as the entry point runs it: a SystemExit (argparse's --help) is its exit code."""
    try:
        return cli.main(argv)
    except SystemExit as exc:
        return int(exc.code or 0)


def _parsers():
    """(name, parser) of every parser a user reaches, the delegated subcommands' included."""
    top = cli.build_parser()
    sub = next(a for a in top._actions if isinstance(a, argparse._SubParsersAction))
    out = [("pinclear", top)] + [(n, p) for n, p in sub.choices.items() if not p.passthrough]
    an = analysis_cli.build_parser()
    an_sub = next(a for a in an._actions if isinstance(a, argparse._SubParsersAction))
    out += [("analyse", an)] + [(f"analyse {n}", p) for n, p in an_sub.choices.items()]
    out += [("view", viz_cli.build_view_parser()), ("plot", viz_cli.build_plot_parser()),
            ("inverse-dynamics", screw_cli.build_parser()), ("reproduce", reproduce_parser())]
    from pinclear.cli import export, export_run, importing, study, wear

    out += [("import", importing.build_parser()), ("export", export.build_parser()),
            ("export-run", export_run.build_parser())]
    out += [("wear", wear.build_parser()), ("study", study.build_parser())]
    return out


def _options(parser):
    return [a for a in parser._actions if a.help is not argparse.SUPPRESS
            and not isinstance(a, (argparse._HelpAction, argparse._VersionAction, argparse._SubParsersAction))]


def test_every_subcommand_is_listed():
    top = cli.build_parser()
    sub = next(a for a in top._actions if isinstance(a, argparse._SubParsersAction))
    assert sorted(sub.choices) == sorted(COMMANDS)


@pytest.mark.parametrize("command", COMMANDS + ["analyse bifurcation", "analyse poincare"])
def test_help_of_every_subcommand_exits_0(command, capsys):
    assert _main(command.split() + ["--help"]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"usage: pinclear {command}"), out[:200]


@pytest.mark.slow
def test_version_and_bare_invocation_from_the_entry_point():
    """`pinclear --version` prints the version; `pinclear` alone prints the command list, exit 2."""
    r = subprocess.run([sys.executable, "-m", "pinclear.cli", "--version"], capture_output=True, text=True,
                       timeout=300, cwd=ROOT)
    assert r.returncode == 0 and r.stdout.startswith(f"pinclear {pinclear.__version__}"), r
    assert "C++ extension pinclear.model._passes: " in r.stdout and "kernel cache: " in r.stdout
    r = subprocess.run([sys.executable, "-m", "pinclear.cli"], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert r.returncode == 2
    assert all(c in r.stdout for c in COMMANDS), r.stdout


@pytest.mark.parametrize("name, parser", _parsers(), ids=lambda x: x if isinstance(x, str) else "")
def test_every_option_has_help_and_shows_its_default(name, parser):
    for a in _options(parser):
        assert a.help and a.help.strip(), f"{name} {a.option_strings or a.dest}: no help text"
        shown = parser._get_formatter()._expand_help(a) if a.help else ""
        if a.option_strings and a.default not in (None, False, [], argparse.SUPPRESS):
            assert "default" in shown, f"{name} {a.option_strings}: default {a.default!r} not shown"
        # numbers go through the finite-number types (float('nan') would parse)
        assert a.type is not float, f"{name} {a.option_strings}: type=float accepts nan"


@pytest.mark.parametrize("name, parser", _parsers(), ids=lambda x: x if isinstance(x, str) else "")
def test_every_numeric_option_refuses_nan_and_inf(name, parser):
    for a in _options(parser):
        if a.type is None or a.type is int or not callable(a.type) or a.type.__name__ not in (
                "positive number", "nonnegative number", "any number", "whole number"):
            continue
        for bad in ("nan", "inf", "-inf"):
            with pytest.raises(argparse.ArgumentTypeError):
                a.type(bad)


@pytest.mark.parametrize("argv, option", [
    (["simulate", "four_bar", "--t-end", "1", "--max-cpu", "nan"], "--max-cpu"),
    (["simulate", "four_bar", "--t-end", "1", "--checkpoint-every", "nan"], "--checkpoint-every"),
    (["simulate", "four_bar", "--t-end", "inf"], "--t-end"),
    (["simulate", "four_bar", "--t-end", "1", "--rtol", "-1e-6"], "--rtol"),
    (["sweep", "four_bar", "--vary", "x=1", "--t-end", "1", "--out", "o", "--max-cpu", "inf"], "--max-cpu"),
    (["bench", "atlas", "--budget", "nan"], "--budget"),
    (["info", "four_bar", "--threshold", "nan"], "--threshold"),
    (["view", "four_bar", "--force-scale", "inf"], "--force-scale"),
    (["analyse", "poincare", "x.npz", "--period", "nan", "--signal", "s"], "--period"),
    (["inverse-dynamics", "four_ups_upr", "--t-end", "nan"], "--t-end"),
])
def test_nan_and_inf_options_are_one_line_errors_naming_the_option(argv, option, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert _main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("pinclear: error: ") and option in err, err
    assert not list(tmp_path.iterdir())          # refused before anything ran or was written


@pytest.mark.parametrize("command", ["simulate", "sweep", "analyse bifurcation"])
def test_method_and_integrator_choices_are_the_registries(command):
    parser = dict(_parsers())[command]
    acts = {a.dest: a for a in parser._actions}
    assert list(acts["method"].choices) == list(METHODS) and "manifold" in METHODS
    assert list(acts["integrator"].choices) == list(INTEGRATORS)


@pytest.mark.parametrize("argv", [["reproduce"], ["plot"], ["analyse"], ["simulate", "--method", "x"],
                                  ["view", "four_bar", "--size", "nope", "--html", "x.html"]])
def test_usage_errors_are_one_line(argv, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert _main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("pinclear: error: "), err


@pytest.mark.slow
def test_version_says_whether_the_extension_is_in_use_from_any_folder(tmp_path):
    """The README's extension check: `pinclear --version` reports the imported package's
    extension and why it is not in use, run from any folder."""
    import os

    from pinclear.model import native

    env = {**os.environ, "PYTHONPATH": str(Path(pinclear.__file__).resolve().parents[1])}
    r = subprocess.run([sys.executable, "-m", "pinclear.cli", "--version"], capture_output=True, text=True,
                       timeout=300, cwd=tmp_path, env=env)
    assert r.returncode == 0
    assert ("C++ extension pinclear.model._passes: in use" in r.stdout) == native.available(), r.stdout
    r = subprocess.run([sys.executable, "-m", "pinclear.cli", "--version"], capture_output=True, text=True,
                       timeout=300, cwd=tmp_path, env={**env, "PINCLEAR_NATIVE": "0"})
    assert "not in use: turned off by PINCLEAR_NATIVE=0" in r.stdout, r.stdout
