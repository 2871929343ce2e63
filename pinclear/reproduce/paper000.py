"""Paper 000 (4UPS-UPU with a spherical clearance at S2, Chen & Cui 2021), sec. 4: platform
responses with the clearance against the ideal joint (mu 0.05, 0.10), the contact force at S2 for
mu 0.05/0.10/0.15 (the paper's 115-163 N), phase portraits and Poincaré maps of the platform's Z
and of the clearance's Y at mu 0.01/0.05/0.10, and bifurcation diagrams against mu in
[0.01, 0.20] and against the clearance in (0, 0.9] mm, classified by :func:`pinclear.analysis.classify`.

Every multi-run study goes through the sweep engine (:func:`pinclear.sweeps.sweep` for the
response runs, :func:`pinclear.analysis.bifurcation` for the diagrams) on one executor: local
worker processes (``workers``) or a Dask cluster (``scheduler``).
"""
from __future__ import annotations

import os

import numpy as np
import pinocchio as pin

from .. import safeio
from .. import analysis, kinematics
from ..errors import InputError
from ..mechanisms import four_ups_upu as mod
from ..models import model_path
from ..sidecar import load
from ..simulate import simulate
from ..sweeps import make_executor, sweep
from .report import compare

T = mod.PERIOD
#: paper 000 sec. 4.3: (min, max) of the S2 contact force over four steady periods (t ~ 102-108 s)
PAPER_FORCE = {0.05: (115.4, 162.7), 0.10: (127.9, 152.8), 0.15: (122.5, 160.1)}
#: paper 000 sec. 4.4 (Figs. 9-16): the motion it reads off its portraits and diagrams
PAPER_KIND = {"platform": "period-1 for every mu and clearance (quasi-periodic only at mu = 0.01)",
              "clearance": "chaotic for mu in [0.010, 0.022], quasi-periodic above; quasi-periodic for every "
                           "clearance in (0, 0.9] mm at mu = 0.1"}
PLATFORM = ["platform.x", "platform.y", "platform.z"]
CLEARANCE = ["S2.eccentricity[0]", "S2.eccentricity[1]", "S2.eccentricity[2]"]
SIGNALS = ["platform.z", "S2.eccentricity[1]", "platform.x", "platform.y", "S2.eccentricity[0]",
           "S2.eccentricity[2]"]

#: study sizes. full: the paper's (contact force read after 50 periods, 100 recorded cycles per
#: bifurcation value, mu step 0.01); quick: the same studies, fewer values and cycles (<= 5 min on 2 cores)
SETTINGS = {
    "full": {"force_periods": 54, "window_periods": 4, "mu_values": [round(0.01 * k, 2) for k in range(1, 21)],
             "clearance_values": sorted({round(5e-5 * k, 6) for k in range(1, 19)} | {4.2e-4, 6.7e-4}),
             "transient": 20, "cycles": 100, "per_period": 200, "dt_out": 2e-3},
    "quick": {"force_periods": 4, "window_periods": 2, "mu_values": [0.01, 0.05, 0.10],
              "clearance_values": [3.0e-4, 6.7e-4], "transient": 3, "cycles": 10, "per_period": 100, "dt_out": 2e-3},
}
#: the sensitivity study at the paper's chaotic end (mu 0.01, the sidecar's 0.5 mm gap): each
#: reconstructed quantity the clearance's motion could hinge on, changed alone. Friction ramp
#: (modified Coulomb, eqs. 18-19; the paper's v0/v1 are in its lost Table 3), the floor of the
#: impact speed in the damping (pinclear's, not the paper's), gravity's direction (the reading of
#: sec. 3.1), and the integration tolerance (a separate run at rtol 1e-10)
SENS_MU = 0.01
SENS_VARIANTS = {
    "baseline: v0 0.1 mm/s, v1 1 mm/s, floor 0.1 mm/s, gravity +X": {},
    "friction ramp 10x wider: v0 1 mm/s, v1 10 mm/s": {"S2.friction_law": {"type": "modified_coulomb", "v0": 1e-3,
                                                                           "v1": 1e-2}},
    "friction ramp 10x narrower: v0 0.01 mm/s, v1 0.1 mm/s": {"S2.friction_law": {"type": "modified_coulomb",
                                                                                  "v0": 1e-5, "v1": 1e-4}},
    "impact-speed floor 1 um/s": {"S2.v_impact_min": 1e-6},
    "impact-speed floor 1 mm/s": {"S2.v_impact_min": 1e-3},
    "gravity -X (the other reading of sec. 3.1)": {"gravity": -1.0},
    "moving platform mass and inertia x1.5": {"masses": ("moving_platform",)},
    "limb rods' masses and inertias x1.5": {"masses": tuple(f"rod{i}_{p}" for i in range(1, 6)
                                                            for p in ("lower", "upper"))},
}
#: the factor of the mass variants: the reconstructed bodies' sizes are guesses of that order
SENS_MASS_FACTOR = 1.5
SENS_RTOL = 1e-10
SMOOTH = T / 20          # moving-average window for the force band: removes the impact ringing, keeps the load
WHY_FORCE = ("reconstructed masses and platform joint angles (docs/papers.md, paper 000: Tables 1-3 are lost); the "
             "contact force follows limb 2's load, which with our layout swings {lo:.0f}-{hi:.0f} N over a period "
             "with ideal joints (mean {mean:.0f} N): the mean is set by the load, the band by the layout and "
             "gravity's direction (-X would make it several times wider: sensitivity table)")


def sensitivity_mechanism(variant):
    """The S2-clearance model at mu = SENS_MU with one reconstructed quantity changed
    (SENS_VARIANTS); module-level so that it pickles to worker processes."""
    change = dict(SENS_VARIANTS[variant])
    flip = change.pop("gravity", None)
    bodies = change.pop("masses", ())
    mech = load(model_path("four_ups_upu"), clearances=["S2"], overrides={"S2.mu": SENS_MU, **change})
    if flip is not None:
        mech.model.gravity.linear = flip * np.asarray(mech.model.gravity.linear)
    for body in bodies:
        scale_body(mech.model, body, SENS_MASS_FACTOR)
    return mech


def scale_body(model, body, factor):
    """Scale the mass and rotational inertia of the joint that carries URDF link ``body`` by
    ``factor`` (centre of mass kept), before any workspace is made. In this model every scaled
    link is the only body of its joint (the URDF gives each rod and the platform a joint of
    their own), so this scales exactly that link."""
    j = model.frames[model.getFrameId(body)].parentJoint
    y = model.inertias[j]
    model.inertias[j] = pin.Inertia(y.mass * factor, y.lever, y.inertia * factor)


def executor_for(workers, scheduler, n_jobs):
    """(executor, close) for the studies: 'serial' for one local worker (no process start-up),
    else local processes or the Dask scheduler (pinclear.sweeps.make_executor)."""
    if scheduler is None and workers is not None and int(workers) == 1:
        return "serial", None
    if scheduler is None and workers is not None and int(workers) < 1:
        raise InputError(f"workers must be a positive number of processes, got {workers!r}")
    return make_executor(workers or max(1, min(os.cpu_count() or 1, n_jobs)), scheduler)


#: the response/contact-force runs, the same in both modes (the paper's values; clearance: the sidecar's 0.5 mm)
RESPONSE = {"force_mu": list(PAPER_FORCE), "stiffness": ["printed", "conformal"], "clearance": 5e-4,
            "sensitivity": True}


def _settings(quick, settings):
    s = dict(SETTINGS["quick" if quick else "full"], **RESPONSE)
    bad = set(settings or {}) - set(s)
    if bad:
        raise InputError(f"paper 000: unknown setting {sorted(bad)[0]!r}", choices=sorted(s))
    s.update(settings or {})
    return s


def ideal_reaction(t, gravity_sign=1.0):
    """World force of the ideal spherical joint S2 at times ``t`` (one ideal run; periodic), and
    the worst condition number of the closures + drives Jacobian along that run. gravity_sign -1:
    gravity reversed (the other reading of paper 000's sec. 3.1)."""
    mech = load(model_path("four_ups_upu"))
    mech.model.gravity.linear = gravity_sign * np.asarray(mech.model.gravity.linear)
    tr = simulate(mech, float(t[-1]), t_eval=np.asarray(t, float), rtol=1e-9)
    return np.column_stack([tr.lam[f"S2.{c}"] for c in "xyz"]), worst_condition(mech, tr)


def worst_condition(mech, traj, n=60):
    """Largest condition number of the square Jacobian of closures and drives at ``n`` samples of
    ``traj``: a singular crossing (unbounded joint forces) would show as a blow-up."""
    ws = mech.workspace()
    idx = np.unique(np.linspace(0, len(traj.t) - 1, n).astype(int))
    return float(max(np.linalg.cond(kinematics.jacobian(mech, ws, traj.q[i], traj.t[i], with_drives=True))
                     for i in idx))


def moving_average(x, n):
    n = max(int(n), 1)
    return np.convolve(x, np.ones(n) / n, mode="valid")


def run(out, quick=False, workers=None, scheduler=None, settings=None):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter

    MM = FuncFormatter(lambda v, _: f"{1e3 * v:.6g}")      # m/s data shown in mm/s: no offset, no multiplier
    s = _settings(quick, settings)
    path = model_path("four_ups_upu")
    results, notes, checks, figures = [], [], [], []
    n_force = len(PAPER_FORCE) * 2
    ex, close = executor_for(workers, scheduler, max(n_force, len(s["mu_values"]), len(s["clearance_values"])))
    try:
        # ---------------------------------------------------------------- responses and contact force
        t_end = s["force_periods"] * T
        t_eval = np.arange(t_end - s["window_periods"] * T, t_end + 1e-12, s["dt_out"])
        t_eval[-1] = min(t_eval[-1], t_end)
        sw = sweep(path, {"S2.mu": list(s["force_mu"]), "S2.stiffness": list(s["stiffness"])}, t_end,
                   out / f"runs_{'quick' if quick else 'full'}" / "responses",
                   load_options={"clearances": ["S2"], "overrides": {"S2.clearance": s["clearance"]}},
                   sim_options={"t_eval": t_eval}, executor=ex, progress=None)
        lam, cond = ideal_reaction(t_eval - t_eval[0])
        notes.append(f"no singular crossing: along the ideal motion the closures + drives Jacobian's condition "
                     f"number stays below {cond:.3g}")
        lam_mag = np.linalg.norm(lam, axis=1)
        nav = int(round(SMOOTH / s["dt_out"]))
        why = WHY_FORCE.format(lo=lam_mag.min(), hi=lam_mag.max(), mean=lam_mag.mean())
        fig_f, axf = plt.subplots(2, 1, figsize=(9, 7), sharex=True)
        fig_r, axr = plt.subplots(3, 3, figsize=(12, 8), sharex=True)
        law = np.array([np.concatenate(mod.platform_position(t)) for t in t_eval])
        contact_runs = []          # (mu, share of the window in contact, least raw force)
        for p in sw.points:
            mu, stiff = p.overrides["S2.mu"], p.overrides["S2.stiffness"]
            if not p.ok:
                notes.append(f"response run mu = {mu}, K {stiff}: {p.status}: {p.message}")
                continue
            tr = p.trajectory()
            F = tr.outputs["S2.normal_force"] + tr.outputs["S2.friction_force"]
            Fm = np.linalg.norm(F, axis=1)
            band = moving_average(Fm, nav)
            # the period mean of the contact force is the limb's load: independent check against the ideal joint
            dev = np.linalg.norm(F.mean(0) + lam.mean(0)) / np.linalg.norm(lam.mean(0))
            checks.append({"name": f"period-mean contact force vs ideal S2 reaction, mu {mu}, K {stiff}",
                           "relative_difference": float(dev), "contact_mean_N": float(Fm.mean()),
                           "ideal_mean_N": float(lam_mag.mean())})
            if stiff != "printed":
                notes.append(f"mu = {mu}, K conformal (R1 R2/(R_socket - R_ball)): contact force mean "
                             f"{Fm.mean():.1f} N, raw peak {Fm.max():.0f} N, {SMOOTH:.2g} s band "
                             f"{band.min():.1f}-{band.max():.1f} N")
                continue
            lo, hi = PAPER_FORCE[mu]
            contact_runs.append((mu, float(np.mean(tr.outputs["S2.contact"] > 0)), float(Fm.min())))
            results.append(compare(f"contact force mean, mu {mu} (K as printed)", Fm.mean(), 0.5 * (lo + hi), "N",
                                   0.15, "paper: mid-point of its min/max; " + why))
            results.append(compare(f"contact force min ({SMOOTH:.2g} s average), mu {mu}", band.min(), lo, "N", 0.15,
                                   why))
            results.append(compare(f"contact force max ({SMOOTH:.2g} s average), mu {mu}", band.max(), hi, "N", 0.15,
                                   why))
            notes.append(f"mu = {mu}, K printed: raw contact force {Fm.min():.1f}-{Fm.max():.0f} N (least-largest), "
                         f"in contact {100 * np.mean(tr.outputs['S2.contact'] > 0):.0f} % of the window; period-mean "
                         f"contact force equals the ideal joint's reaction to {100 * dev:.2f} %")
            axf[0].plot(tr.t, Fm, lw=0.5, label=f"mu {mu}")
            axf[1].plot(tr.t[nav - 1:], band, label=f"mu {mu}")
            if mu in (0.05, 0.10):
                mech = load(path, clearances=["S2"], overrides={"S2.mu": mu, "S2.clearance": s["clearance"]})
                two = tr.t >= t_end - 2 * T - 1e-9
                for j, c in enumerate("xyz"):
                    se = analysis.series(tr, f"platform.{c}", mech)
                    acc = np.gradient(se.xdot, tr.t)
                    for row, (y, ref) in enumerate(((se.x, law[:, j]), (se.xdot, law[:, 3 + j]), (acc, law[:, 6 + j]))):
                        axr[row, j].plot(tr.t[two], y[two], lw=0.7, label=f"mu {mu}")
                    notes.append(f"mu = {mu}: platform {c.upper()} deviation from the ideal motion law: position "
                                 f"{1e6 * np.abs(se.x - law[:, j]).max():.1f} um, velocity "
                                 f"{1e3 * np.abs(se.xdot - law[:, 3 + j]).max():.2f} mm/s")
        always = contact_runs and all(share == 1.0 for _, share, _ in contact_runs)
        notes.append(f"with ideal joints the S2 load stays between {lam_mag.min():.0f} and {lam_mag.max():.0f} N. "
                     + ("With the clearance the ball stays on the socket wall throughout every response window "
                        f"(least raw force {min(f for _, _, f in contact_runs):.0f} N): no lift-off, no landing; "
                        "the high-frequency ringing at the larger mu (the paper's 'obvious high-frequency "
                        "vibration') modulates the force around the load's maximum without separating the ball"
                        if always else "With the clearance the contact share of the window per mu: "
                        + ", ".join(f"{m}: {100 * sh:.1f} % (least force {f:.0f} N)" for m, sh, f in contact_runs)))
        dev_c = [c for c in notes if "platform Z deviation" in c]
        notes.append(f"removing S2's three rows leaves the platform one free motion, which the {1e3 * s['clearance']:g} "
                     "mm gap bounds: the platform's steady offset from the law (above) is that gap times the "
                     "kinematic ratio of platform motion to ball motion along this freedom" if dev_c else
                     "platform deviations: see the response figure")
        axf[0].plot(t_eval, lam_mag, "k--", lw=0.8, label="ideal joint S2 reaction")
        axf[1].plot(t_eval, lam_mag, "k--", lw=0.8, label="ideal joint")
        for mu, (lo, hi) in PAPER_FORCE.items():
            axf[1].axhspan(lo, hi, color="C7", alpha=0.08)
        axf[0].set_ylabel("|F| at S2 [N]")
        axf[1].set_ylabel(f"{SMOOTH:.2g} s average [N]\n(grey: paper's bands)")
        axf[1].set_xlabel("t [s]")
        axf[0].legend(fontsize=8)
        axf[0].set_title("Contact force at S2 (K as printed)", fontsize=10)
        fig_f.tight_layout()
        safeio.savefig(fig_f, out / "contact_force.png", dpi=90)
        two = t_eval >= t_end - 2 * T - 1e-9
        for j, c in enumerate("XYZ"):
            for row, name in enumerate(("position [m]", "velocity [m/s]", "acceleration [m/s^2]")):
                axr[row, j].plot(t_eval[two], law[two, 3 * row + j], "k--", lw=0.8, label="ideal")
                axr[row, j].set_title(f"platform {c} {name}", fontsize=9)
                axr[row, j].ticklabel_format(axis="y", useOffset=False)
        for j in range(3):
            axr[2, j].set_xlabel("t [s]")
        axr[0, 0].legend(fontsize=8)
        fig_r.suptitle("Platform with the S2 clearance vs the ideal motion law (acceleration: "
                       "derivative of the exact velocity on the output grid)", fontsize=9)
        fig_r.tight_layout()
        safeio.savefig(fig_r, out / "platform_responses.png", dpi=90)
        plt.close(fig_f)
        plt.close(fig_r)
        figures += ["platform_responses.png", "contact_force.png"]

        # ---------------------------------------------------------------- bifurcations, portraits, Poincaré
        common = dict(period=T, signal=SIGNALS, cycles=s["cycles"], transient=s["transient"],
                      per_period=s["per_period"], keep_portrait=True, load_options={"clearances": ["S2"]},
                      executor=ex)
        bmu = analysis.bifurcation(str(path), "S2.mu", s["mu_values"], **common)
        bc = analysis.bifurcation(str(path), "S2.clearance", s["clearance_values"], **common)
        bs = bt = None
        if s["sensitivity"]:
            sens_common = dict(common, load_options=None)
            bs = analysis.bifurcation(sensitivity_mechanism, "variant", list(SENS_VARIANTS), **sens_common)
            bt = analysis.bifurcation(sensitivity_mechanism, "variant", list(SENS_VARIANTS)[:1],
                                      sim_options={"rtol": SENS_RTOL}, **sens_common)
    finally:
        if close is not None:
            close()
    bmu.save(out / "bifurcation_mu.npz")
    bc.save(out / "bifurcation_clearance.npz")

    portraits = [r for r in bmu.runs if any(abs(float(r.value) - m) < 1e-9 for m in (0.01, 0.05, 0.10))]
    if portraits:
        fig, axes = plt.subplots(len(portraits), 4, figsize=(16, 3.8 * len(portraits)), squeeze=False)
        for row, r in zip(axes, portraits):
            for k, sig in enumerate(("platform.z", "S2.eccentricity[1]")):
                if sig not in r.portraits:
                    row[2 * k].set_title(f"mu {r.value}: {r.status}", fontsize=9)
                    continue
                _, x, xd = r.portraits[sig]
                sec = r.sections[sig]
                # portrait in mm and mm/s; Poincaré points as offsets from their mean in um and um/s
                # (a period-1 map is a cluster far smaller than the orbit: absolute values would
                # need offset notation)
                row[2 * k].plot(1e3 * np.asarray(x), 1e3 * np.asarray(xd), lw=0.4)
                row[2 * k].set_title(f"mu {r.value}: {sig} phase portrait", fontsize=9)
                row[2 * k].set_xlabel(f"{sig} [mm]")
                row[2 * k].set_ylabel(f"d/dt {sig} [mm/s]")
                sx, sv = np.asarray(sec.x), np.asarray(sec.xdot)
                row[2 * k + 1].plot(1e6 * (sx - sx.mean()), 1e6 * (sv - sv.mean()), ".", ms=3, color="C3")
                c = r.classifications[sig]
                row[2 * k + 1].set_title(f"Poincaré map: {c.kind}\nabout {1e3 * sx.mean():.4g} mm, "
                                         f"{1e3 * sv.mean():.4g} mm/s", fontsize=8.5)
                row[2 * k + 1].set_xlabel(f"{sig} - mean [um]")
                row[2 * k + 1].set_ylabel("velocity - mean [um/s]")
                for a in row[2 * k:2 * k + 2]:
                    a.ticklabel_format(useOffset=False)
        fig.tight_layout()
        safeio.savefig(fig, out / "phase_poincare_mu.png", dpi=80)
        plt.close(fig)
        figures.append("phase_poincare_mu.png")
    for res, name, label in ((bmu, "bifurcation_mu.png", "mu"), (bc, "bifurcation_clearance.png", "clearance [m]")):
        fig, axes = plt.subplots(2, 3, figsize=(14, 7))
        for ax, sig in zip(axes.ravel(), PLATFORM + CLEARANCE):
            analysis.plot_bifurcation(res, signal=sig, ax=ax)
            ax.set_title(f"{sig}: velocity at the Poincaré section", fontsize=9)
            ax.set_ylabel(f"d/dt {sig} [mm/s]")
            ax.yaxis.set_major_formatter(MM)
            ax.set_xlabel(label)
        fig.tight_layout()
        safeio.savefig(fig, out / name, dpi=80)
        plt.close(fig)
        figures.append(name)

    for res, label in ((bmu, "mu"), (bc, "clearance")):
        for sig, what in (("platform.z", "platform Z"), ("S2.eccentricity[1]", "clearance Y")):
            rows = res.table(sig)
            txt = "; ".join(f"{r['value']:.4g}: {r['kind'] if r['status'] == 'success' else r['status']}"
                            + (f" (K {r['K']:.2f})" if r["K"] is not None else "") for r in rows)
            notes.append(f"ours, {what} vs {label}: {txt}")
        for r in res.runs:
            sec = r.sections.get("platform.z")
            if sec is not None and len(sec):
                notes.append(f"{label} {r.value:.4g}: Poincaré points spread: platform Z {1e6 * np.ptp(sec.x):.3g} um "
                             f"(velocity {1e3 * np.ptp(sec.xdot):.3g} mm/s), clearance Y "
                             f"{1e6 * np.ptp(r.sections['S2.eccentricity[1]'].x):.3g} um over {len(sec)} cycles")
    sens = []
    if bs is not None:
        rows = []
        for res, rtol in ((bs, "1e-8 (default)"), (bt, f"{SENS_RTOL:g}")):
            for r in res.runs:
                row = [r.value, rtol]
                for sig in ("S2.eccentricity[1]", "platform.z"):
                    c, sec = r.classifications.get(sig), r.sections.get(sig)
                    row += [(c.kind if c else r.status),
                            (1e6 * float(np.ptp(sec.x)) if sec is not None and len(sec) else float("nan"))]
                rows.append(row)
        sens.append({"title": f"what the motion at mu = {SENS_MU} (the paper's chaotic end, 0.5 mm gap) hinges on: "
                              "one reconstructed quantity changed at a time",
                     "columns": ["variant", "rtol", "clearance Y", "Poincaré spread of clearance Y [um]", "platform Z",
                                 "Poincaré spread of platform Z [um]"],
                     "rows": rows,
                     "note": f"{s['transient']} transient + {s['cycles']} recorded periods per run. A period-1 "
                             "orbit's Poincaré points coincide to the integration error (spread << 1 um); the paper "
                             "reports chaos of the clearance at mu 0.010-0.022. A variant that changed the verdict "
                             "would name a quantity the paper's chaos depends on. The masses of the moving platform and "
                             f"of the rods (the lost Tables 1-3) are scaled by {SENS_MASS_FACTOR:g} one group at a time; "
                             "the platform joint angles are not varied (the drives' inverse kinematics is built "
                             "from them, so a layout variant needs a regenerated model and law)"})
    lam_m, _ = ideal_reaction(np.linspace(0.0, T, 401), gravity_sign=-1.0)
    lam_p, _ = ideal_reaction(np.linspace(0.0, T, 401))
    rows = []
    for name, lm in (("+X (paper 000, sec. 3.1: rods' x axes point down)", lam_p), ("-X", lam_m)):
        f = np.linalg.norm(lm, axis=1)
        rows.append([name, float(f.mean()), float(f.min()), float(f.max()), float(f.min() / f.max())])
    rows.append(["paper (Figs. 5-7, the three mu)", float(np.mean([0.5 * (a + b) for a, b in PAPER_FORCE.values()])),
                 min(a for a, _ in PAPER_FORCE.values()), max(b for _, b in PAPER_FORCE.values()),
                 "0.71-0.84"])
    sens.append({"title": "gravity direction: the ideal S2 load over one period (the contact force follows it "
                          "within 3 %, check above)",
                 "columns": ["gravity", "mean [N]", "min [N]", "max [N]", "min / max"], "rows": rows,
                 "note": "the paper's band and its min/max ratio fit +X; -X gives the right mean but a band several "
                         "times too wide"})

    def kinds(sig):
        ks = [r["kind"] if r["status"] == "success" else r["status"] for res in (bmu, bc) for r in res.table(sig)]
        return ", ".join(f"{k} ({ks.count(k)} of {len(ks)} runs)" for k in sorted(set(ks), key=str))

    notes.insert(0, "conclusion, paper: 'clearance chaotic at small mu, platform period-1' (platform "
                 f"{PAPER_KIND['platform']}; clearance {PAPER_KIND['clearance']}). Ours: platform Z {kinds('platform.z')}; "
                 f"clearance Y {kinds('S2.eccentricity[1]')}")
    notes.append("classification: pinclear.analysis.classify with its defaults (period within 1e-4 of the "
                 "attractor's extent, else the 0-1 test with >= 40 samples); the paper judges its figures by eye. "
                 + ("Quick run: too few cycles for the 0-1 test, so non-periodic sequences read 'unresolved'."
                    if quick else ""))
    notes.append("every result used K as printed in paper 000 (eq. 17, 4/(3(s1+s2)) sqrt(R1R2/(R1+R2))); the "
                 "conformal radius R1R2/(R_socket - R_ball) is reported beside it for the contact force")
    notes.append("independent check: " + "; ".join(f"{c['name']}: {100 * c['relative_difference']:.2f} %"
                                                   for c in checks))
    return {"title": "Paper 000: 4UPS-UPU with a spherical clearance at S2", "paper": "000",
            "settings": {"mode": "quick" if quick else "full", "clearance": f"{1e3 * s['clearance']:g} mm",
                         "ball radius": "20 mm (reconstructed)", "stiffness": "printed",
                         "force window": f"{s['window_periods']} periods ending at {t_end:g} s",
                         "bifurcation cycles": f"{s['transient']} transient + {s['cycles']} recorded",
                         "mu values": len(s["mu_values"]), "clearance values": len(s["clearance_values"])},
            "results": results, "notes": notes, "checks": checks, "figures": figures, "sensitivity": sens,
            "classification": {"mu": {sig: bmu.table(sig) for sig in SIGNALS},
                               "clearance": {sig: bc.table(sig) for sig in SIGNALS}},
            "paper_kind": PAPER_KIND}
