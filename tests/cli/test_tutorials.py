"""The tutorials run as written: every ```bash and ```python block of docs/tutorial.md and
docs/tutorial_spatial.md, in order, verbatim, in an empty folder, and every number the text
quotes from them agrees with what the run printed within the tolerance stated beside it here
(issue 52, item 2). Untagged blocks are output or drawings and are not run.

PINCLEAR_TUTORIAL_T_END=T may only shorten the runs (each `--t-end X` becomes min(X, T)); the
quoted numbers are then not checked (they belong to the full runs). The fast tests check that
every block parses, that every quote here is in the text and states its tolerance and reason.
"""
from __future__ import annotations

import ast
import contextlib
import io
import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = {"tutorial": ROOT / "docs" / "tutorial.md", "tutorial_spatial": ROOT / "docs" / "tutorial_spatial.md"}
T_END_ENV = "PINCLEAR_TUTORIAL_T_END"
_BLOCK = re.compile(r"^```(\w*)[^\n]*\n(.*?)^```\s*$", re.MULTILINE | re.DOTALL)


def blocks(doc):
    """[(language, code)] of the fenced blocks of ``doc`` in order."""
    return [(m.group(1), m.group(2)) for m in _BLOCK.finditer(DOCS[doc].read_text(encoding="utf-8"))]


def _num(pattern):
    """The first number after ``pattern`` (a regex) in a text."""
    def get(text):
        m = re.search(pattern + r"\s*([-+]?[0-9.]+(?:e[-+]?[0-9]+)?)", text)
        assert m, f"no {pattern!r} in the output"
        return float(m.group(1))
    return get


def _summary(run, *keys):
    def get(_text, cwd):
        s = json.loads((cwd / "out" / run / "summary.json").read_text())
        for k in keys:
            s = s[k]
        return float(s)
    return get


# (doc, the quote as the text has it, its value, |measured - value| allowed, why that tolerance,
#  the measurement: f(all output printed by the blocks) or f(output, folder))
QUOTES = [
    ("tutorial", "rank 4, condition 3.88", 3.88, 0.01,
     "the closures' Jacobian at the assembled start: geometry, round-off only; the quote has 3 digits",
     _num(r"4 rows, rank 4, condition")),
    ("tutorial", '"rhs_evals": 1160', 1160, 60,
     "+-5%: the step sequence moves with the library builds (the text names the versions)",
     _num(r'"mobility": 3,.*?"rhs_evals":')),
    ("tutorial", '"rhs_evals": 119508', 119508, 6000, "+-5%, as above: the clearance run",
     _num(r'"mobility": 5,.*?"rhs_evals":')),
    ("tutorial", "P2: 197 N", 197.0, 2.0,
     "+-1%: the peak over accepted steps moves with the step sequence of another library build",
     _summary("rrr3_P2", "contact_force_peaks", "P2")),
    ("tutorial", "at 15.4 ms", 15.4e-3, 0.2e-3, "the landing's time: +-0.2 ms, a fraction of the impact",
     _summary("rrr3_P2", "contact_force_peak_times", "P2")),
    ("tutorial", "| 1e-4 | success | 81 | 10077 |", 81, 8,
     "+-10%: an impact near grazing counts or not as the steps fall (events are the contact's switchings)",
     lambda _t, cwd: float(np.load(cwd / "out" / "rrr3_sweep" / "table.npz")["events"][0])),
    ("tutorial", "shrink by about 0.8-0.9 per cycle", 0.85, 0.1,
     "an unresolved section's ratio moves with round-off (0.84 and 0.91 on two machines): contracting, "
     "within the quoted span +-0.05",
     lambda _t, cwd: float(re.search(r"shrink by about ([0-9.]+)", (cwd / "out" / "rrr3_poincare" / "poincare.json")
                                     .read_text()).group(1))),
    ("tutorial", '`"kind": "period-4"`', 4, 0, "a period is an integer: exact",
     lambda _t, cwd: float(json.loads((cwd / "out" / "rrr3_poincare" / "poincare.json").read_text())
                           ["P2.eccentricity[0]"]["period"])),
    ("tutorial_spatial", "6 rows, rank 6, condition 8.49", 8.49, 0.01,
     "the closures' Jacobian at the assembled start: geometry, round-off only; the quote has 3 digits",
     _num(r"6 rows, rank 6, condition")),
    ("tutorial_spatial", "90 deg from its lock at t = 0", 90.0, 1e-6,
     "write() turns the chain to the assembled start: q2 = 0 to round-off", _num(r"spherical chain S1 [^:]*:")),
    ("tutorial_spatial", "balance: 5.1e-04 of the drives' work", 5.1e-4, 0.6e-4,
     "the trapezoidal rule's error on fixed samples: +-10% covers the integrator's rtol 1e-8 and the 2 digits",
     _num(r"balance:")),
    ("tutorial_spatial", "(0.0082 J)", 0.0082, 0.0001, "the drives' work, 2 digits", _num(r"drives' work \(")),
    ("tutorial_spatial", "halving dt_out: / 4.00", 4.0, 0.2,
     "second order: the ratio tends to 4; +-5% for the higher-order terms at a 4 ms grid", _num(r"halving dt_out: /")),
    ("tutorial_spatial", "S2 peak 1083 N", 1083.0, 11.0,
     "+-1%: the peak over accepted steps moves with the step sequence of another library build",
     _summary("rps3_S2", "contact_force_peaks", "S2")),
    ("tutorial_spatial", "at 10.3 ms", 10.3e-3, 0.2e-3, "the landing's time: +-0.2 ms, a fraction of the impact",
     _summary("rps3_S2", "contact_force_peak_times", "S2")),
    ("tutorial_spatial", "relative difference 3e-07", 3e-7, 1e-5,
     "two formulations at rtol 1e-8: agreement within 1e-5 (the quote's order of magnitude is a build's)",
     _num(r"relative difference")),
    ("tutorial_spatial", "difference in q of `5e-07`", 5e-7, 1e-5,
     "as above, for the configurations (m or rad)", _num(r"largest difference in q:")),
    ("tutorial_spatial", "S1 stays 72 deg or more", 72.0, 1.0, "the smallest margin along the samples, 2 digits",
     _num(r"S1 stays")),
]


@pytest.mark.parametrize("doc", sorted(DOCS))
def test_every_block_parses_and_every_command_is_pinclears_or_pythons(doc):
    found = blocks(doc)
    assert any(lang == "bash" for lang, _ in found) and any(lang == "python" for lang, _ in found)
    for lang, code in found:
        if lang == "python":
            ast.parse(code)
        elif lang == "bash":
            for line in _commands(code):
                assert shlex.split(line)[0] in ("pinclear", "python", "mkdir", "cp"), line


@pytest.mark.parametrize("quote", QUOTES, ids=lambda q: f"{q[0]}:{q[1][:30]}")
def test_every_quote_is_in_the_text_with_a_tolerance_and_its_reason(quote):
    doc, text, value, tol, why, _ = quote
    assert text in DOCS[doc].read_text(encoding="utf-8"), f"{doc}: {text!r} is not in the text"
    assert 0 <= tol and len(why.split()) >= 4
    assert re.search(r"[0-9]", text) and np.isfinite(value)


def _commands(code):
    """The commands of a bash block (lines joined at a trailing backslash)."""
    return [c.strip() for c in code.replace("\\\n", " ").splitlines() if c.strip() and not c.strip().startswith("#")]


def _shorten(line):
    cap = os.environ.get(T_END_ENV)
    if not cap:
        return line
    return re.sub(r"--t-end (\S+)", lambda m: f"--t-end {min(float(m.group(1)), float(cap)):g}", line)


def run_tutorial(doc, cwd: Path) -> str:
    """Run the blocks of ``doc`` in order in ``cwd``: bash lines as processes, python blocks in
    one namespace in this process. Returns everything they printed."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    bindir = Path(sys.executable).parent
    env["PATH"] = str(bindir) + os.pathsep + env.get("PATH", "")
    printed, ns = [], {"__name__": "__tutorial__"}
    for lang, code in blocks(doc):
        if lang == "bash":
            for line in _commands(code):
                argv = shlex.split(_shorten(line))
                if argv[0] == "pinclear":
                    argv = [sys.executable, "-m", "pinclear.cli", *argv[1:]]
                elif argv[0] == "python":
                    argv[0] = sys.executable
                out = subprocess.run(argv, check=False, cwd=cwd, env=env, capture_output=True, text=True, timeout=1800)
                assert out.returncode == 0, f"{line}\n{out.stderr[-3000:]}"
                printed.append(out.stdout)
        elif lang == "python":
            buf = io.StringIO()
            old = Path.cwd()
            os.chdir(cwd)
            try:
                with contextlib.redirect_stdout(buf):
                    exec(compile(code, f"<{doc}.md>", "exec"), ns)   # noqa: S102 (the docs' own code: the test)
            finally:
                os.chdir(old)
            printed.append(buf.getvalue())
    return "\n".join(printed)


@pytest.mark.slow
@pytest.mark.parametrize("doc", sorted(DOCS))
def test_the_tutorial_runs_as_written_and_prints_what_it_quotes(doc, tmp_path):
    if doc == "tutorial":
        (tmp_path / "examples").symlink_to(ROOT / "examples")      # the tutorial runs in a clone's root
    printed = run_tutorial(doc, tmp_path)
    if os.environ.get(T_END_ENV):
        pytest.skip(f"{T_END_ENV} shortened the runs: the quoted numbers are the full runs'")
    for qdoc, text, value, tol, why, measure in QUOTES:
        if qdoc != doc:
            continue
        got = measure(printed) if measure.__code__.co_argcount == 1 else measure(printed, tmp_path)
        assert np.isfinite(got) and abs(got - value) <= tol, f"{doc}: {text!r}: measured {got:g} ({why})"


@pytest.mark.slow
def test_info_prints_a_spherical_chains_distance_to_its_lock(tmp_path, capsys):
    """The builder's chain starts 90 deg from its lock; a start at q2 = 0.5 rad (edited in the
    sidecar by hand) is 90 deg - 0.5 rad away (pinclear.model.joint_chains: 90 deg - |q2|)."""
    from pinclear.cli import commands as cli
    from pinclear.io.builder import Builder

    b = Builder("ball").body("bob", 2.0, com=(0, 0, -0.5), inertia=(0.01, 0.02, 0.03))
    b.joint("S", "spherical", "ground", "bob", xyz=(0, 0, 1.0), q=(0.1, 0.2, 0.3))
    b.write(tmp_path)
    assert cli.main(["info", str(tmp_path / "ball.yaml")]) == 0
    out = capsys.readouterr().out
    assert "spherical chain S (3 revolute axes at one point): 90 deg from its lock at t = 0" in out, out
    sidecar = tmp_path / "ball.yaml"
    sidecar.write_text(sidecar.read_text().replace("S_2: 0.0", "S_2: 0.5"))
    assert cli.main(["info", str(sidecar), "--json"]) == 0
    margin = json.loads(capsys.readouterr().out)["lock_margins_deg"]["S"]
    assert margin == pytest.approx(90.0 - np.degrees(0.5), abs=1e-9)
