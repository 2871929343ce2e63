"""Phase portraits, Poincaré maps and bifurcation diagrams on matplotlib Figures (no pyplot)."""
from __future__ import annotations

import numpy as np

from pinclear.analysis.diagrams import BifurcationResult, is_number
from pinclear.analysis.poincare import PoincareSection
from pinclear.analysis.signals import axis_label, phase_portrait, series
from pinclear.core.errors import InputError
from pinclear.core.safeio import savefig


def _figure(ax, figsize):
    if ax is not None:
        return ax.figure, ax
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize)
    return fig, fig.subplots()


def plot_phase_portrait(x, xdot=None, section=None, label="", ax=None, path=None, mech=None, t_min=None,
                        unit=None):
    """Phase portrait (x, xdot); ``x`` may be a Trajectory with ``xdot`` the signal spec (its unit
    then comes from the signal). Poincaré samples (``section``) are overlaid as dots; ``unit``:
    the SI unit of x for the axes. Returns (figure, arrays plotted)."""
    if hasattr(x, "t") and hasattr(x, "q"):
        if xdot is None:
            raise InputError("plot_phase_portrait(traj, signal): give the signal")
        label = label or (xdot if isinstance(xdot, str) else "signal")
        s = series(x, xdot, mech)
        unit = unit or s.unit
        x, xdot = phase_portrait(x, xdot, mech=mech, t_min=t_min)
    x, xdot = np.asarray(x, float), np.asarray(xdot, float)
    fig, ax = _figure(ax, (5, 4.5))
    ax.plot(x, xdot, lw=0.6, color="C0", gid="portrait")
    data = {"x": x, "xdot": xdot}
    if section is not None:
        ax.plot(section.x, section.xdot, "o", ms=3, color="C3", gid="section", label="Poincaré")
        data.update(section_x=section.x, section_xdot=section.xdot)
        ax.legend(fontsize=8)
    ax.set_xlabel(axis_label(label or "x", unit))
    ax.set_ylabel(axis_label(label or "x", unit, rate=True))
    ax.set_title("phase portrait")
    readable_ticks(ax)
    ax.grid(alpha=0.3)
    if path is not None:
        savefig(fig, path, dpi=120, bbox_inches="tight")
    return fig, data


def readable_ticks(ax):
    """Ticks that neither run together nor collide with the labels: at most 5 per
    axis, no additive offset, and for mm- or um-sized signals the power of ten written into the
    axis label ("[1e-4 m]": ticks in units of 0.1 mm) rather than as matplotlib's offset text,
    which is drawn at the axis' end over the label or the title."""
    from matplotlib.ticker import FuncFormatter, MaxNLocator

    for axis, lim, setter in ((ax.xaxis, ax.get_xlim(), ax.set_xlabel), (ax.yaxis, ax.get_ylim(), ax.set_ylabel)):
        axis.set_major_locator(MaxNLocator(nbins=5))
        big = max(abs(lim[0]), abs(lim[1]))
        e = int(np.floor(np.log10(big))) if np.isfinite(big) and big > 0 else 0
        scale = 10.0 ** e if not -2 <= e <= 3 else 1.0
        axis.set_major_formatter(FuncFormatter(lambda v, _pos, s=scale: f"{v / s:.4g}"))
        if scale != 1.0:
            label = axis.get_label_text()
            head, sep, unit = label.rpartition(" [")           # the unit's bracket, not an index's
            setter(f"{head} [1e{e} {unit}" if sep and unit.endswith("]") else f"{label} [1e{e}]")


def plot_poincare(section: PoincareSection, ax=None, path=None, unit=None):
    """Poincaré map: (x, xdot) at the section times (``unit``: the SI unit of x, for the axes).
    Returns (figure, arrays plotted)."""
    fig, ax = _figure(ax, (5, 4.5))
    ax.plot(section.x, section.xdot, ".", ms=4, color="C3", gid="section")
    ax.set_xlabel(axis_label(section.label, unit))
    ax.set_ylabel(axis_label(section.label, unit, rate=True))
    readable_ticks(ax)
    ax.set_title(f"Poincaré map (T = {section.period:.6g} s, phase {section.phase:.3g} s, {len(section)} points)")
    ax.grid(alpha=0.3)
    if path is not None:
        savefig(fig, path, dpi=120, bbox_inches="tight")
    return fig, {"x": section.x, "xdot": section.xdot}


def plot_bifurcation(result: BifurcationResult, coordinate="xdot", signal=None, ax=None, path=None, label=None):
    """Bifurcation diagram: Poincaré samples of ``signal`` (default: the first recorded) of
    every successful run against the parameter; failed values are marked with red crosses at
    the bottom of the plot. Returns (figure, arrays plotted)."""
    p, y = result.points(coordinate, signal=signal)
    fig, ax = _figure(ax, (7, 4.5))
    many = len(p) > 5000
    ax.plot(p, y, "," if many else ".", ms=2, color="k", gid="bifurcation", rasterized=many)
    failed = np.array([float(r.value) for r in result.runs if not r.ok and is_number(r.value)])
    if len(failed):
        ybase = np.full(len(failed), np.min(y) if len(y) else 0.0)
        ax.plot(failed, ybase, "x", color="r", gid="failed", label="run failed")
        ax.legend(fontsize=8)
    name = label or (result.parameter if isinstance(result.parameter, str) else "parameter")
    ax.set_xlabel(str(name))
    sig = result._key(signal)
    ax.set_ylabel(f"d/dt {sig}" if coordinate == "xdot" else sig)
    ax.set_title("bifurcation diagram (Poincaré samples)")
    ax.grid(alpha=0.3)
    lp, lam = result.lyapunov()
    if len(lp):
        # the largest Lyapunov exponent of each value on a second axis: > 0 where the motion is chaotic
        ax2 = ax.twinx()
        order = np.argsort(lp)
        ax2.plot(lp[order], lam[order], "o-", color="tab:blue", ms=3, lw=1, gid="lyapunov")
        ax2.axhline(0.0, color="tab:blue", lw=0.5, ls=":")
        ax2.set_ylabel("largest Lyapunov exponent [1/s]", color="tab:blue")
    if path is not None:
        savefig(fig, path, dpi=120, bbox_inches="tight")
    return fig, {"p": p, "y": y, "failed": failed, "lyapunov": (lp, lam)}

