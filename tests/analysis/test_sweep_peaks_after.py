"""`sweep --peaks-after T` (issue 52, item 6): each point's summary holds its peaks from T on, in
the table as ``peaks_after.*`` columns equal to the point's own window peaks; a T outside the run
is refused before any point runs."""
import numpy as np
import pytest

from pinclear.analysis.sweeps import sweep
from pinclear.core.errors import InputError


@pytest.mark.slow
def test_sweep_table_has_the_window_peaks(tmp_path):
    res = sweep("clr_planar_pendulum", [("A.clearance", [1e-4, 2e-4])], 0.05, tmp_path / "s",
                sim_options={"rtol": 1e-6, "dt_out": 1e-3, "peaks_after": 0.03}, load_options={"clearances": ["A"]},
                executor="serial", progress=None)
    assert not res.failures
    table = np.load(tmp_path / "s" / "table.npz")
    col = table["peaks_after.contact_force_peaks.A"]
    for i, p in enumerate(res.points):
        tr = p.trajectory()
        w = tr.window_peaks(0.03)
        assert col[i] == w["contact_force_peaks"]["A"]
        assert table["peaks_after.t_from"][i] == 0.03
        assert col[i] <= table["contact_force_peaks.A"][i]
    text = (tmp_path / "s" / "table.csv").read_text().splitlines()[0]
    assert "peaks_after.contact_force_peaks.A" in text and "units." not in text


def test_sweep_peaks_after_outside_the_run_is_refused(tmp_path):
    with pytest.raises(InputError, match="peaks_after"):
        sweep("clr_planar_pendulum", [("A.clearance", [1e-4])], 0.05, tmp_path / "s",
              sim_options={"peaks_after": 0.05}, load_options={"clearances": ["A"]}, executor="serial", progress=None)
