"""One option names the mechanism file of a run: `--mech FILE.yaml` (`--file` kept as an alias) in
plot, view, analyse poincare and analyse bifurcation. A run of a mechanism that is not bundled is
plotted, viewed and analysed with it; without it the command stops with one line that names
`--mech` and the subcommand's own --help (issue 52, item 3)."""
from __future__ import annotations

import argparse
import shutil

import pytest

import pinclear
from pinclear.cli import analyse as analysis_cli
from pinclear.cli import commands as cli
from pinclear.cli import view as viz_cli
from pinclear.core.errors import ModelFileError
from pinclear.core.models import model_path
from tests.helpers import DATA

OSC = DATA / "analysis_oscillator.yaml"


def _main(argv, capsys):
    """cli.main as the entry point runs it (argparse's SystemExit is its exit code): (code, out, err)."""
    try:
        code = cli.main([str(a) for a in argv])
    except SystemExit as exc:
        code = int(exc.code or 0)
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture(scope="module")
def own(tmp_path_factory):
    """A run of the four-bar copied under another name (not a bundled mechanism): (sidecar, run)."""
    d = tmp_path_factory.mktemp("own")
    shutil.copy(model_path("four_bar").with_suffix(".urdf"), d / "four_bar.urdf")
    shutil.copy(model_path("four_bar"), d / "my_linkage.yaml")
    tr = pinclear.simulate(pinclear.load(d / "my_linkage.yaml"), 0.3, dt_out=0.01)
    return d / "my_linkage.yaml", tr.save(d / "run.npz")


def _argv(cmd, run, out):
    return {"plot": ["plot", run, "--out", out],
            "view": ["view", run, "--html", out / "run.html"],
            "analyse poincare": ["analyse", "poincare", run, "--period", "0.1", "--signal", "crank_joint",
                                 "--out", out]}[cmd]


RUN_COMMANDS = ["plot", "view", "analyse poincare"]


@pytest.mark.parametrize("cmd", RUN_COMMANDS)
@pytest.mark.parametrize("option", ["--mech", "--file"])
def test_a_run_of_an_own_mechanism_with_mech_or_its_alias(own, tmp_path, capsys, cmd, option):
    sidecar, run = own
    code, out, err = _main(_argv(cmd, run, tmp_path / "o") + [option, sidecar], capsys)
    assert code == 0, err
    written = {"plot": "energy.png", "view": "run.html", "analyse poincare": "poincare_crank_joint.png"}[cmd]
    assert (tmp_path / "o" / written).is_file()


@pytest.mark.parametrize("cmd", RUN_COMMANDS)
def test_without_mech_one_line_naming_mech_and_the_subcommands_help(own, tmp_path, capsys, cmd):
    _, run = own
    code, out, err = _main(_argv(cmd, run, tmp_path / "o"), capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert err.startswith("pinclear: error: ") and "not a bundled mechanism" in err
    assert "--mech FILE.yaml" in err and err.rstrip().endswith(f"(see pinclear {cmd} --help)"), err
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())


def test_the_library_error_names_both_ways(own):
    _, run = own
    with pytest.raises(ModelFileError, match=r"--mech FILE.yaml on the command line, or Trajectory.load_mechanism"):
        pinclear.Trajectory.load(run).load_mechanism()


def test_a_bad_poincare_argument_points_to_poincare_help(own, tmp_path, capsys):
    _, run = own
    code, _, err = _main(_argv("analyse poincare", run, tmp_path / "o") + ["--bogus"], capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "unrecognized arguments: --bogus" in err and "(see pinclear analyse poincare --help)" in err, err


@pytest.fixture(scope="module")
def own_oscillator(tmp_path_factory):
    d = tmp_path_factory.mktemp("osc")
    shutil.copy(OSC.with_suffix(".urdf"), d / "analysis_oscillator.urdf")
    shutil.copy(OSC, d / "my_oscillator.yaml")
    return d / "my_oscillator.yaml"


def _bif(out):
    return ["analyse", "bifurcation", "--param", "forces[push].law.terms[0].omega", "--values", "4",
            "--period-from-speed", "--signal", "slide", "--cycles", "1", "--transient", "0",
            "--per-period", "4", "--workers", "1", "--out", out]


@pytest.mark.parametrize("how", ["--mech", "--file", "FILE"])
def test_bifurcation_takes_the_sidecar_as_mech_alias_or_file(own_oscillator, tmp_path, capsys, how):
    argv = _bif(tmp_path / "b") + ([own_oscillator] if how == "FILE" else [how, own_oscillator])
    code, out, err = _main(argv, capsys)
    assert code == 0, err
    assert (tmp_path / "b" / "bifurcation.npz").is_file() and "slide:" in out


@pytest.mark.parametrize("extra, says", [([], "missing: give --mech FILE.yaml"),
                                         (["a.yaml", "--mech", "b.yaml"], "given twice")])
def test_bifurcation_without_or_with_two_mechanisms(tmp_path, capsys, monkeypatch, extra, says):
    monkeypatch.chdir(tmp_path)
    code, _, err = _main(_bif("b") + extra, capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1 and says in err, err
    assert err.rstrip().endswith("(see pinclear analyse bifurcation --help)"), err
    assert not list(tmp_path.iterdir())


def _sub(name):
    an = analysis_cli.build_parser()
    return next(a for a in an._actions if isinstance(a, argparse._SubParsersAction)).choices[name]


@pytest.mark.parametrize("parser", [viz_cli.build_plot_parser, viz_cli.build_view_parser,
                                    lambda: _sub("poincare"), lambda: _sub("bifurcation")])
def test_mech_is_the_option_and_file_its_alias(parser):
    act = next(a for a in parser()._actions if "--mech" in a.option_strings)
    assert act.option_strings == ["--mech", "--file"] and act.dest == "mech" and "sidecar" in act.help
