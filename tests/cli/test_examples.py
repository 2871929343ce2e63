"""Every example script runs in its quick smoke mode (marked ``examples``: CI runs them with
``pytest -m examples``; a plain ``pytest -q`` skips them). Each run must also print numbers
that physics bounds: a closed loop stays closed, a prescribed motion is tracked."""
from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.examples


def _out(tmp_path):
    """The output folder an example is given: new, two levels deep, as a user's first run."""
    return tmp_path / "new" / "dir"


def run_example(name, tmp_path, *args, timeout=900):
    """The example as a user runs it, in quick mode, into a folder that does not exist yet (the
    example creates it)."""
    assert not _out(tmp_path).exists()
    out = subprocess.run([sys.executable, str(ROOT / "examples" / name), *args, "--quick", "--out",
                          str(_out(tmp_path))], cwd=tmp_path, capture_output=True, text=True, timeout=timeout)
    assert out.returncode == 0, out.stderr[-3000:]
    return out.stdout


@pytest.mark.parametrize("script", sorted(p.name for p in (ROOT / "examples").glob("*.py")))
def test_every_example_documents_quick_in_its_header(script):
    doc = ast.get_docstring(ast.parse((ROOT / "examples" / script).read_text(encoding="utf-8")))
    assert doc and "--quick" in doc, f"{script}: the header docstring does not say what --quick does"


def number(text, label):
    m = re.search(label + r"\s+([-+0-9.eE]+)", text)
    assert m, f"{label!r} not printed in:\n{text}"
    return float(m.group(1))


@pytest.mark.parametrize("script, png", [("four_ups_upu_ideal.py", "four_ups_upu_ideal.png"),
                                         ("nine_bar_ideal.py", "nine_bar_ideal.png"),
                                         ("three_upru_up_ideal.py", "three_upru_up_ideal.png")])
def test_ideal_examples(tmp_path, script, png):
    text = run_example(script, tmp_path)
    assert "status success" in text
    # the loops stay closed to the integrator's tolerance (rtol 1e-8 on metre-sized links)
    assert number(text, "max closure residual") < 1e-6
    assert (_out(tmp_path) / png).stat().st_size > 10_000


def test_four_ups_upr_ideal(tmp_path):
    text = run_example("four_ups_upr_ideal.py", tmp_path)
    assert "status success" in text
    assert number(text, "max closure residual") < 1e-6
    assert (_out(tmp_path) / "four_ups_upr_ideal_high.png").stat().st_size > 10_000


def test_four_ups_upr_inverse_dynamics(tmp_path):
    """Paper 004's layouts: (a)-(e) are singular at the initial pose (rank 5 of 6), (f), the
    layout the paper builds, is not (rank 6, well conditioned)."""
    text = run_example("four_ups_upr_inverse_dynamics.py", tmp_path)
    for lay in "abcde":
        assert re.search(rf"\({lay}\) of Fig. 2 at the initial configuration: rank 5 of 6", text), text
    assert number(text, r"\(f\) of Fig. 2 at the initial configuration: rank 6 of 6, condition") < 1e3
    assert (_out(tmp_path) / "drive_forces.png").stat().st_size > 10_000


def test_view_mechanism(tmp_path):
    """The standalone page embeds meshcat's viewer (three.js included) and the scene."""
    run_example("view_mechanism.py", tmp_path, "nine_bar")
    assert (_out(tmp_path) / "nine_bar.html").stat().st_size > 100_000


@pytest.mark.parametrize("script", ["four_ups_upu_clearance.py", "nine_bar_clearance.py",
                                    "three_upru_up_clearance.py"])
def test_clearance_examples(tmp_path, script):
    text = run_example(script, tmp_path)
    assert "status success" in text
    assert list(_out(tmp_path).glob("*.png"))


def test_analysis_oscillator(tmp_path):
    """Sweep in 2 worker processes; the section velocities follow the driven oscillator's
    closed-form steady state (transfer function) to integration accuracy."""
    text = run_example("analysis_oscillator.py", tmp_path)
    assert number(text, "from the closed form:") < 1e-6
    assert (_out(tmp_path) / "oscillator_poincare.png").exists()


def test_analysis_double_well(tmp_path):
    """Weak forcing of the double-well oscillator is period-1 (small oscillation in one well)."""
    text = run_example("analysis_double_well.py", tmp_path)
    assert re.search(r"0\.200\s+success\s+period-1", text), text


def test_rrr3_clearance(tmp_path):
    """The tutorial's 3-RRR: every run succeeds with its loops closed and its energy audited, and
    the first contact-force peak from the ideal start is a fraction of the least-energy start's
    (whose journal moves relative to its bearing at t = 0)."""
    text = run_example("rrr3_clearance.py", tmp_path)
    assert text.count("status success") == 3 and "ok False" not in text
    assert number(text, "max closure residual") < 1e-6
    ideal = number(text, "P2 contact-force peak, clearance start:")
    least = number(text, "P2 contact-force peak, least-energy start:")
    assert 0 < ideal < 0.5 * least
    for name in ("energy", "contact_force", "journal", "platform"):
        assert (_out(tmp_path) / "clearance" / f"{name}.png").stat().st_size > 10_000


def test_rrr3_build_quick(tmp_path):
    text = run_example("rrr3_build.py", tmp_path)
    assert "mobility 3, 3 drives" in text
    assert (_out(tmp_path) / "rrr3.yaml").exists()
