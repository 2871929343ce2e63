"""The standard figures of a run (matplotlib ``Figure`` objects without pyplot: no GUI
backend is ever touched, nothing opens a window, the global backend stays as it was).

Each ``fig_*`` function returns a Figure whose lines carry exactly the arrays they were made
from (no smoothing, no resampling), so tests can check the data rather than the pixels; it
returns None when the run has nothing to show for it (no platform, no clearance, ...).

* ``platform``  position, velocity and acceleration of the platform frame (world
  components that move) and its orientation when it turns, with clearance (solid) and, if
  given, the ideal run (dashed) on the same axes, and then the deviation from the ideal run;
* ``contact_force``  normal and friction force magnitudes of each clearance joint, the peak
  from the integration steps marked (the curves are samples: they may miss an impact's top);
* ``journal``  eccentricity (journal/ball centre in the bearing/socket frame) inside the
  clearance circle of radius c;
* ``residual``  closure residual |Phi|_inf;
* ``energy``  kinetic, potential, spring and total energy, and the dissipated energy of
  the clearance joints when recorded;
* ``drives``  drive forces/torques (the drive rows' multipliers), peaks marked, the ideal run dashed.
"""
from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
import pinocchio as pin
from matplotlib.figure import Figure

from pinclear.core import safeio
from pinclear.model.kinematics import frame_motion
from pinclear.viz.elements import active_clearances, clearance_plot, recorded_clearances, run_clearances
from pinclear.viz.elements import clearance_size as element_clearance

AXES = "xyz"


def _subplots(nrows=1, ncols=1, figsize=(8, 4), **kw):
    fig = Figure(figsize=figsize)
    return fig, fig.subplots(nrows, ncols, **kw)


def _frame_pva(model: pin.Model, fid: int, traj):
    """World position, velocity and classical acceleration of frame ``fid`` along a run."""
    fm = frame_motion(model, [fid], traj.q, traj.v, traj.a)
    return fm.p[:, 0], fm.v[:, 0], fm.a[:, 0]


def _frame_rotations(model: pin.Model, fid: int, traj) -> np.ndarray:
    """World rotation matrices of frame ``fid`` at the run's samples, (n, 3, 3)."""
    return frame_motion(model, [fid], traj.q).R[:, 0]


def _on_times(t, t_ref, Y_ref):
    """A reference run's samples Y_ref(t_ref) at the times t: the samples themselves when both runs
    share their output grid (the usual case: one --dt-out), else linear interpolation per
    component (NaN outside the reference's time span)."""
    Y_ref = np.asarray(Y_ref, float)
    if len(t) == len(t_ref) and np.array_equal(t, t_ref):
        return Y_ref
    cols = Y_ref.reshape(len(t_ref), -1)
    out = np.column_stack([np.interp(t, t_ref, c, left=np.nan, right=np.nan) for c in cols.T])
    return out.reshape((len(t),) + Y_ref.shape[1:])


def rotation_vectors(R, R0) -> np.ndarray:
    """log3(R0^T R) per sample (rad, (n, 3)): the rotation from R0 to R as a rotation vector in R0's
    axes; R0 one matrix or one per sample."""
    R0 = np.broadcast_to(R0, R.shape)
    return np.array([pin.log3(a.T @ b) for a, b in zip(R0, R)]).reshape(len(R), 3)


def _sample_note(traj) -> str:
    """What a curve of output samples resolves: the output step, said on the figure."""
    dt = np.diff(traj.t)
    return f"curves: output samples (Δt = {np.median(dt):.3g} s)" if len(dt) else "curves: output samples"


def _step_peak(traj, family, name):
    """(value, t) of a run's peak from the integration (its summary's, Trajectory.peak_summary;
    over the accepted steps, independent of the output grid), or None (a run saved without)."""
    ps = traj.peak_summary()
    if ps.get("peaks_from") != "integration":
        return None
    value, t = (ps.get(f"{family}_peaks") or {}).get(name), (ps.get(f"{family}_peak_times") or {}).get(name)
    return None if value is None or t is None else (float(value), float(t))


def _moving(X: np.ndarray, rel: float = 1e-3) -> list[int]:
    """Components that actually move (span above rel x the largest span)."""
    span = X.max(axis=0) - X.min(axis=0)
    top = span.max()
    return [i for i in range(X.shape[1]) if top > 0 and span[i] > rel * top] or [int(np.argmax(span))]


def clearance_names(traj) -> list[str]:
    """Clearance joints of a run (its mechanism's, or those recorded in its metadata)."""
    return list(run_clearances(traj))


def clearance_type(traj, name: str) -> str | None:
    """Kind of clearance joint ``name`` (a type of pinclear.core.registry.CLEARANCE_TYPES)."""
    return run_clearances(traj).get(name)


def _plot_of(traj, name: str):
    """The ClearancePlot of joint ``name``'s type (None: unknown type)."""
    return clearance_plot(clearance_type(traj, name))


def clearance_size(traj, name: str):
    """Clearance of joint ``name``: radial c (float) of a ball or journal, or the gaps
    (c1, c2) across a slider's guide; from the element (or its description in the run's
    metadata), else from the outputs (|e| - penetration = c wherever both are recorded)."""
    mech = getattr(traj, "mech", None)
    if mech is not None:
        for el in active_clearances(mech):
            if el.name == name:
                return element_clearance(el)
    rec = recorded_clearances(traj.meta).get(name, {})
    if "clearance" in rec:
        c = np.ravel(np.asarray(rec["clearance"], float))
        return tuple(map(float, c)) if c.size > 1 else float(c[0])
    e = traj.outputs.get(f"{name}.eccentricity")
    d = traj.outputs.get(f"{name}.penetration")
    plot = _plot_of(traj, name)
    if e is not None and d is not None and np.ndim(e) == 2 and not (plot is not None and plot.boundary != "circle"):
        return float(np.median(np.linalg.norm(e, axis=1) - np.ravel(d)))
    return None


# ------------------------------------------------------------------------------ figures
def fig_platform(traj, model: pin.Model, fid: int, ref=None, label=None,
                 ref_label="ideal joints"):
    """Position, velocity, acceleration (world components that move) of the platform frame; its
    orientation (rotation vector from the start, log3(R(0)^T R), rad) when it turns; with ``ref``
    (the ideal run) dashed on the same axes, and below the deviations from it, which a clearance of
    0.1 mm on signals of 0.1 m hides on the panels above: position P - P_ref (mm) and orientation
    log3(R_ref^T R) (mrad), the reference taken at the run's sample times (gids
    ``deviation.position.x``, ``deviation.orientation.x``)."""
    P, V, A = _frame_pva(model, fid, traj)
    comps = _moving(P)
    if label is None:
        label = "with clearance" if clearance_names(traj) else "run"
    Rot = _frame_rotations(model, fid, traj)
    theta = rotation_vectors(Rot, Rot[0]) if len(Rot) else np.zeros((0, 3))
    turns = len(theta) and np.max(np.abs(theta)) > 1e-9
    rcomps = _moving(theta) if turns else []
    panels = ["position", "velocity", "acceleration"] + (["orientation"] if turns else [])
    if ref is not None:
        panels.append("deviation")
    colors = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    fig, axs = _subplots(len(panels), 1, sharex=True, figsize=(8, 2.4 * len(panels) + 1), squeeze=False)
    axs = axs[:, 0]
    R = _frame_pva(model, fid, ref) if ref is not None else None
    for ax, X, k, unit, title in zip(axs, (P, V, A), range(3), ("m", "m/s", "m/s²"),
                                     ("position", "velocity", "acceleration")):
        for c in comps:
            ax.plot(traj.t, X[:, c], color=colors[c], lw=1.2, label=f"{AXES[c]} {label}",
                    gid=f"{title}.{AXES[c]}")
            if R is not None:
                ax.plot(ref.t, R[k][:, c], color=colors[c], lw=1.0, ls="--",
                        label=f"{AXES[c]} {ref_label}", gid=f"{title}.{AXES[c]}.ref")
        ax.set_ylabel(f"{title} [{unit}]")
        ax.grid(alpha=0.3)
    Rot_ref = _frame_rotations(model, fid, ref) if ref is not None else None
    if turns:
        ax = axs[3]
        for c in rcomps:
            ax.plot(traj.t, theta[:, c], color=colors[c], lw=1.2, label=f"θ{AXES[c]} {label}",
                    gid=f"orientation.{AXES[c]}")
            if Rot_ref is not None and len(Rot_ref):
                th_ref = rotation_vectors(Rot_ref, Rot_ref[0])
                ax.plot(ref.t, th_ref[:, c], color=colors[c], lw=1.0, ls="--", label=f"θ{AXES[c]} {ref_label}",
                        gid=f"orientation.{AXES[c]}.ref")
        ax.set_ylabel("orientation log3(R(0)^T R) [rad]", fontsize=8)
        ax.grid(alpha=0.3)
    if ref is not None:
        ax = axs[-1]
        dP = P - _on_times(traj.t, ref.t, R[0])
        for c in comps:
            ax.plot(traj.t, dP[:, c] * 1e3, color=colors[c], lw=1.2, label=f"Δ{AXES[c]} [mm]",
                    gid=f"deviation.position.{AXES[c]}")
        if turns:
            Rr = _on_times(traj.t, ref.t, Rot_ref)
            ok = np.all(np.isfinite(Rr.reshape(len(Rr), -1)), axis=1)
            dth = np.full((len(traj.t), 3), np.nan)
            if ok.any():
                dth[ok] = rotation_vectors(Rot[ok], _nearest_rotations(Rr[ok]))
            for c in rcomps:
                ax.plot(traj.t, dth[:, c] * 1e3, color=colors[c], lw=1.0, ls=":", label=f"Δθ{AXES[c]} [mrad]",
                        gid=f"deviation.orientation.{AXES[c]}")
        ax.set_ylabel(f"run − {ref_label}\n[mm]" + (" / [mrad]" if turns else ""), fontsize=8)
        ax.axhline(0.0, color="k", lw=0.6)
        ax.legend(fontsize=7, ncol=3)
        ax.grid(alpha=0.3)
    axs[0].legend(fontsize=8, ncol=2)
    axs[-1].set_xlabel("t [s]")
    fig.suptitle(f"platform frame '{model.frames[fid].name}' (world components)")
    fig.tight_layout()
    return fig


def _nearest_rotations(M):
    """The rotation matrices nearest to M (per sample, by SVD): an interpolated rotation matrix is
    not orthogonal; on a shared output grid M is a rotation already and is returned unchanged
    up to rounding."""
    U, _, Vt = np.linalg.svd(M)
    d = np.sign(np.linalg.det(U @ Vt))
    U[:, :, 2] *= d[:, None]
    return U @ Vt


def fig_contact_force(traj):
    names = [n for n in clearance_names(traj)
             if f"{n}.normal_force" in traj.outputs or f"{n}.fn" in traj.outputs]
    if not names:
        return None
    fig, axs = _subplots(len(names), 1, sharex=True, figsize=(8, 3 * len(names)), squeeze=False)
    for ax, n in zip(axs[:, 0], names):
        # the total normal force (the ``fn`` output) is the quantity of the summary's contact peak
        if f"{n}.fn" in traj.outputs:
            Fn, what = np.ravel(traj.outputs[f"{n}.fn"]), "normal ΣFn"
        else:
            Fn, what = np.linalg.norm(traj.outputs[f"{n}.normal_force"], axis=1), "normal |Fn|"
        ax.plot(traj.t, Fn, lw=1.0, label=what, gid=f"{n}.normal")
        ft = traj.outputs.get(f"{n}.friction_force")
        if ft is not None and np.ndim(ft) == 2:
            ax.plot(traj.t, np.linalg.norm(ft, axis=1), lw=1.0, label="friction |Ft|", gid=f"{n}.friction")
        pk = _step_peak(traj, "contact_force", n)
        if pk is not None:
            _mark_peak(ax, pk, f"{n}.peak", "N")
        ax.set_ylabel(f"{n} force [N]")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    axs[-1, 0].set_xlabel("t [s]")
    fig.suptitle(f"clearance contact forces ({_sample_note(traj)}; ▼ peak over the integration steps, "
                 "as in summary.json)", fontsize=9)
    fig.tight_layout()
    return fig


def _mark_peak(ax, pk, gid, unit, sign=1.0, color="r"):
    """A marker at a peak from the integration (value, t), labelled with its value: the samples
    drawn may miss a short impact's top (they are spaced by the output step, the peak is over
    the accepted steps)."""
    value, t = pk
    ax.plot([t], [sign * value], marker="v" if sign > 0 else "^", color=color, ls="none", ms=7,
            label=f"peak {value:.4g} {unit} at t = {t:.4g} s (steps)", gid=gid)


def fig_journal(traj):
    names = [n for n in clearance_names(traj) if f"{n}.eccentricity" in traj.outputs]
    if not names:
        return None
    fig, axs = _subplots(1, len(names), figsize=(5 * len(names), 5), squeeze=False)
    for ax, n in zip(axs[0], names):
        E = np.asarray(traj.outputs[f"{n}.eccentricity"], float)
        if E.ndim == 1:
            E = E[:, None]
        plot = _plot_of(traj, n)
        if plot is not None and plot.across_axis and E.shape[1] == 3:
            # across the bearing/guide axis (z of its frame): along it is free travel
            i, j = 0, 1
        else:
            # a ball moves in 3-D: show the two directions it explores most
            span = E.max(axis=0) - E.min(axis=0)
            i, j = (sorted(np.argsort(span)[-2:]) if E.shape[1] >= 2 else (0, 0))
        hidden = [k for k in range(E.shape[1]) if k not in (i, j)]
        ax.plot(E[:, i] * 1e3, E[:, j] * 1e3, lw=0.8, gid=f"{n}.path")
        if hidden and not (plot is not None and plot.across_axis):
            # a projection: say onto which plane, and how much of the motion it leaves out
            k = hidden[0]
            ax.text(0.01, 0.01, f"projection onto the e_{AXES[i]}-e_{AXES[j]} plane of the socket frame (the two "
                    f"directions of largest spread);\ne_{AXES[k]} not shown: spread "
                    f"{(E[:, k].max() - E[:, k].min()) * 1e3:.3g} mm", transform=ax.transAxes, fontsize=7,
                    va="bottom", gid=f"{n}.projection")
        c = clearance_size(traj, n)
        if isinstance(c, tuple) and (i, j) == (0, 1):
            # slider centre in its guide: free within +-c1 x +-c2 (untilted slider)
            cx, cy = c[0] * 1e3, c[1] * 1e3
            ax.plot([-cx, cx, cx, -cx, -cx], [-cy, -cy, cy, cy, -cy], "k--", lw=1.0,
                    label=f"gaps {cx:.4g} x {cy:.4g} mm", gid=f"{n}.gap")
            ax.legend(fontsize=8, loc="upper right")
        elif isinstance(c, float) and c > 0:
            th = np.linspace(0, 2 * np.pi, 361)
            ax.plot(c * 1e3 * np.cos(th), c * 1e3 * np.sin(th), "k--", lw=1.0,
                    label=f"clearance c = {c * 1e3:.4g} mm", gid=f"{n}.circle")
            ax.legend(fontsize=8, loc="upper right")
        ax.set_aspect("equal")
        ax.locator_params(nbins=5)
        ax.set_xlabel(f"e_{AXES[i]} [mm] (bearing frame)")
        ax.set_ylabel(f"e_{AXES[j]} [mm]")
        ax.set_title(f"{n}: {plot.body if plot is not None else 'body 2'} centre")
        ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def fig_residual(traj):
    r = np.asarray(traj.residual, float)
    if r.size == 0 or not np.any(r != 0):      # no closure rows (all replaced by clearances)
        return None
    fig, ax = _subplots(figsize=(8, 3.5))
    pos = r > 0
    ax.semilogy(traj.t, np.where(pos, r, np.nan), lw=1.0, gid="residual")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("closure residual |Φ|∞")
    ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    return fig


#: the energy figure's curves: balance term -> (label, sign in B = T + V_g + V_el + E_diss - W...)
ENERGY_CURVES = {"kinetic": ("kinetic T", 1), "gravity": ("gravity V_g - V_g(0)", 1), "elastic": ("elastic V_el", 1),
                 "dissipated": ("dissipated E_diss", 1), "work_drives": ("drives' work W_d", -1),
                 "work_closures": ("closure rows' work W_c", -1), "work_applied": ("applied forces' work W_a", -1)}


def fig_energy(traj):
    """The audited energy balance over time (pinclear.dynamics.energy.balance_series): each term of
    B = T + V_g + V_el + E_diss - W_d - W_c - W_a that is not zero, and below, on its own scale,
    the balance's error B - B(0) with the audit's bound (a closed balance is a flat line)."""
    from pinclear.dynamics.energy import balance_series, energy_balance

    try:
        S = balance_series(traj)
    except (AttributeError, KeyError):
        return None
    if "message" in S:
        return None
    fig, (ax, ax2) = _subplots(2, 1, figsize=(8, 5.5), sharex=True, gridspec_kw={"height_ratios": [3, 1.3]})
    t = S["t"]
    for key, (label, _) in ENERGY_CURVES.items():
        if np.any(S[key] != 0):
            ax.plot(t, S[key], lw=1.0, label=label, gid=f"energy.{key}")
    ax.set_ylabel("energy [J]")
    ax.set_title("energy balance B = T + V_g + V_el + E_diss - W_d - W_c - W_a", fontsize=9)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    ax2.plot(t, S["balance"], lw=1.0, color="k", label="B - B(0)", gid="energy.balance")
    eb = energy_balance(traj)
    if eb.get("bound") is not None and np.isfinite(eb["bound"]) and eb["scale"]:
        lim = eb["bound"] * eb["scale"]
        if lim <= 10 * np.abs(S["balance"]).max():
            ax2.axhline(lim, color="r", lw=0.8, ls="--", label="audit bound", gid="energy.bound")
            ax2.axhline(-lim, color="r", lw=0.8, ls="--")
        else:       # drawn, it would flatten the error to a line: stated instead
            ax2.text(0.01, 0.92, f"audit bound ±{lim:.2g} J (ok: {eb['ok']})", transform=ax2.transAxes, fontsize=8,
                     va="top", gid="energy.bound_text")
    ax2.set_xlabel("t [s]")
    ax2.set_ylabel("B - B(0) [J]")
    ax2.legend(fontsize=8)
    ax2.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def drive_names(traj) -> list[str]:
    mech = getattr(traj, "mech", None)
    if mech is not None:
        return [d.name for d in mech.drives]
    meta = getattr(traj, "meta", {}) or {}
    drives = meta.get("mechanism", {}).get("drives")
    if drives is not None:
        return [d["name"] for d in drives]
    # closure rows are named "<closure>.<row>"; drive rows carry the drive's name
    return [k for k in traj.lam if "." not in k]


def fig_drives(traj, ref=None, ref_label="ideal joints"):
    """The drive rows' multipliers (forces N, torques N m) over the samples, each drive's peak from
    the integration marked (summary.json's ``drive_force_peaks``, on the side of the sampled
    curve's sign there), and ``ref``'s (the ideal run) dashed."""
    names = [n for n in drive_names(traj) if n in traj.lam]
    if not names:
        return None
    fig, ax = _subplots(figsize=(8, 4.5))
    colors = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, n in enumerate(names):
        col = colors[i % len(colors)]
        ax.plot(traj.t, traj.lam[n], lw=1.0, color=col, label=n, gid=f"drive.{n}")
        if ref is not None and n in ref.lam:
            ax.plot(ref.t, ref.lam[n], lw=1.0, ls="--", color=col, label=f"{n} {ref_label}", gid=f"drive.{n}.ref")
        pk = _step_peak(traj, "drive_force", n)
        if pk is not None and len(traj.t):
            near = traj.lam[n][int(np.argmin(np.abs(traj.t - pk[1])))]
            _mark_peak(ax, pk, f"drive.{n}.peak", "N (m)", sign=-1.0 if near < 0 else 1.0, color=col)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("drive force [N] / torque [N m]")
    ax.set_title(f"{_sample_note(traj)}; markers: peaks over the integration steps (summary.json)", fontsize=9)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


# ------------------------------------------------------------------------------ all
def make_figures(traj, mech=None, ref=None, frame: str | None = None) -> dict:
    """All standard figures of ``traj``: name -> Figure, or name -> reason it was skipped.
    ``frame`` names the frame to plot as platform (default: the sidecar's platform frame)."""
    mech = mech if mech is not None else getattr(traj, "mech", None)
    figs: dict = {}
    fid = getattr(mech, "platform_frame", None) if mech is not None else None
    if frame is not None:
        fid = mech.frame_id(frame)
    if fid is not None:
        figs["platform"] = fig_platform(traj, mech.model, fid, ref=ref)
    else:
        figs["platform"] = "no platform frame (sidecar 'platform: frame:', or --frame NAME)"
    for name, fn, why in (("contact_force", fig_contact_force, "no clearance joint active"),
                          ("journal", fig_journal, "no clearance eccentricity recorded"),
                          ("residual", fig_residual, "no closure rows (or no samples)"),
                          ("energy", fig_energy, "no energies recorded"),
                          ("drives", lambda tr: fig_drives(tr, ref=ref), "no drives")):
        f = fn(traj)
        figs[name] = f if f is not None else why
    return figs


def save_all(traj, out_dir, mech=None, ref=None, fmt="png", dpi=110, frame=None) -> tuple[dict, dict]:
    """Write the standard figures to ``out_dir``; returns (written name -> path,
    skipped name -> reason)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written, skipped = {}, {}
    for name, fig in make_figures(traj, mech=mech, ref=ref, frame=frame).items():
        if isinstance(fig, str):
            skipped[name] = fig
            continue
        path = out / f"{name}.{fmt}"
        safeio.savefig(fig, path, dpi=dpi)
        written[name] = path
    return written, skipped
