"""Readable Poincaré figures and classification notes (issue 52, item 8): for a mm-sized
eccentricity the power of ten sits in the axis label (no offset text at the axis' end, which drew
over the label), with at most 5 ticks per axis; a period-k orbit with fewer distinct clusters
says why."""
import numpy as np

from pinclear.analysis.classify import classify
from pinclear.analysis.plots import plot_poincare
from pinclear.analysis.poincare import PoincareSection


def _section(x, xdot, label="A.eccentricity[0]"):
    n = len(x)
    return PoincareSection(np.arange(n), np.arange(n) * 0.1, np.asarray(x, float), np.asarray(xdot, float), 0.1, 0.0,
                           label, np.zeros(n, bool))


def test_poincare_axes_carry_their_power_of_ten_in_the_label():
    rng = np.random.default_rng(1)
    x = 1e-4 * (1 + 0.3 * rng.standard_normal(50))          # 0.1 mm eccentricities
    xd = 2e-3 * rng.standard_normal(50)
    fig, data = plot_poincare(_section(x, xd), unit="m")
    ax = fig.axes[0]
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(fig).draw()           # the offset text is set when the figure is drawn
    assert ax.xaxis.get_offset_text().get_text() == "" and ax.yaxis.get_offset_text().get_text() == ""
    assert "[1e-4 m]" in ax.get_xlabel() and "[1e-3 m/s]" in ax.get_ylabel()
    ticks = [t for t in ax.get_xticks() if ax.get_xlim()[0] <= t <= ax.get_xlim()[1]]
    assert len(ticks) <= 6
    # the tick texts are the values in the label's unit: tick value / 1e-4
    lab = ax.xaxis.get_major_formatter()(ticks[1], 1)
    assert float(lab) == float(f"{ticks[1] / 1e-4:.4g}")
    np.testing.assert_array_equal(data["x"], x)            # the data drawn are the section's, unscaled
    np.testing.assert_array_equal(ax.lines[0].get_xdata(), x)


def test_metre_sized_signals_keep_plain_labels():
    fig, _ = plot_poincare(_section(np.linspace(0.1, 0.3, 20), np.linspace(-1, 1, 20), "slide"), unit="m")
    assert fig.axes[0].get_xlabel() == "slide [m]"


def test_period_k_with_fewer_clusters_is_explained():
    # period 4 whose points 0 and 2 coincide: 3 distinct clusters
    cycle = np.array([[1.0, 0.0], [2.0, 1.0], [1.0, 0.0 + 1e-12], [3.0, -1.0]])
    P = np.tile(cycle, (20, 1))
    c = classify(P, rtol=1e-6)
    assert c.kind == "period-4" and c.clusters == 3
    assert "3 distinct clusters for period 4" in c.note
    c2 = classify(np.tile(np.array([[1.0, 0.0], [2.0, 1.0]]), (20, 1)), rtol=1e-6)
    assert c2.kind == "period-2" and "clusters" not in c2.note
