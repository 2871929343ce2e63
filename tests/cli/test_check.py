"""`pinclear simulate ... --check` (issue 52, item 7): the run made again at rtol/10 and half the
output step, and a table of how the summary's peaks, events and audit moved, with an exit status.

The reference for "converged" is the integration's own error: at rtol 1e-9 the pendulum's landing
peak is resolved far below 1 % (a tenfold tighter run moves it by about rtol x the steps' error
growth); at rtol 1e-2 a start-up impact is integrated with errors of percent size, which the
check must report as moved."""
import json
from argparse import Namespace

import pytest

from pinclear.cli.check import DEFAULT_TOL, compare, refined_args, table


def test_compare_flags_what_moved():
    a = {"drive_force_peaks": {"d": 10.0}, "contact_force_peaks": {"A": 100.0},
         "acceleration_peaks": {"rz": {"value": 5.0, "t": 0.1}}, "events": 10,
         "energy_balance": {"error_rel": 1e-9, "ok": True}, "max_closure_residual": 0.0}
    b = {"drive_force_peaks": {"d": 10.05}, "contact_force_peaks": {"A": 103.0},
         "acceleration_peaks": {"rz": {"value": 5.0, "t": 0.1}}, "events": 10,
         "energy_balance": {"error_rel": 1e-10, "ok": True}, "max_closure_residual": 0.0}
    rows = {r["quantity"]: r for r in compare(a, b, tol=0.01)}
    assert rows["drive_force_peaks.d"]["change"] == pytest.approx(0.05 / 10.05, rel=1e-12)
    assert not rows["drive_force_peaks.d"]["moved"]                # 0.5 % < 1 %
    assert rows["contact_force_peaks.A"]["moved"]                  # 2.9 %
    assert rows["acceleration_peaks.rz"]["change"] == 0.0 and not rows["events"]["moved"]
    assert not rows["energy_balance.ok"]["moved"]
    b["energy_balance"]["ok"] = False
    assert {r["quantity"]: r for r in compare(a, b)}["energy_balance.ok"]["moved"]
    # a window peak at round-off (a coordinate at rest after the transient) does not move
    a["rtol"] = 1e-6
    a["peaks_after"] = {"acceleration_peaks": {"rz": {"value": 2.1e-14, "t": 0.2}}}
    b["peaks_after"] = {"acceleration_peaks": {"rz": {"value": 2.3e-14, "t": 0.2}}}
    row = {r["quantity"]: r for r in compare(a, b)}["peaks_after.acceleration_peaks.rz"]
    assert row["change"] > 0.05 and not row["moved"]
    text = table(compare(a, b, 0.01), 0.01)
    assert "MOVED" in text and text.splitlines()[-1].startswith("not converged to 1 %")


def test_refined_arguments():
    T = Namespace(meta={"rtol": 1e-8}, t=[0.0, 0.002, 0.004])
    args = Namespace(rtol=None, atol=None, h=None, dt_out=None, out="o", check=True, resume=None, checkpoint_every=1.0)
    r = refined_args(args, T)
    assert r.rtol == pytest.approx(1e-9) and r.dt_out == pytest.approx(0.001) and r.out.endswith("check")
    assert r.check is False and r.atol is None and args.rtol is None       # the caller's arguments unchanged
    r = refined_args(Namespace(**{**vars(args), "rtol": 1e-6, "atol": 1e-8, "h": 1e-3, "dt_out": 1e-2}), T)
    assert (r.rtol, r.atol, r.h, r.dt_out) == pytest.approx((1e-7, 1e-9, 5e-4, 5e-3))


@pytest.mark.slow
def test_simulate_check_end_to_end(tmp_path, capsys):
    from pinclear.cli.commands import main

    base = ["simulate", "clr_planar_pendulum", "--clearance", "A", "--t-end", "0.05", "--dt-out", "1e-3",
            "--progress", "off", "--check"]
    assert main(base + ["--rtol", "1e-9", "--out", str(tmp_path / "tight")]) == 0
    out = capsys.readouterr().out
    assert "contact_force_peaks.A" in out and f"converged to {100 * DEFAULT_TOL:g} %" in out
    refined = json.loads((tmp_path / "tight" / "check" / "summary.json").read_text())
    assert refined["rtol"] == pytest.approx(1e-10)
    assert main(base + ["--rtol", "1e-2", "--out", str(tmp_path / "loose")]) == 1
    assert "not converged" in capsys.readouterr().out
