"""Paper 002 (Chen & Pan 2021: planar 2-DOF nine-bar with revolute clearances at A and B).

Sec. 3: slider 9's displacement, velocity and acceleration, the impact force and the journal-centre
trajectory for a 0.5 mm clearance at A or at B (3.2), 0.1 vs 0.5 mm at A (3.3) and none / one
(B) / two clearances (3.4), over the first two crank turns. Sec. 4 (friction 0.3): phase
portraits and Poincaré maps at 0.01 and 0.8 mm, the bifurcation diagram against the clearance
(0.01-1 mm) and against the driving speed (pi-3 pi rad/s at 0.1 mm), 100 cycles each.

The runs go through the sweep engine (pinclear.analysis.sweeps.sweep for sec. 3, analysis.bifurcation for
sec. 4) on one executor: local processes (``workers``) or a Dask cluster (``scheduler``). Each
bifurcation run is classified per joint from both eccentricity components at once
(classify_state), with the "same point" tolerance derived from the run's rtol and steps per period.
"""
from __future__ import annotations

import math
import sys
import time
from functools import partial

import numpy as np

from pinclear import analysis as an
from pinclear.analysis.classify import CLEARANCE_FRACTION, classify_state
from pinclear.analysis.plots import readable_ticks
from pinclear.analysis.sweeps import make_executor, sweep
from pinclear.core import safeio
from pinclear.core.models import model_path
from pinclear.dynamics.stepping.peaks import window_peak
from pinclear.mechanisms.nine_bar import DIMS
from pinclear.studies.reproduce import chaos, linkage002
from pinclear.studies.reproduce.bands import (NotReached, band_of, kinds_band, ledger_counts, ledger_text,
                                              reconstructed_inputs, tornado_figure)
from pinclear.studies.reproduce.verdicts import half_digit, row, tolerance

SLIDER = "guide"                      # slider 9's prismatic joint (urdf/nine_bar.urdf)
JOINTS = ("A", "B")
SIGNALS = [f"{j}.eccentricity[{k}]" for j in JOINTS for k in (0, 1)]
SPEED = {"drives[crank1_drive].law.coeffs[1]": 1.0, "drives[crank4_drive].law.coeffs[1]": -1.0}
RTOL = 1e-6

#: paper 002 sec. 3 (text under Figs. 5-19): (value, unit, time of the peak in s)
PAPER = {
    "ideal displacement peak": (0.115, "m", 0.616), "A displacement": (0.123, "m", 0.616),
    "B displacement": (0.103, "m", 0.616), "AB displacement": (0.109, "m", 0.616),
    "ideal velocity peak": (0.653, "m/s", 0.512), "A velocity": (0.712, "m/s", 0.512),
    "B velocity": (0.586, "m/s", 0.512), "AB velocity": (0.636, "m/s", 0.512),
    "A 0.5 mm acceleration peak": (76.2, "m/s^2", 0.64), "A 0.1 mm acceleration peak": (90.7, "m/s^2", 1.68),
    "A 0.5 mm impact force peak": (289.0, "N", 0.018), "B 0.5 mm impact force peak": (581.0, "N", 0.037),
    "A 0.1 mm impact force peak": (124.0, "N", 0.64), "AB impact force peak at B": (330.0, "N", 0.034),
}
#: sec. 4.1 / 4.2, read off the phase portraits and Poincaré maps (no numbers printed)
PAPER_CHAOS = {1e-5: "quasi-periodic (a closed curve)", 8e-4: "chaotic (scattered points)"}

GROUPS = {
    "linkage": "the ideal slider's four printed numbers (sec. 3.2: 0.115 m at 0.616 s, 0.653 m/s at 0.512 s) chose "
               "the linkage: L1, L4, Hx, Hy are fitted to them by least squares on eq. 15 in closed form "
               "(pinclear.studies.reproduce.linkage002; the other dimensions reconstructed, Tables 1-2 lost). "
               "These rows are calibration: ours is the simulated ideal run's peak on the output grid, which "
               "checks the fit through the dynamics (pinclear's closures, not eq. 15)",
    "shift": "what the clearance changes in the slider's motion, predicted on the fitted linkage: eq. 15's "
             "dimensions outnumber the four printed numbers, so the fit leaves a family of linkages that all hit "
             "them (links 6 and 8 anywhere in 0.30-0.46 m and 0.40-0.48 m, the cranks and the pivot H fitted "
             "again: the fit table); the band is the spread of the shift over that family and the keyed inputs. "
             "The paper's 0.5 mm clearances move the displacement peak by 16-24 clearances (notes)",
    "startup": "ours is the first landing of a journal started centred (0.006-0.015 s; the start state, Table 4, "
               "is lost), the paper's a peak in its steady motion: not the same quantity",
    "impact": "impact spikes scale with the reconstructed contact stiffness, journal radius and masses (Table 3 "
              "lost); K as printed in eq. 8 (R1 R2 / (R1 + R2)); peaks sampled every 1e-4 s lie within 1 % of those "
              "sampled every 2e-6 s (first impacts, measured). The A 0.5 mm row's band spans the measured "
              "sensitivity runs (journal radius 5-20 mm x K printed / conformal, start position in the bearing)",
    "chaos": "sec. 4 (mu 0.3), classified with the clearance's resolution ({frac:.0%} of the clearance: 'below "
             "resolution' is never chaos) and the run's integration error bound; 'irregular' = 0-1 test K > 0.5 "
             "without a confirmed Lyapunov exponent ('chaotic' needs a positive one that agrees over two tolerances and "
             "two run lengths: pinclear.studies.reproduce.chaos, run on each diagram's first irregular values, the notes say "
             "which). Bands over the reconstructed inputs wait "
             "for --bands with a full-study budget",
}


#: sensitivity of the impact-force peak (A, 0.5 mm) to the reconstructed journal radius (sidecar
#: 10 mm) and the stiffness form: eq. 8 as printed (R1 R2 / (R1 + R2), the external-contact form)
#: or the conformal one (R1 R2 / (R_bearing - R_journal)) a journal in a bearing has
SENS_RADII = (0.005, 0.01, 0.02)
SENS_K = ("printed", "conformal")


def _settings(quick):
    if quick:
        return {"response t_end [s]": 2.0, "output step [s]": 1e-4, "clearances [mm]": [0.01, 0.1, 0.8],
                "speeds [pi rad/s]": [2.0, 3.0], "cycles": 8, "transient cycles": 4, "rtol": RTOL,
                "mu (sec. 4)": 0.3, "quick": True, "sensitivity": True, "long cycles": 100, "lyapunov limit": 1,
                **NAMED}
    return {"response t_end [s]": 2.0, "output step [s]": 1e-4,
            "clearances [mm]": [float(v) for v in np.round(np.linspace(0.01, 1.0, 25), 6)],
            "speeds [pi rad/s]": [float(v) for v in np.round(np.linspace(1.0, 3.0, 21), 6)],
            "cycles": 100, "transient cycles": 20, "rtol": RTOL, "mu (sec. 4)": 0.3, "quick": False,
            "sensitivity": True, "long cycles": 400, "lyapunov limit": 2, **NAMED}


#: the values the paper names (sec. 4: 0.01 and 0.8 mm; 2 pi and 3 pi rad/s): each gets a Lyapunov
#: estimate with its confidence bound whatever its 0-1 class, before any other value
NAMED = {"lyapunov at clearances [mm]": [0.01, 0.8], "lyapunov at speeds [pi rad/s]": [2.0, 3.0]}


def _say(msg):
    print(f"reproduce 002: {msg}", file=sys.stderr, flush=True)


# --------------------------------------------------------------------------- sec. 3
#: (label, active clearances, varied key and values, fixed overrides); the clearances are 0.5 mm
#: unless varied
RESPONSE_SWEEPS = [
    ("A", ["A"], {"A.clearance": [0.5e-3, 0.1e-3]}, {}),
    ("B", ["B"], {"B.clearance": [0.5e-3]}, {}),
    ("AB", ["A", "B"], {"A.clearance": [0.5e-3]}, {"B.clearance": 0.5e-3}),
]


def _response_runs(out, s, executor):
    """Trajectories of sec. 3: 'ideal', 'A 0.5', 'A 0.1', 'B 0.5', 'AB 0.5' (and the ideal start state)."""
    from pinclear.dynamics.simulate import simulate
    from pinclear.io.sidecar import load

    path = model_path("nine_bar")
    ideal = load(path)
    t_end, dt = s["response t_end [s]"], s["output step [s]"]
    runs = {"ideal": simulate(ideal, t_end, rtol=RTOL, dt_out=dt)}
    # the clearance runs start where the ideal one does: journals centred, every body moving as in
    # the ideal mechanism (the paper's Table 4 start state is lost; a journal at rest in a moving
    # bearing would add a start-up impact of crank-tip speed)
    q0, v0 = runs["ideal"].q[0].tolist(), runs["ideal"].v[0].tolist()
    sim = dict(method="lagrange", integrator="RK45", rtol=RTOL, dt_out=dt, q0=q0, v0=v0)
    for label, active, vary, fixed in RESPONSE_SWEEPS:
        res = sweep(path, vary, t_end, out / "runs" / label, sim_options=sim,
                    load_options={"clearances": active, "overrides": {**_for(s.get("overrides", {}), active), **fixed}},
                    executor=executor, progress=None)
        for p in res.points:
            c_mm = 1e3 * next(iter(p.overrides.values()))
            key = f"{label} {c_mm:g}"
            runs[key] = p.trajectory() if p.ok else None
            if not p.ok:
                _say(f"{key} mm: {p.status}: {p.message}")
    return runs


def _for(overrides, active):
    """The overrides that concern the active clearances (or no clearance at all): a run with A alone
    takes A.* and leaves B.* out (load refuses overrides of inactive joints)."""
    return {k: v for k, v in overrides.items() if k.split(".")[0] not in JOINTS or k.split(".")[0] in active}


_SLIDER_INDEX = []


def _slider(tr):
    """Slider 9's displacement from its start, velocity and acceleration (every variant shares
    the URDF tree, so the joint index is the ideal model's)."""
    if not _SLIDER_INDEX:
        from pinclear.io.sidecar import load

        model = load(model_path("nine_bar")).model
        j = model.joints[model.getJointId(SLIDER)]
        _SLIDER_INDEX[:] = [j.idx_q, j.idx_v]
    iq, iv = _SLIDER_INDEX
    return tr.q[:, iq] - tr.q[0, iq], tr.v[:, iv], tr.a[:, iv]


def _peak(t, y, t_max=None):
    """(largest |y|, its time) up to t_max; (nan, nan) without samples (a run shorter than a window)."""
    return window_peak(t, y, t_to=None if t_max is None else t_max + 1e-12)


def _steady_peak(t, y):
    """(largest |y|, its time) in the steady regime, t >= STEADY (the summary's peaks_after's
    function)."""
    return window_peak(t, y, t_from=STEADY)


def _response_table(runs, s):
    """{run: its numbers} of sec. 3: peaks (whole run, and after the start-up at t >= STEADY),
    the slider's shift from the ideal run at the ideal peak, eccentricities and penetrations."""
    ideal = runs["ideal"]
    xi, vi, ai = _slider(ideal)
    # the paper's peaks lie in the first crank turn
    dpk, t_d = _peak(ideal.t, xi, 1.0)
    vpk, t_v = _peak(ideal.t, vi, 1.0)
    table = {"ideal": {"displacement peak [m]": dpk, "at [s]": t_d, "velocity peak [m/s]": vpk, "at (v) [s]": t_v,
                       "acceleration peak [m/s^2]": _peak(ideal.t, ai)[0]}}
    i_d, i_v = int(np.argmin(np.abs(ideal.t - t_d))), int(np.argmin(np.abs(ideal.t - t_v)))
    for key in ("A 0.5", "B 0.5", "AB 0.5", "A 0.1"):
        tr = runs.get(key)
        if tr is None:
            continue
        x, v, a = _slider(tr)
        n = min(len(x), len(xi))
        row_ = {"displacement at the ideal peak [m]": float(abs(x[i_d])),
                "velocity at the ideal peak [m/s]": float(abs(v[i_v])),
                # the paper compares peak values (0.123 vs 0.115 m): magnitudes, as for the velocity
                "displacement shift at the ideal peak [m]": float(abs(x[i_d]) - abs(xi[i_d])),
                "velocity shift at the ideal peak [m/s]": float(abs(v[i_v]) - abs(vi[i_v])),
                "max |x - x_ideal| [m]": float(np.max(np.abs(x[:n] - xi[:n]))),
                "steady acceleration peak [m/s^2]": _steady_peak(tr.t, a)[0]}
        row_["acceleration peak [m/s^2]"], row_["at (a) [s]"] = _peak(tr.t, a)
        for j in JOINTS:
            if f"{j}.fn" in tr.outputs:
                fn = tr.outputs[f"{j}.fn"]
                row_[f"{j} impact force peak [N]"], row_[f"{j} at [s]"] = _peak(tr.t, fn)
                row_[f"{j} steady impact force peak [N]"] = _steady_peak(tr.t, fn)[0]
                e = tr.outputs[f"{j}.eccentricity"]
                row_[f"{j} max eccentricity [m]"] = float(np.max(np.hypot(e[:, 0], e[:, 1])))
                row_[f"{j} max penetration [m]"] = float(np.max(tr.outputs[f"{j}.penetration"]))
        row_["cpu_s"] = tr.stats.get("cpu_s")
        table[key] = row_
    return table


def _step_table(runs):
    """The output-step table of sec. 3's clearance runs: the slider's acceleration peaks (over the
    run and steady) and the impact-force peaks read off every 10th..2nd output sample
    (pinclear.analysis.convergence.sampled_convergence), beside the integration's own peaks over its
    accepted steps (Trajectory.peak_summary: independent of the output grid)."""
    from pinclear.analysis.convergence import sampled_convergence
    from pinclear.studies.reproduce.report import convergence_table

    checks, integ = {}, {}
    for key in ("A 0.5", "A 0.1", "B 0.5", "AB 0.5"):
        tr = runs.get(key)
        if tr is None or len(tr.t) < 20:
            continue
        _, _, a = _slider(tr)
        fns = {j: np.ravel(tr.outputs[f"{j}.fn"]) for j in JOINTS if f"{j}.fn" in tr.outputs}

        def measure(i, tr=tr, a=a, fns=fns):
            got = {"slider acceleration peak [m/s^2]": float(np.max(np.abs(a[i]))),
                   f"steady slider acceleration peak (t >= {STEADY:g} s) [m/s^2]": window_peak(tr.t[i], a[i],
                                                                                              t_from=STEADY)[0]}
            got.update({f"{j} impact force peak [N]": float(np.max(f[i])) for j, f in fns.items()})
            return got

        checks[f"{key} mm"] = sampled_convergence(tr.t, measure, rtol=0.01)
        pk = tr.peak_summary()
        acc = (pk.get("acceleration_peaks") or {}).get(SLIDER) if pk.get("peaks_from") == "integration" else None
        integ[f"{key} mm"] = {f"{j} impact force peak [N]": v for j, v in (pk.get("contact_force_peaks") or {}).items()
                              if v is not None}
        if isinstance(acc, dict) and acc.get("value") is not None:
            integ[f"{key} mm"]["slider acceleration peak [m/s^2]"] = float(acc["value"])
    if not checks:
        return None
    bad = [f"{k}: {n}" for k, c in checks.items() for n, ok in c.converged.items() if not ok]
    return convergence_table(
        "output-step convergence of sec. 3's peaks: every 10th, 7th, 5th, 3rd and 2nd output sample, and the "
        "integration's own peak over its accepted steps", checks, extra=integ,
        extra_label="integration (accepted steps)",
        note=("the rows read every sample; converged: at most 1 % change from every 3rd to every 2nd sample (grids "
              "not nested). " + ("NOT converged: " + "; ".join(bad) if bad else "every quantity converged")))


#: the paper's steady-regime peaks are those after its start-up: from this time on (s), after our
#: start-up landings (0.006-0.015 s) and their rattling have died out
STEADY = 0.5
#: the paper's peaks of sec. 3 whose instant lies in its steady regime (t >= STEADY): compared with
#: our peaks after STEADY; the others (0.018-0.037 s) are start-up impacts, compared over the run
STEADY_ROWS = ("A 0.5 mm acceleration peak", "A 0.1 mm acceleration peak", "A 0.1 mm impact force peak")


def _merge(bands, key, band):
    """bands[key] widened by ``band`` = (lo, hi, what)."""
    if band is None:
        return
    old = bands.get(key)
    if isinstance(band, NotReached) or isinstance(old, NotReached):
        # a band the budget did not reach leaves one measured otherwise (the sensitivity runs') as it is
        bands[key] = old if old is not None and not isinstance(old, NotReached) else band
        return
    if len(band) == 2:                     # categorical: (kinds, what)
        bands[key] = band
        return
    bands[key] = band if old is None else (min(old[0], band[0]), max(old[1], band[1]), f"{old[2]}; {band[2]}")


def _banded(name, quantity, ours, paper, unit, bands, key, **kw):
    band, frm, need = band_of(bands, key, ours)
    cost = kw.pop("cpu_s", None)                  # the caller's estimate, when no band was asked for
    return row(name, quantity, ours, paper, unit, band=band, band_from=frm,
               cpu_s=need if need is not None else (None if band is not None else cost), **kw)


def _response_rows(table, bands=None):
    """Sec. 3's rows. The ideal linkage's four printed numbers chose the linkage (linkage002's
    fit): calibration; what the clearance changes (the shifts, predicted over the family of
    linkages the fit leaves) and the impact peaks are classified. ``bands``: {key: (lo, hi,
    what)} measured over the reconstructed inputs (keys: 'A shift d', 'A shift v', the PAPER
    keys, and those + ' steady')."""
    bands = bands or {}
    ideal = table["ideal"]
    fit = linkage002.residuals(DIMS)
    why = ("fitted (linkage002): closed-form residual {:+.2g} print precisions; ours from the simulated ideal run on "
           "the output grid")
    spec = [("ideal slider: displacement peak (first turn)", "kinematic peak", "displacement peak [m]",
             "ideal displacement peak", "m", 0),
            ("ideal slider: instant of the displacement peak", "instant", "at [s]", None, "s", 1),
            ("ideal slider: velocity peak (first turn)", "kinematic peak", "velocity peak [m/s]", "ideal velocity peak",
             "m/s", 2),
            ("ideal slider: instant of the velocity peak", "instant", "at (v) [s]", None, "s", 3)]
    rows = []
    for name, quantity, col, pk, unit, k in spec:
        printed = linkage002.PRINTED[list(linkage002.PRINTED)[k]][2]
        rows.append(row(name, quantity, ideal[col], float(printed), unit, printed=printed, status="calibration",
                        group="linkage", why=why.format(fit[k])))
    for name in ("A", "B", "AB"):
        r = table.get(f"{name} 0.5")
        if r is None:
            continue
        # the paper's shift and its reading precision (two values printed to 1 mm / 1 mm/s)
        dp = PAPER[f"{name} displacement"][0] - PAPER["ideal displacement peak"][0]
        dv = PAPER[f"{name} velocity"][0] - PAPER["ideal velocity peak"][0]
        cost = None if r.get("cpu_s") is None else r["cpu_s"] * len(linkage002.linkage_family())
        rows += [_banded(f"{name} 0.5 mm: shift of the slider displacement at the ideal peak", "kinematic peak",
                         1e3 * r["displacement shift at the ideal peak [m]"], 1e3 * dp, "mm", bands, f"{name} shift d",
                         reading=1.0, group="shift", cpu_s=cost, why=FAMILY_WHY),
                 _banded(f"{name} 0.5 mm: change of the slider velocity at the ideal peak", "kinematic peak",
                         1e3 * r["velocity shift at the ideal peak [m/s]"], 1e3 * dv, "mm/s", bands, f"{name} shift v",
                         reading=1.0, group="shift", cpu_s=cost, why=FAMILY_WHY)]
    rows += _impact_rows(table, bands)
    return rows


#: the shift rows' band source: the linkage family of the fit (its members' runs; CPU = members x one run)
FAMILY_WHY = ("prediction: --bands varies links 6 and 8 over the fitted family (linkage002.member fits L1, L4, Hx, Hy "
              "again for each) with the other reconstructed inputs")


def _impact_rows(table, bands):
    rows = []
    spec = [("A 0.5", "A 0.5 mm acceleration peak", "acceleration peak", "acceleration peak [m/s^2]", "m/s^2"),
            ("A 0.1", "A 0.1 mm acceleration peak", "acceleration peak", "acceleration peak [m/s^2]", "m/s^2"),
            ("A 0.5", "A 0.5 mm impact force peak", "impact peak", "A impact force peak [N]", "N"),
            ("A 0.1", "A 0.1 mm impact force peak", "impact peak", "A impact force peak [N]", "N"),
            ("B 0.5", "B 0.5 mm impact force peak", "impact peak", "B impact force peak [N]", "N"),
            ("AB 0.5", "AB impact force peak at B", "impact peak", "B impact force peak [N]", "N")]
    for key, pk, quantity, col, unit in spec:
        r = table.get(key)
        if r is None:
            continue
        paper, _, t_paper = PAPER[pk]
        name = f"{pk} (paper at {t_paper:g} s)"
        if pk in STEADY_ROWS:
            t_ours = r["at (a) [s]"] if quantity == "acceleration peak" else r["A at [s]"]
            rows.append(row(f"{name}, ours over the start-up (at {t_ours:.3g} s)", quantity, r[col], paper, unit,
                            status="not comparable", group="startup"))
            steady = r[col.replace("acceleration peak", "steady acceleration peak").replace(
                "impact force peak", "steady impact force peak")]
            rows.append(_banded(f"{name}, ours in the steady regime (t >= {STEADY:g} s)", quantity, steady, paper, unit,
                                bands, pk + " steady", printed=f"{paper:g}", group="impact"))
        else:
            rows.append(_banded(f"{name}, ours over the run", quantity, r[col], paper, unit, bands, pk,
                                printed=f"{paper:g}", group="impact"))
    return rows


def _response_notes(table):
    notes = []
    shifts = {k: v["max |x - x_ideal| [m]"] for k, v in table.items() if k != "ideal"}
    if shifts:
        notes.append("largest slider offset from the ideal run: " + ", ".join(
            f"{k} mm {1e3 * sh:.3g} mm ({sh / (float(k.split()[1]) * 1e-3):.2g} clearances)" for k, sh in shifts.items())
            + ". The paper's 0.5 mm clearances move the displacement peak by 8 mm (A, +7 %) and 12 mm (B, -10 %), "
            "16 to 24 times the clearance: levers of order one from A or B to the slider cannot amplify the play "
            "that much")
    for key, r in table.items():
        for j in JOINTS:
            if f"{j} max eccentricity [m]" in r:
                c = float(key.split()[1]) * 1e-3
                notes.append(f"{key} mm, journal {j}: eccentricity at most {1e3 * r[f'{j} max eccentricity [m]']:.4g} mm "
                             f"= clearance {1e3 * c:g} mm + max penetration {1e6 * r[f'{j} max penetration [m]']:.3g} um; "
                             f"largest impact at {r[f'{j} at [s]']:.3g} s")
    a5, a1 = table.get("A 0.5", {}), table.get("A 0.1", {})
    if a5 and a1:
        notes.append(f"clearance size at A (paper: the larger clearance, the more violent; its own peaks say 76.2 vs "
                     f"90.7 m/s^2 and 289 vs 124 N for 0.5 vs 0.1 mm): ours {a5['acceleration peak [m/s^2]']:.4g} vs "
                     f"{a1['acceleration peak [m/s^2]']:.4g} m/s^2 and {a5['A impact force peak [N]']:.4g} vs "
                     f"{a1['A impact force peak [N]']:.4g} N")
    return notes


def _claim_rows(table, bands=None):
    """Sec. 3.4's claim: a second clearance weakens the impact at B (581 -> 330 N)."""
    b, ab = table.get("B 0.5", {}), table.get("AB 0.5", {})
    if not (b and ab):
        return []
    ours = "weaker with A and B" if ab["B impact force peak [N]"] < b["B impact force peak [N]"] else \
        "stronger with A and B"
    band, frm, need = kinds_band(bands or {}, ["one vs two"], ours)
    return [row("impact at B, one (B) vs two clearances (paper: 581 -> 330 N)", "ordering", ours, "weaker with A and B",
                band=band, band_from=frm, cpu_s=need, group="impact", why=f"ours {b['B impact force peak [N]']:.4g} -> {ab['B impact force peak [N]']:.4g} N "
                                    "(peaks over the run)")]


#: the paper's printed numbers drawn on each run's curves (sec. 3.2-3.4): run -> (axis row, column,
#: PAPER key); rows 0-2 of column 0 are displacement, velocity, acceleration, (0, 1) the impact force
PAPER_MARKS = {"ideal": [(0, 0, "ideal displacement peak"), (1, 0, "ideal velocity peak")],
               "A 0.5": [(0, 0, "A displacement"), (1, 0, "A velocity"), (2, 0, "A 0.5 mm acceleration peak"),
                         (0, 1, "A 0.5 mm impact force peak")],
               "A 0.1": [(2, 0, "A 0.1 mm acceleration peak"), (0, 1, "A 0.1 mm impact force peak")],
               "B 0.5": [(0, 0, "B displacement"), (1, 0, "B velocity"), (0, 1, "B 0.5 mm impact force peak")],
               "AB 0.5": [(0, 0, "AB displacement"), (1, 0, "AB velocity"), (0, 1, "AB impact force peak at B")]}


def _mark_paper(ax, key, t, curves, colour):
    """The paper's printed peaks of run ``key`` as crosses at their printed instants, on the side
    (sign) our curve has there; ``curves``: {(row, col): samples} of the run."""
    for r, c, pk in PAPER_MARKS.get(key, []):
        y = curves.get((r, c))
        if y is None:
            continue
        value, _, t_pk = PAPER[pk]
        side = 1.0 if y[int(np.argmin(np.abs(t - t_pk)))] >= 0 else -1.0
        ax[r, c].plot([t_pk], [side * value], "x", ms=8, mew=2, color=colour)
        ax[r, c].annotate(f"paper {value:g}", (t_pk, side * value), fontsize=7, color=colour,
                          textcoords="offset points", xytext=(4, 4))


def _response_figures(runs, out, plt):
    ideal = runs["ideal"]
    xi, vi, ai = _slider(ideal)
    figs = []
    for fig_name, keys, title in [("response_A_vs_B.png", ["A 0.5", "B 0.5"], "sec. 3.2: clearance at A vs B, 0.5 mm"),
                                  ("response_size_A.png", ["A 0.5", "A 0.1"], "sec. 3.3: clearance size at A"),
                                  ("response_number.png", ["B 0.5", "AB 0.5"], "sec. 3.4: one (B) vs two clearances")]:
        fig, ax = plt.subplots(3, 2, figsize=(11, 9))
        for col, (y, lab) in enumerate([(xi, "displacement [m]"), (vi, "velocity [m/s]"), (ai, "acceleration [m/s^2]")]):
            ax[col, 0].plot(ideal.t, y, "k--", lw=0.8, label="no clearance")
            ax[col, 0].set_ylabel(f"slider 9 {lab}")
        _mark_paper(ax, "ideal", ideal.t, {(0, 0): xi, (1, 0): vi}, "k")
        for n, key in enumerate(keys):
            tr = runs.get(key)
            if tr is None:
                continue
            curves = dict(zip(((0, 0), (1, 0), (2, 0)), _slider(tr)))
            for (r, _), y in curves.items():
                ax[r, 0].plot(tr.t, y, lw=0.6, color=f"C{n}", label=f"{key} mm")
            for j in JOINTS:
                if f"{j}.fn" in tr.outputs:
                    ax[0, 1].plot(tr.t, tr.outputs[f"{j}.fn"], lw=0.6, label=f"{key} mm, at {j}")
            jj = "B" if key.startswith(("B", "AB")) else "A"
            if f"{jj}.fn" in tr.outputs:
                curves[(0, 1)] = tr.outputs[f"{jj}.fn"]
            _mark_paper(ax, key, tr.t, curves, f"C{n}")
            e = tr.outputs[f"{jj}.eccentricity"] * 1e3
            a = ax[1 if n == 0 else 2, 1]
            a.plot(e[:, 0], e[:, 1], lw=0.5)
            th, c_mm = np.linspace(0, 2 * np.pi, 200), float(key.split()[1])
            a.plot(c_mm * np.cos(th), c_mm * np.sin(th), "k:", lw=0.8)      # the clearance circle
            a.set_title(f"journal centre at {jj}, {key} mm: eex, eey [mm] (dotted: clearance)", fontsize=9)
            a.set_aspect("equal")
        ax[0, 0].legend(fontsize=8)
        ax[0, 1].legend(fontsize=8)
        ax[0, 1].set_ylabel("impact force [N]")
        ax[2, 0].set_xlabel("t [s]")
        fig.suptitle(title + " (x: the paper's printed peaks at their printed instants, Figs. 5-8, 15-18)")
        fig.tight_layout()
        safeio.savefig(fig, out / fig_name, dpi=90)
        plt.close(fig)
        figs.append(fig_name)
    return figs


# --------------------------------------------------------------------------- sec. 4
def crank_period(w):
    """The mechanism repeats after one crank turn: T = 2 pi / |w| (module-level: it pickles)."""
    return 2 * math.pi / abs(w)


def _joint_kinds(res, s, clearance=None):
    """{value: {joint: Classification}} from both eccentricity components of each joint, with
    the resolution CLEARANCE_FRACTION x the clearance (``clearance``, default the run's value)."""
    per = s["cycles"] + s["transient cycles"]
    out = {}
    for r in res.runs:
        kinds = {}
        c = float(r.value) if clearance is None else clearance
        for j in JOINTS:
            secs = [r.sections.get(f"{j}.eccentricity[{k}]") for k in (0, 1)]
            if r.ok and r.stats.get("steps"):
                kinds[j] = classify_state(secs, sim_rtol=RTOL, steps_per_period=r.stats["steps"] / per,
                                          resolution=CLEARANCE_FRACTION * c)
            else:
                kinds[j] = None
        out[round(float(r.value), 9)] = kinds
    return out


def _transient_checks(res, s, clearance=None):
    """{(value, joint): TransientCheck}: each run's class judged again with more periods of
    transient left out (20 more in the full study, 20 -> 40; at most half the recorded cycles).
    No new run (pinclear.analysis.convergence.transient_check)."""
    from pinclear.analysis.convergence import transient_check

    extra = max(1, min(20, s["cycles"] // 2))
    per = s["cycles"] + s["transient cycles"]
    checks = {}
    for r in res.runs:
        if not (r.ok and r.stats.get("steps")):
            continue
        c = float(r.value) if clearance is None else clearance
        for j in JOINTS:
            secs = [r.sections.get(f"{j}.eccentricity[{k}]") for k in (0, 1)]
            if all(x is not None and len(x) > extra for x in secs):
                checks[(round(float(r.value), 9), j)] = transient_check(
                    secs, extra=extra, sim_rtol=RTOL, steps_per_period=r.stats["steps"] / per,
                    resolution=CLEARANCE_FRACTION * c)
    return checks


def _apply_transient(kinds, checks, s, what, fmt):
    """The longer transient's class replaces the shorter's where they differ (the start-up had not
    decayed: transient_check's rule), in ``kinds`` in place. Returns the note and, per value,
    the text the rows at that value add to their reason."""
    from pinclear.analysis.convergence import transient_summary

    per_value = {}
    for (v, j), c in checks.items():
        if not c.agree and kinds.get(v, {}).get(j) is not None:
            kinds[v][j] = c.long
        per_value.setdefault(v, []).append(f"{j}: {c.short.kind}" + ("" if c.agree else f" -> {c.long.kind}"))
    extra = next(iter(checks.values())).extra if checks else 0
    head = f"{s['transient cycles']} vs {s['transient cycles'] + extra} transient periods"
    note = f"{what} diagram, {head}: " + transient_summary({f"{fmt(v)}, {j}": c for (v, j), c in checks.items()})
    return note, {v: f"{head}: {', '.join(t)}" for v, t in per_value.items()}


def _bifurcation(parameter, values, period, s, executor, overrides, rtol=RTOL, cycles=None, lyapunov_at=None):
    return an.bifurcation(model_path("nine_bar"), parameter, values, period=period, signal=SIGNALS,
                          cycles=cycles or s["cycles"], transient=s["transient cycles"], per_period=100,
                          keep_portrait=not lyapunov_at, lyapunov=bool(lyapunov_at), lyapunov_at=lyapunov_at,
                          sim_options=dict(method="lagrange", integrator="RK45", rtol=rtol),
                          load_options=dict(clearances=list(JOINTS), overrides={**s.get("overrides", {}), **overrides}),
                          executor=executor)


def _lyapunov(kinds, parameter, period, s, executor, overrides, priority):
    """The diagram's 'irregular' runs given the Lyapunov check (pinclear.studies.reproduce.chaos), the
    paper's named values first; ``kinds`` is updated in place. Returns the notes."""
    def again(vals, rtol, lengths):
        return _bifurcation(parameter, vals, period, s, executor, overrides, rtol=rtol, cycles=max(lengths),
                            lyapunov_at=lengths)

    per = period if callable(period) else (lambda v: period)
    return chaos.confirm_irregular(kinds, again, RTOL, s["cycles"], per, s["lyapunov limit"], priority=priority)


#: the named values' Lyapunov evidence of the last run (for the claims table)
LYAPUNOV_NAMED = {}


def _named_evidence(parameter, values, period, s, executor, overrides):
    """{value: ChaosEvidence} of the paper's named values, whatever their 0-1 class: one rerun per
    tolerance (pinclear.studies.reproduce.chaos.lyapunov_evidence)."""
    def again(vals, rtol, lengths):
        return _bifurcation(parameter, vals, period, s, executor, overrides, rtol=rtol, cycles=max(lengths),
                            lyapunov_at=lengths)

    return chaos.lyapunov_evidence(values, again, RTOL, s["cycles"])


def _chaos(s, out, executor, plt, bands=None):
    notes, figs, tables = [], [], {}
    mu = {f"{j}.mu": s["mu (sec. 4)"] for j in JOINTS}
    # --- against the clearance (sec. 4.1, Figs. 20-24)
    values = sorted({round(v * 1e-3, 9) for v in s["clearances [mm]"]} | set(PAPER_CHAOS))
    _say(f"bifurcation against the clearance: {len(values)} values x {s['transient cycles'] + s['cycles']} turns")
    res = _bifurcation({f"{j}.clearance": 1.0 for j in JOINTS}, values, 1.0, s, executor, mu)
    res.save(out / "bifurcation_clearance.npz")
    kinds = _joint_kinds(res, s)
    tnote, trans = _apply_transient(kinds, _transient_checks(res, s), s, "clearance", lambda v: f"{1e3 * v:.4g} mm")
    notes += [f"clearance {n}" for n in _lyapunov(kinds, {f"{j}.clearance": 1.0 for j in JOINTS}, 1.0, s, executor,
                                                  mu, priority=(8e-4,))]
    named = _named_evidence({f"{j}.clearance": 1.0 for j in JOINTS}, [round(1e-3 * v, 9) for v in
                                                                    s["lyapunov at clearances [mm]"]], 1.0, s,
                            executor, mu)
    notes += [f"clearance {1e3 * v:g} mm (named by the paper): {chaos.exponent_text(ev)}" for v, ev in named.items()]
    tables["clearance"] = _table(res, kinds, 1e3, "clearance [mm]")
    rows = _clearance_rows(res, kinds, named, bands, trans)
    for c, said in PAPER_CHAOS.items():
        k = kinds.get(c, {})
        ours = ", ".join(f"{j}: {_kind_text(k.get(j))}" for j in JOINTS)
        r = next((r for r in res.runs if round(float(r.value), 9) == c), None)
        ev = (f" ({r.stats['events'] / (s['cycles'] + s['transient cycles']):.3g} contact or separation events "
              "per turn)") if r is not None and r.stats.get("events") is not None else ""
        notes.append(f"clearance {1e3 * c:g} mm, mu 0.3: paper {said}; ours {ours}{ev}")
    figs.append(_portraits(res, list(PAPER_CHAOS), "chaos_clearance.png", lambda v: f"c = {1e3 * v:g} mm", plt, out,
                           clearance=lambda v: v, omega=lambda v: 2 * math.pi))
    figs.append(_diagrams(res, "bifurcation_clearance.png", "clearance c [m]", plt, out))
    notes.append(_spread_note(res, "clearance"))
    notes.append(tnote)
    # --- against the driving speed (sec. 4.2, Figs. 25-29), 0.1 mm
    # exact multiples of pi (2 pi is then the same drive law as the clearance study's)
    speeds = sorted({float(v) * math.pi for v in s["speeds [pi rad/s]"]} | {2 * math.pi, 3 * math.pi})
    _say(f"bifurcation against the driving speed: {len(speeds)} values")
    res_w = _bifurcation(SPEED, speeds, crank_period, s, executor,
                         {**mu, **{f"{j}.clearance": 0.1e-3 for j in JOINTS}})
    res_w.save(out / "bifurcation_speed.npz")
    kinds_w = _joint_kinds(res_w, s, clearance=0.1e-3)
    tnote_w, trans_w = _apply_transient(kinds_w, _transient_checks(res_w, s, clearance=0.1e-3), s, "speed",
                                        lambda v: f"{v / math.pi:.4g} pi rad/s")
    notes += [f"speed {n}" for n in _lyapunov(kinds_w, SPEED, crank_period, s, executor,
                                              {**mu, **{f"{j}.clearance": 0.1e-3 for j in JOINTS}},
                                              priority=(2 * math.pi, 3 * math.pi))]
    named_w = _named_evidence(SPEED, [v * math.pi for v in s["lyapunov at speeds [pi rad/s]"]], crank_period, s,
                              executor, {**mu, **{f"{j}.clearance": 0.1e-3 for j in JOINTS}})
    notes += [f"speed {v / math.pi:g} pi rad/s, 0.1 mm (named by the paper): {chaos.exponent_text(ev)}"
              for v, ev in named_w.items()]
    tables["speed"] = _table(res_w, kinds_w, 1 / math.pi, "speed [pi rad/s]")
    rows += _speed_rows(res_w, kinds_w, named_w, bands, trans_w)
    LYAPUNOV_NAMED.clear()
    LYAPUNOV_NAMED.update({f"{1e3 * v:g} mm": ev for v, ev in named.items()})
    LYAPUNOV_NAMED.update({f"{v / math.pi:g} pi rad/s": ev for v, ev in named_w.items()})
    for w, said in ((2 * math.pi, "chaotic, small range of the points"), (3 * math.pi, "chaotic, wider range")):
        k = kinds_w.get(round(w, 9), {})
        notes.append(f"driving speed {w / math.pi:g} pi rad/s, 0.1 mm: paper {said}; ours "
                     + ", ".join(f"{j}: {_kind_text(k.get(j))}" for j in JOINTS))
    figs.append(_portraits(res_w, [2 * math.pi, 3 * math.pi], "chaos_speed.png",
                           lambda v: f"w = {v / math.pi:g} pi rad/s", plt, out, clearance=lambda v: 0.1e-3,
                           omega=lambda v: v))
    figs.append(_diagrams(res_w, "bifurcation_speed.png", "driving speed w [rad/s]", plt, out))
    notes.append(_spread_note(res_w, "speed"))
    notes.append(tnote_w)
    fails = res.failures + res_w.failures
    if fails:
        notes.append("runs that did not finish (kept in the diagrams' npz files): "
                     + "; ".join(f"{v}: {st}: {m}" for v, st, m in fails))
    return rows, notes, figs, tables


#: kinds that repeat (or cannot be told from a repeating motion at the clearance's resolution)
REGULAR = ("period-", "below resolution")


def _regular(kind):
    return kind.startswith(REGULAR)


def _kinds_at(kinds, value):
    k = kinds.get(round(float(value), 9), {})
    return sorted({c.kind for c in k.values() if c is not None})


def _lyap_why(ev):
    return "; " + chaos.exponent_text(ev) if ev is not None else ""


def _named(named, value):
    return next((ev for v, ev in (named or {}).items() if abs(float(v) - float(value)) <= 1e-9 * max(1.0, abs(value))),
                None)


def _kind_row(name, ours, paper, bands, key, why, quantity="motion kind"):
    band, frm, need = kinds_band(bands or {}, [key], ours)
    return row(name, quantity, ours, paper, band=band, band_from=frm, cpu_s=need, group="chaos", why=why)


def _trans_why(trans, value):
    t = _named(trans, value) if trans else None
    return f"; transient check ({t})" if t else ""


def _clearance_rows(res, kinds, named=None, bands=None, trans=None):
    """Sec. 4.1's claims: 0.01 mm quasi-periodic, 0.8 mm chaotic, periodic -> chaos as the
    clearance grows, chaos at A stronger than at B. ``bands``: the kind points' bands;
    ``trans``: {value: the transient check's text} (the kinds already carry the longer
    transient's class where the two differ)."""
    rows = [_kind_row(f"motion of the journals A and B at {1e3 * c:g} mm (mu 0.3)", _kinds_at(kinds, c),
                      said.split(" (")[0], bands, f"kind {1e3 * c:g} mm",
                      "the set of the two joints' kinds" + _lyap_why(_named(named, c)) + _trans_why(trans, c))
            for c, said in PAPER_CHAOS.items() if _kinds_at(kinds, c)]
    vals = sorted(round(float(r.value), 9) for r in res.runs if r.ok)
    if len(vals) >= 2:
        rows.append(_transition_row(kinds, vals, "the motion as the clearance grows (Fig. 24)", "c", "clearance",
                                    lambda c: f"{1e3 * c:g} mm", "; the paper prints no threshold"
                                    + _moved_note(trans), bands, "trend c"))
        sp = _spread(res, vals[-1])
        if sp is not None:
            n = _spread_n(res, vals[-1])
            rows.append(_kind_row(f"the joint with the stronger chaos (larger Poincaré velocity spread at {1e3 * vals[-1]:g} mm)",
                                  spread_order(sp["A"], sp["B"], n), "A", bands, "stronger", quantity="ordering",
                                  why=f"std A {sp['A']:.3g} m/s, B {sp['B']:.3g} m/s over {n} points each: "
                                f"{100 * abs(sp['A'] / sp['B'] - 1):.1f} % apart against a sampling error of "
                                f"{100 / math.sqrt(2 * max(n - 1, 1)):.1f} % each (both listed when within 2 standard "
                                "errors of their difference)"))
    return rows


def _transition_row(kinds, vals, name, symbol, what, fmt, note="", bands=None, key=None):
    """The ordering row "periodic, then non-periodic as SYMBOL grows" over the swept ``vals``:
    ours holds when the smallest value's kinds are all regular and the largest's none."""
    first = next((v for v in vals if not all(_regular(k) for k in _kinds_at(kinds, v))), None)
    lo_reg = all(_regular(k) for k in _kinds_at(kinds, vals[0]))
    hi_irr = not any(_regular(k) for k in _kinds_at(kinds, vals[-1]))
    claim = f"periodic, then non-periodic as {symbol} grows"
    ours = claim if lo_reg and hi_irr else "no such transition"
    band, frm, need = kinds_band(bands or {}, [key] if key else [], ours)
    return row(name, "ordering", ours, claim, band=band, band_from=frm, cpu_s=need, group="chaos",
               why=(f"first non-periodic {what} " + (fmt(first) if first else "none")
                    + f" over {fmt(vals[0]).split(' ')[0]}-{fmt(vals[-1])}{note}"))


def _moved_note(trans):
    """'; transient check: ...' over a diagram: how many values keep their kinds with a longer transient."""
    if not trans:
        return ""
    moved = [t for t in trans.values() if "->" in t]
    return f"; transient check ({next(iter(trans.values())).split(':')[0]}): {len(trans) - len(moved)} of " \
           f"{len(trans)} values keep their kinds" + (" (the longer transient's kinds used)" if moved else "")


def _speed_rows(res_w, kinds_w, named=None, bands=None, trans=None):
    """Sec. 4.2's claims: chaotic at 2 pi and at 3 pi rad/s (0.1 mm), the points spreading wider at 3 pi."""
    rows = [_kind_row(f"motion of the journals at {w / math.pi:g} pi rad/s, 0.1 mm", _kinds_at(kinds_w, w), "chaotic",
                      bands, f"kind {w / math.pi:g} pi", "the set of the two joints' kinds" + _lyap_why(_named(named, w))
                      + _trans_why(trans, w))
            for w in (2 * math.pi, 3 * math.pi) if _kinds_at(kinds_w, w)]
    vals = sorted(round(float(r.value), 9) for r in res_w.runs if r.ok)
    if len(vals) >= 2:
        rows.append(_transition_row(kinds_w, vals, "the motion as the driving speed grows, 0.1 mm (Fig. 29)", "w",
                                    "speed", lambda w: f"{w / math.pi:g} pi rad/s", _moved_note(trans), bands=bands,
                                    key="trend w"))
    a, b = _spread(res_w, 2 * math.pi), _spread(res_w, 3 * math.pi)
    if a is not None and b is not None:
        n = min(_spread_n(res_w, 2 * math.pi), _spread_n(res_w, 3 * math.pi))
        ours = spread_order(max(b.values()), max(a.values()), n, labels=("wider at 3 pi", "not wider at 3 pi"))
        rows.append(_kind_row("Poincaré points spread wider at 3 pi than at 2 pi rad/s", ours, "wider at 3 pi",
                              bands, "wider at 3 pi", quantity="ordering",
                              why=f"largest std {max(a.values()):.3g} vs {max(b.values()):.3g} m/s over {n} "
                                  "points (both listed when within 2 standard errors)"))
    return rows


def _kind_text(c):
    if c is None:
        return "no run"
    if c.kind == "unresolved":
        return f"unresolved (no period in {c.n} cycles, fewer than the 0-1 test's 40)"
    return c.kind + (f" (K = {c.K:.2f})" if c.K is not None else "") + (f", {c.note}" if c.note and c.kind != "unresolved" else "")


def _table(res, kinds, factor, label):
    rows = []
    for r in res.runs:
        k = kinds.get(round(float(r.value), 9), {})
        rows.append({label: float(r.value) * factor, "status": r.status,
                     **{f"{j} kind": (k[j].kind if k.get(j) else None) for j in JOINTS},
                     **{f"{j} K": (k[j].K if k.get(j) else None) for j in JOINTS},
                     **{f"{j} note": (k[j].note if k.get(j) else None) for j in JOINTS},
                     "contact events": r.stats.get("events"), "cpu_s": r.stats.get("cpu_s"), "steps": r.stats.get("steps")})
    return rows


def spread_order(a, b, n, labels=("A", "B"), z=2.0):
    """Which of two standard deviations ``a``, ``b`` (each of ``n`` samples) is larger, decided
    only beyond their sampling error: ln(s) of n samples has a standard error of about
    1/sqrt(2 (n - 1)) (normal theory; 7 % at n = 100), so the difference of two has
    sqrt(2) times that. Returns the larger's label, or both labels (a list) when |ln(a/b)| is
    within ``z`` standard errors: the statistic cannot tell them apart."""
    se = math.sqrt(2.0) / math.sqrt(2.0 * max(n - 1, 1))
    d = math.log(a / b) if a > 0 and b > 0 else 0.0
    if abs(d) <= z * se:
        return sorted(labels)
    return labels[0] if d > 0 else labels[1]


def _order_text(order):
    """spread_order's answer as one text: a decided label as it is, an undecided pair joined (a
    label is a string, so sorting it would sort its letters)."""
    return order if isinstance(order, str) else ", ".join(sorted(order))


def _spread_n(res, value):
    r = next((r for r in res.runs if r.ok and abs(float(r.value) - value) <= 1e-9 * max(1.0, abs(value))), None)
    return 0 if r is None else min(len(r.sections[f"{j}.eccentricity[0]"]) for j in JOINTS)


def _spread(res, value):
    """Standard deviation of each joint's Poincaré samples of the relative velocity (the larger
    of the two eccentricity components) at ``value``; None where that run did not finish."""
    r = next((r for r in res.runs if r.ok and abs(float(r.value) - value) <= 1e-9 * max(1.0, abs(value))), None)
    if r is None:
        return None
    return {j: max(float(np.std(r.sections[f"{j}.eccentricity[{k}]"].xdot)) for k in (0, 1)) for j in JOINTS}


def _spread_note(res, what):
    if what == "clearance":
        v = max(float(r.value) for r in res.runs)
        sp = _spread(res, v)
        if sp is None:
            return f"clearance {1e3 * v:g} mm: the run did not finish"
        return (f"clearance {1e3 * v:g} mm: spread (std) of the Poincaré samples of the relative velocity A "
                f"{sp['A']:.3g} m/s, B {sp['B']:.3g} m/s (paper 4.1: the chaos at A is stronger than at B)")
    a, b = _spread(res, 2 * math.pi), _spread(res, 3 * math.pi)
    if a is None or b is None:
        return "driving speed: the 2 pi or 3 pi run did not finish"
    return (f"spread (std) of the Poincaré samples of the relative velocity at 2 pi vs 3 pi rad/s: A {a['A']:.3g} vs "
            f"{b['A']:.3g} m/s, B {a['B']:.3g} vs {b['B']:.3g} m/s (paper 4.2: the points spread wider at 3 pi)")


def _portraits(res, values, name, title, plt, out, clearance=None, omega=None):
    """Per joint, the phase portrait (eccentricity in mm, its rate in mm/s, the paper's clearance
    unit) with its Poincaré points, and below it the Poincaré map alone at the points' own scale
    with the resolution disc (CLEARANCE_FRACTION x the clearance, times the driving frequency in
    velocity) drawn at their mean: points inside it are 'below resolution'. clearance(v), omega(v):
    the run's clearance (m) and driving frequency (rad/s)."""
    from matplotlib.patches import Ellipse

    fig, ax = plt.subplots(2 * len(JOINTS), len(values), figsize=(5 * len(values), 4 * 2 * len(JOINTS)),
                           squeeze=False)
    for col, v in enumerate(values):
        r = next((r for r in res.runs if abs(float(r.value) - v) <= 1e-12 * max(1.0, abs(v))), None)
        for k, j in enumerate(JOINTS):
            sig = f"{j}.eccentricity[0]"
            a, m = ax[2 * k, col], ax[2 * k + 1, col]
            if r is None or sig not in r.portraits:
                a.set_title(f"{title(v)}: no run")
                continue
            _, x, xd = r.portraits[sig]
            sec = r.sections[sig]
            a.plot(1e3 * np.asarray(x), 1e3 * np.asarray(xd), lw=0.5, color="C0")
            a.plot(1e3 * np.asarray(sec.x), 1e3 * np.asarray(sec.xdot), "o", ms=3, color="C3")
            a.set_xlabel(f"{sig} (eex) [mm]")
            a.set_ylabel(f"d/dt {sig} [mm/s]")
            a.set_title(f"{title(v)}, joint {j}: phase trajectory and Poincaré points", fontsize=9)
            m.plot(1e3 * np.asarray(sec.x), 1e3 * np.asarray(sec.xdot), "o", ms=3, color="C3")
            if clearance is not None and len(sec):
                rad = 1e3 * CLEARANCE_FRACTION * clearance(v)
                m.add_patch(Ellipse((1e3 * float(np.mean(sec.x)), 1e3 * float(np.mean(sec.xdot))), 2 * rad,
                                    2 * rad * omega(v), fill=False, ls="--", color="k", lw=0.8))
                m.autoscale_view()
            m.set_xlabel(f"{sig} [mm]")
            m.set_ylabel(f"d/dt {sig} [mm/s]")
            m.set_title(f"{title(v)}, joint {j}: Poincaré map ({len(sec)} points; dashed: the resolution)",
                        fontsize=9)
            for b in (a, m):
                readable_ticks(b)          # no offset text: the values as printed
    fig.tight_layout()
    safeio.savefig(fig, out / name, dpi=80)
    plt.close(fig)
    return name


#: the paper's abscissae: clearance in mm (Fig. 24), driving speed in multiples of pi rad/s (Fig. 29)
AXES = {"clearance c [m]": ("clearance c [mm]", 1e3), "driving speed w [rad/s]": ("driving speed w [pi rad/s]",
                                                                                  1.0 / math.pi)}


def _diagrams(res, name, label, plt, out):
    from matplotlib.ticker import FuncFormatter

    xlabel, scale = AXES.get(label, (label, 1.0))
    fig, ax = plt.subplots(1, 2, figsize=(13, 4.5))
    for a, j in zip(ax, JOINTS):
        an.plot_bifurcation(res, signal=f"{j}.eccentricity[0]", ax=a, label=label)
        a.set_xlabel(xlabel)
        a.xaxis.set_major_formatter(FuncFormatter(lambda v, _, k=scale: f"{k * v:.4g}"))
        a.set_title(f"joint {j}: Poincaré samples of the relative velocity", fontsize=9)
        a.set_ylabel(f"d/dt {j}.eccentricity[0] [mm/s]")
        a.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{1e3 * v:.6g}"))   # no offset, no multiplier
    fig.tight_layout()
    safeio.savefig(fig, out / name, dpi=90)
    plt.close(fig)
    return name


# --------------------------------------------------------------------------- sensitivity
def _impact_sensitivity(out, s, executor, q0, v0):
    """Impact-force peak at A (0.5 mm, sec. 3.2) against the journal radius and the K form."""
    path = model_path("nine_bar")
    sim = dict(method="lagrange", integrator="RK45", rtol=RTOL, dt_out=s["output step [s]"], q0=q0, v0=v0)
    res = sweep(path, {"A.radius": list(SENS_RADII), "A.stiffness": list(SENS_K)}, s["response t_end [s]"],
                out / "runs" / "sensitivity_A", sim_options=sim, load_options={"clearances": ["A"]},
                executor=executor, progress=None)
    rows = []
    for p in res.points:
        r, k = p.overrides["A.radius"], p.overrides["A.stiffness"]
        if not p.ok:
            rows.append([1e3 * r, k, p.status, float("nan"), float("nan"), float("nan")])
            continue
        tr = p.trajectory()
        pk, tpk = _peak(tr.t, tr.outputs["A.fn"])
        first, t_first = _peak(tr.t, tr.outputs["A.fn"], 0.1)
        rows.append([1e3 * r, k, "success", pk, first, pk / PAPER["A 0.5 mm impact force peak"][0]])
    return {"title": "impact-force peak at A (0.5 mm clearance, sec. 3.2) against the reconstructed journal radius "
                     "and the stiffness form of eq. 8",
            "columns": ["journal radius [mm]", "K", "status", "peak over the run [N]", "peak in the first 0.1 s [N]",
                        "peak / paper's 289 N"],
            "rows": rows,
            "note": "the start state (journal centred, every body moving as in the ideal mechanism) is reconstructed "
                    "too; it is not varied here: the clearance opens the loop at A, so an off-centre start needs a "
                    "re-assembled configuration that the study does not build"}


#: the start-eccentricity study: the journal at A started this far off the bearing's centre
#: (half the 0.5 mm clearance), in four directions of the plane
START_E = 0.25e-3
START_ANGLES = (0.0, 0.5 * math.pi, math.pi, 1.5 * math.pi)


def start_states(q0, e=START_E, angles=START_ANGLES):
    """Assembled configurations of the A-clearance model whose journal at A starts ``e`` off
    the bearing's centre in the directions ``angles`` (every other loop closed, the cranks
    where the drives put them at t = 0). The clearance opens the loop at A: the closures and
    drives left have a two-dimensional null space at the ideal start q0, and moving along it
    moves the journal in the bearing to first order; the map from that motion to the
    eccentricity is measured by finite differences and inverted. Returns (q, e_reached) per
    angle, e_reached from the assembled state."""
    from pinclear.dynamics.simulate import simulate
    from pinclear.io.sidecar import load
    from pinclear.model import kinematics

    mech = load(model_path("nine_bar"), clearances=["A"])
    ws = mech.workspace()
    q0 = np.asarray(q0, float)
    J = kinematics.jacobian(mech, ws, q0, 0.0, with_drives=True)
    null = np.linalg.svd(J)[2][np.linalg.matrix_rank(J):].T          # (nv, 2)

    def ecc(q):
        tr = simulate(mech, 1e-6, q0=q, v0=np.zeros(mech.nv), dt_out=1e-6)
        return np.asarray(tr.outputs["A.eccentricity"][0][:2], float), tr.q[0]

    e0, _ = ecc(q0)
    h = 1e-5
    G = np.column_stack([(ecc(q0 + h * null[:, k])[0] - e0) / h for k in range(null.shape[1])])
    out = []
    for a in angles:
        target = e * np.array([math.cos(a), math.sin(a)])
        ds = np.linalg.lstsq(G, target - e0, rcond=None)[0]
        e_reached, q = ecc(q0 + null @ ds)
        out.append((q.tolist(), e_reached.tolist()))
    return out


def _start_run(job):
    """One 2 s run of the A-clearance model from a given start state (module-level: it pickles
    to worker processes). Returns the impact-force peaks and the run's status and CPU."""
    from pinclear.dynamics.simulate import simulate
    from pinclear.io.sidecar import load

    mech = load(model_path("nine_bar"), clearances=["A"])
    tr = simulate(mech, job["t_end"], method="lagrange", integrator="RK45", rtol=RTOL, dt_out=job["dt"],
                           q0=job["q0"], v0=job["v0"])
    fn = tr.outputs["A.fn"]
    e = tr.outputs["A.eccentricity"][0]
    return {"status": tr.status, "e0": float(np.hypot(e[0], e[1])), "angle": float(math.atan2(e[1], e[0])),
            "peak": _peak(tr.t, fn)[0], "first": _peak(tr.t, fn, 0.1)[0], "cpu": tr.stats.get("cpu_s")}


def _start_sensitivity(s, executor, q0, v0, centred):
    """Impact-force peak at A (0.5 mm) against the journal's start position in the bearing."""
    _say(f"start eccentricity at A: {1e3 * START_E:g} mm in {len(START_ANGLES)} directions")
    jobs = [{"t_end": s["response t_end [s]"], "dt": s["output step [s]"], "q0": q, "v0": list(v0)}
            for q, _ in start_states(q0)]
    rows = []
    if centred is not None:
        fn = centred.outputs["A.fn"]
        rows.append(["centred (the study's start)", 0.0, float("nan"), centred.status, _peak(centred.t, fn)[0],
                     _peak(centred.t, fn, 0.1)[0], _peak(centred.t, fn)[0] / PAPER["A 0.5 mm impact force peak"][0]])
    for r in (executor.map(_start_run, jobs) if executor not in (None, "serial") else map(_start_run, jobs)):
        rows.append([f"{1e3 * r['e0']:.3g} mm off centre", 1e3 * r["e0"], math.degrees(r["angle"]), r["status"],
                     r["peak"], r["first"], r["peak"] / PAPER["A 0.5 mm impact force peak"][0]])
    return {"title": "impact-force peak at A (0.5 mm clearance, sec. 3.2) against the journal's start position in "
                     "the bearing (the paper's start state, Table 4, is lost)",
            "columns": ["start", "start eccentricity [mm]", "direction [deg]", "status", "peak over the run [N]",
                        "peak in the first 0.1 s [N]", "peak / paper's 289 N"],
            "rows": rows,
            "note": "each off-centre start is the ideal start moved along the two-dimensional null space the open "
                    "loop at A leaves (every other loop closed, cranks at their t = 0 angles), velocities projected "
                    "onto the constraints from the ideal ones (pinclear.studies.reproduce.paper002.start_states)"}


def _long_run(s, executor):
    """The 0.01 mm regime (sec. 4.1, the paper's 'quasi-periodic') over more crank turns."""
    mu = {f"{j}.mu": s["mu (sec. 4)"] for j in JOINTS}
    # the paper's 20 transient turns (sec. 4), then more recorded turns than its 100 in the full study
    long = dict(s, cycles=s["long cycles"], **{"transient cycles": max(20, s["transient cycles"])})
    _say(f"0.01 mm over {long['transient cycles']} + {long['cycles']} turns")
    res = _bifurcation({f"{j}.clearance": 1.0 for j in JOINTS}, [1e-5], 1.0, long, executor, mu)
    kinds = _joint_kinds(res, long)
    r = res.runs[0]
    rows = []
    for j in JOINTS:
        c = kinds.get(1e-5, {}).get(j)
        sp = max(float(np.ptp(r.sections[f"{j}.eccentricity[{k}]"].x)) for k in (0, 1)) if r.ok else float("nan")
        rows.append([j, long["transient cycles"], long["cycles"], r.status, _kind_text(c), 1e6 * sp,
                     r.stats.get("cpu_s")])
    return {"title": "the 0.01 mm clearance (mu 0.3, 2 pi rad/s) over more crank turns (paper: quasi-periodic)",
            "columns": ["joint", "transient turns", "recorded turns", "status", "ours", "Poincaré spread of the "
                        "eccentricity [um]", "CPU [s]"],
            "rows": rows,
            "note": "the classification's 'same point' tolerance is rtol x steps per period (one period's global "
                    "error bound); the 0-1 test needs >= 40 recorded turns"}


# --------------------------------------------------------------------------- the study
def run(out, quick=False, workers=None, scheduler=None, settings=None, bands=False, budget=None):
    """Sec. 3 and 4 of paper 002 into ``out``; returns the report dict. ``settings`` replaces
    entries of the study's settings (tests use it for a reduced run). ``bands``: the rows' bands
    over reconstructed.yaml (pinclear.studies.reproduce.paper002.paper002_bands, within ``budget`` CPU s)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    s = {**_settings(quick), **(settings or {})}      # "overrides": load() overrides of every run (e.g. A.ce)
    wall0 = time.perf_counter()
    ex, close = make_executor(workers, scheduler)
    try:
        _say("sec. 3 responses (ideal, A, B, A+B)")
        runs = _response_runs(out, s, ex)
        table = _response_table(runs, s)
        q0, v0 = runs["ideal"].q[0].tolist(), runs["ideal"].v[0].tolist()
        sens = []
        if s.get("sensitivity"):
            _say("sensitivity of the impact force (journal radius x K form, start position)")
            sens += [_impact_sensitivity(out, s, ex, q0, v0), _start_sensitivity(s, ex, q0, v0, runs.get("A 0.5"))]
            if s.get("long cycles"):
                sens.append(_long_run(s, ex))
        sens.append(linkage002.family_table())
        steps = _step_table(runs)
        if steps is not None:
            sens.append(steps)
        measured, ledger, figs_bands = {}, None, []
        _merge(measured, "A 0.5 mm impact force peak", _impact_band(sens))
        if bands:
            got, band_tables, ledger = paper002_bands(out, s, ex, budget)
            for k, b in got.items():
                _merge(measured, k, b)
            sens += band_tables
            if ledger.get("levers"):
                figs_bands = [f for f in [tornado_figure(ledger["levers"], ledger["nominal"], paper002_taus(),
                                                         paper002_values(), out)] if f]
        results = _response_rows(table, measured) + _claim_rows(table, measured)
        notes = [f"sec. 3: the {k} mm run did not finish; its rows are missing"
                 for k in ("A 0.5", "B 0.5", "AB 0.5", "A 0.1") if k not in table]
        notes += _response_notes(table)
        figs = _response_figures(runs, out, plt) + figs_bands
        tables = {"response": table}
        if s["cycles"] > 0:
            r2, n2, f2, t2 = _chaos(s, out, ex, plt, measured)
            results += r2
            notes += n2
            figs += f2
            tables.update(t2)
    finally:
        close()
    cpu_runs = sum(v.get("cpu_s") or 0.0 for v in table.values())
    for t in ("clearance", "speed"):
        cpu_runs += sum(r["cpu_s"] or 0.0 for r in tables.get(t, []))
    notes.append("the 'same point' tolerance of the classification is rtol x steps per period of each run (one "
                 "period's global-error bound, pinclear.analysis.classify.integration_rtol); with fewer than 40 "
                 "recorded cycles a motion without a period is 'unresolved' (the 0-1 test needs more samples)")
    s = dict(s, **{"wall time [s]": round(time.perf_counter() - wall0, 1), "CPU of the simulations [s]": round(cpu_runs, 1),
                   "resolution": f"{CLEARANCE_FRACTION:g} x the clearance", "bands": ledger_text(ledger)})
    groups = {k: v.format(frac=CLEARANCE_FRACTION) for k, v in GROUPS.items()}
    return {"title": "Paper 002: nine-bar with revolute clearances at A and B (responses, chaos, bifurcations)",
            "paper": "002", "settings": s, "claims": claims(results), "results": results, "groups": groups, "notes": notes, "figures": figs,
            "tables": tables, "sensitivity": sens, "bands_ledger": ledger_counts(ledger)}


#: the paper's central claims (docs/claims.md lists each key with its verdict)
CLAIMS = {
    "002-chaos-clearance": (("with friction 0.3 the journals move quasi-periodically at 0.01 mm and chaotically at "
                             "0.8 mm"), "sec. 4.1, Figs. 20-23"),
    "002-trend": (("the motion goes from periodic to chaotic as the clearance grows (0.01-1 mm) and as the "
                   "driving speed grows (pi-3 pi rad/s)"), "sec. 4.1-4.2, Figs. 24, 29"),
    "002-chaos-speed": ("at 0.1 mm the motion is chaotic at 2 pi and at 3 pi rad/s, the points spreading wider at 3 pi",
                        "sec. 4.2, Figs. 25-28"),
    "002-stronger-A": ("the chaos at A is stronger than at B", "sec. 4.1"),
    "002-number": ("a second clearance weakens the impact at B (581 -> 330 N)", "sec. 3.4"),
    "002-responses": (("a clearance shifts the slider's displacement and velocity and brings impact peaks (A 0.5 "
                       "mm: 289 N; the larger the clearance, the more violent)"), "sec. 3.2-3.3, Figs. 6-17"),
}


def claims(results):
    from pinclear.studies.reproduce.report import claim

    def pick(*prefixes):
        return [r for r in results if r["name"].startswith(prefixes)]

    def said(rows):
        return "; ".join(f"{r['name'].split(' (')[0]}: {r['ours']}" for r in rows) or "not run"

    ev = "; ".join(f"{k}: {chaos.exponent_text(e)}" for k, e in LYAPUNOV_NAMED.items())
    ch = pick("motion of the journals A and B")
    tr = pick("the motion as the clearance grows", "the motion as the driving speed grows")
    sp = pick("motion of the journals at", "Poincaré points spread wider")
    return [
        claim("002-chaos-clearance", *CLAIMS["002-chaos-clearance"], "phase portraits and Poincaré maps, by eye",
              said(ch) + (f" (Lyapunov: {ev})" if ev else ""), ch),
        claim("002-trend", *CLAIMS["002-trend"], "bifurcation diagrams against clearance and speed", said(tr), tr),
        claim("002-chaos-speed", *CLAIMS["002-chaos-speed"], "phase portraits and Poincaré maps", said(sp), sp),
        claim("002-stronger-A", *CLAIMS["002-stronger-A"], "the spread of the Poincaré points",
              said(pick("the joint with the stronger chaos")), pick("the joint with the stronger chaos")),
        claim("002-number", *CLAIMS["002-number"], "impact-force curves at B", "; ".join(
            f"{r['ours']} ({r['why']})" for r in pick("impact at B, one")), pick("impact at B, one")),
        claim("002-responses", *CLAIMS["002-responses"], "response curves and printed peaks",
              "; ".join(f"{r['name'].split(',')[0]}: {r['ours']:.4g} {r['unit']}" for r in
                        pick("A 0.5 mm: shift", "A 0.5 mm impact force peak")),
              pick("A 0.5 mm: shift", "B 0.5 mm: shift", "AB 0.5 mm: shift", "A 0.5 mm impact force peak",
                   "A 0.1 mm impact force peak", "B 0.5 mm impact force peak", "AB impact force peak",
                   "A 0.5 mm acceleration peak", "A 0.1 mm acceleration peak")),
    ]


def _impact_band(sens):
    """(lo, hi, what) of the A 0.5 mm whole-run impact peak over the sensitivity tables' finished
    runs (journal radius x K form; start position), or None."""
    peaks, what = [], []
    for tb in sens:
        if tb["title"].startswith("impact-force peak at A"):
            col = tb["columns"].index("peak over the run [N]")
            got = [r[col] for r in tb["rows"] if isinstance(r[col], float) and math.isfinite(r[col])]
            if got:
                peaks += got
                what.append("journal radius x K form" if "radius" in tb["title"] else "start position")
    return (min(peaks), max(peaks), " + ".join(what) + f" ({len(peaks)} runs)") if peaks else None


# ------------------------------------------------------------------------------- paper 002 bands
#: the nine-bar's moving bodies, whose masses and inertias the 'link masses' input scales
LINKS = ("crank1", "coupler2", "link3", "crank4", "link6", "plate7", "link8", "slider9")
#: the motion-kind points of the bands, at the values sec. 4 names (not whole diagrams): 0.01 and
#: 0.8 mm at 2 pi rad/s (Figs. 20-23) with 1 mm, the end of Fig. 24's range (the trend's and the
#: stronger joint's value), 2 pi and 3 pi rad/s at 0.1 mm (Figs. 25-28), mu 0.3
KIND_CLEARANCES = (1e-5, 8e-4, 1e-3)
KIND_SPEEDS = (2 * math.pi, 3 * math.pi)


def linkage_model(values):
    """The sidecar of the nine-bar whose links 6 and 8 are ``values``' 'linkage:L6' and
    'linkage:L8' (the bundled urdf/nine_bar.yaml at the nominal lengths): the family member with
    those lengths, its L1, L4, Hx, Hy fitted again to the printed ideal peaks
    (linkage002.member), written once under the user cache folder."""
    from pinclear.core.jit import cache_dir
    from pinclear.core.errors import InputError

    pinned = {k.split(":", 1)[1]: float(v) for k, v in values.items() if k.startswith("linkage:")}
    bad = sorted(set(pinned) - set(linkage002.FAMILY))
    if bad:
        raise InputError(f"paper 002: linkage:{bad[0]} does not span the family",
                         choices=[f"linkage:{f}" for f in linkage002.FAMILY])
    if all(abs(v - getattr(DIMS, f)) <= 1e-12 for f, v in pinned.items()):
        return model_path("nine_bar")
    over, info = linkage002.member(pinned)
    if info["max |residual|"] > 0.05 or info["least sine"] < linkage002.MIN_SINE - 1e-9:
        raise InputError(f"paper 002: no linkage with {pinned} hits the printed ideal peaks (largest residual "
                         f"{info['max |residual|']:.3g} print precisions, least dyad sine {info['least sine']:.3g})")
    return linkage002.model_for(over, cache_dir() / "linkages")


def mechanism002(values, active, extra=None):
    """The nine-bar with clearances ``active`` and one design point's reconstructed inputs
    (reconstructed.yaml '002': '{j}.*' keys for every active journal, 'mass:links' scales the
    moving bodies' masses and inertias, 'linkage:L6' / 'linkage:L8' pick the fitted family's
    member, :func:`linkage_model`); ``extra``: further load() overrides (the study's)."""
    from pinclear.io.sidecar import load
    from pinclear.studies.reproduce.paper000 import scale_body

    over = {}
    for k, v in values.items():
        if k.startswith("{j}."):
            over.update({k.format(j=j): v for j in active})
    over.update(extra or {})
    mech = load(linkage_model(values), clearances=list(active), overrides=over)
    for body in LINKS:
        scale_body(mech.model, body, float(values.get("mass:links", 1.0)))
    return mech


class _KindMech002:
    """Factory of the kind points' mechanisms (picklable): both journals at clearance ``value``
    (``what`` 'clearance', 2 pi rad/s) or at 0.1 mm driven at ``value`` rad/s ('speed'), mu 0.3."""

    def __init__(self, values, what, mu):
        self.values, self.what, self.mu = values, what, mu

    def __call__(self, value):
        extra = {f"{j}.mu": self.mu for j in JOINTS}
        if self.what == "clearance":
            extra.update({f"{j}.clearance": float(value) for j in JOINTS})
        else:
            extra.update({f"{j}.clearance": 0.1e-3 for j in JOINTS})
            extra.update({k: f * float(value) for k, f in SPEED.items()})
        return mechanism002(self.values, JOINTS, extra)


def _kind_runs(values, s):
    """The kind points' bifurcation runs: {'clearance': result, 'speed': result}."""
    common = dict(signal=SIGNALS, cycles=s["cycles"], transient=s["transient cycles"], per_period=100,
                  sim_options=dict(method="lagrange", integrator="RK45", rtol=RTOL), executor="serial")
    return {"clearance": an.bifurcation(_KindMech002(values, "clearance", s["mu (sec. 4)"]), "clearance",
                                        list(KIND_CLEARANCES), period=1.0, **common),
            "speed": an.bifurcation(_KindMech002(values, "speed", s["mu (sec. 4)"]), "speed", list(KIND_SPEEDS),
                                    period=crank_period, **common)}


def _run002(values, s):
    """Paper 002's measured quantities at one design point: sec. 3's four response runs (the
    shifts at the ideal peaks, the impact peaks over the run, the steady peaks, the one-vs-two
    ordering at B) and sec. 4's kinds at the named values (the set of A's and B's kinds, and
    whether the Poincaré points spread wider at 3 pi), each computed as the rows' are."""
    from pinclear.dynamics.simulate import simulate

    ideal = simulate(mechanism002(values, ()), s["response t_end [s]"], rtol=RTOL, dt_out=s["output step [s]"])
    q0, v0 = ideal.q[0].tolist(), ideal.v[0].tolist()
    runs = {"ideal": ideal}
    for key, active, c in (("A 0.5", ("A",), 0.5e-3), ("A 0.1", ("A",), 0.1e-3), ("B 0.5", ("B",), 0.5e-3),
                           ("AB 0.5", ("A", "B"), 0.5e-3)):
        mech = mechanism002(values, active, {f"{j}.clearance": c for j in active})
        tr = simulate(mech, s["response t_end [s]"], method="lagrange", integrator="RK45", rtol=RTOL,
                      dt_out=s["output step [s]"], q0=q0, v0=v0)
        if tr.status != "success":
            return {"status": f"{key} mm: {tr.status}: {tr.message}"}
        runs[key] = tr
    table = _response_table(runs, s)
    out = {}
    for name in ("A", "B", "AB"):
        r = table[f"{name} 0.5"]
        out[f"{name} shift d"] = 1e3 * r["displacement shift at the ideal peak [m]"]
        out[f"{name} shift v"] = 1e3 * r["velocity shift at the ideal peak [m/s]"]
    out["A 0.5 mm impact force peak"] = table["A 0.5"]["A impact force peak [N]"]
    out["B 0.5 mm impact force peak"] = table["B 0.5"]["B impact force peak [N]"]
    out["AB impact force peak at B"] = table["AB 0.5"]["B impact force peak [N]"]
    out["A 0.5 mm acceleration peak steady"] = table["A 0.5"]["steady acceleration peak [m/s^2]"]
    out["A 0.1 mm acceleration peak steady"] = table["A 0.1"]["steady acceleration peak [m/s^2]"]
    out["A 0.1 mm impact force peak steady"] = table["A 0.1"]["A steady impact force peak [N]"]
    claim = _claim_rows(table)
    out["one vs two"] = claim[0]["ours"] if claim else "no run"
    if s["cycles"] > 0:
        kr = _kind_runs(values, s)
        for res, what in ((kr["clearance"], "clearance"), (kr["speed"], "speed")):
            if res.failures:
                return {"status": f"{what} kind point: " + "; ".join(f"{v}: {st}" for v, st, _ in res.failures)}
        kinds = _joint_kinds(kr["clearance"], s)
        for c in KIND_CLEARANCES:
            out[f"kind {1e3 * c:g} mm"] = ", ".join(_kinds_at(kinds, c))
        vals = [round(c, 9) for c in (KIND_CLEARANCES[0], KIND_CLEARANCES[-1])]
        out["trend c"] = _transition_row(kinds, vals, "", "c", "clearance", str)["ours"]
        sp = _spread(kr["clearance"], KIND_CLEARANCES[-1])
        if sp is not None:
            out["stronger"] = _order_text(spread_order(sp["A"], sp["B"], _spread_n(kr["clearance"],
                                                                                       KIND_CLEARANCES[-1])))
        kinds_w = _joint_kinds(kr["speed"], s, clearance=0.1e-3)
        for w in KIND_SPEEDS:
            out[f"kind {w / math.pi:g} pi"] = ", ".join(_kinds_at(kinds_w, w))
        a, b = _spread(kr["speed"], KIND_SPEEDS[0]), _spread(kr["speed"], KIND_SPEEDS[1])
        if a is not None and b is not None:
            n = min(_spread_n(kr["speed"], KIND_SPEEDS[0]), _spread_n(kr["speed"], KIND_SPEEDS[1]))
            out["wider at 3 pi"] = _order_text(spread_order(max(b.values()), max(a.values()), n,
                                                                 labels=("wider at 3 pi", "not wider at 3 pi")))
    out["status"] = "success"
    return out


#: the band keys of the motion kinds and orderings (categorical: tau 0)
KIND_KEYS_002 = ([f"kind {1e3 * c:g} mm" for c in KIND_CLEARANCES] + [f"kind {w / math.pi:g} pi" for w in KIND_SPEEDS]
                 + ["wider at 3 pi", "one vs two", "trend c", "stronger"])


def paper002_taus():
    """{band key: tau} of the rows the bands measure (verdicts.row's rule for each row)."""
    taus = {}
    for name in ("A", "B", "AB"):
        for k, paper, base in (("d", PAPER[f"{name} displacement"][0], PAPER["ideal displacement peak"][0]),
                               ("v", PAPER[f"{name} velocity"][0], PAPER["ideal velocity peak"][0])):
            taus[f"{name} shift {k}"] = max(1.0, tolerance("kinematic peak")[0] * abs(1e3 * (paper - base)))
    for pk in ("A 0.5 mm impact force peak", "B 0.5 mm impact force peak", "AB impact force peak at B"):
        taus[pk] = max(half_digit(f"{PAPER[pk][0]:g}"), tolerance("impact peak")[0] * PAPER[pk][0])
    for pk in STEADY_ROWS:
        q = "acceleration peak" if "acceleration" in pk else "impact peak"
        taus[pk + " steady"] = max(half_digit(f"{PAPER[pk][0]:g}"), tolerance(q)[0] * PAPER[pk][0])
    taus.update({k: 0.0 for k in KIND_KEYS_002})
    return taus


def paper002_values():
    """{band key: the paper's value} (sec. 3-4), for the levers of the rows that miss it."""
    out = {}
    for name in ("A", "B", "AB"):
        out[f"{name} shift d"] = 1e3 * (PAPER[f"{name} displacement"][0] - PAPER["ideal displacement peak"][0])
        out[f"{name} shift v"] = 1e3 * (PAPER[f"{name} velocity"][0] - PAPER["ideal velocity peak"][0])
    for pk in ("A 0.5 mm impact force peak", "B 0.5 mm impact force peak", "AB impact force peak at B"):
        out[pk] = PAPER[pk][0]
    out.update({pk + " steady": PAPER[pk][0] for pk in STEADY_ROWS})
    out.update({"kind 0.01 mm": "quasi-periodic", "kind 0.8 mm": "chaotic", "kind 2 pi": "chaotic",
                "kind 3 pi": "chaotic", "wider at 3 pi": "wider at 3 pi", "one vs two": "weaker with A and B",
                "trend c": "periodic, then non-periodic as c grows", "stronger": "A"})
    return out


#: CPU s of one 002 design point (four 2 s response runs, four kind runs of the study's length),
#: a first guess before any point has run: the measured mean replaces it
COST_002 = {"quick": 40.0, "full": 250.0}


def paper002_bands(out, s, executor, budget=None):
    """(bands {row key: (lo, hi, what) | (kinds, what) | NotReached}, tables, ledger) of paper
    002: every reconstructed input screened on the quick study's runs, then each row banded over
    the inputs that matter for it at the study's settings (pinclear.studies.reproduce.bands); the
    points stored under OUT/bands/ (a second call resumes)."""
    from pinclear.studies.reproduce.bands import PointStore, measure_bands

    screen_s = _settings(True)
    keep = ("response t_end [s]", "output step [s]", "cycles", "transient cycles", "mu (sec. 4)")
    store = PointStore(out, "002", {"screen": {k: screen_s[k] for k in keep}, "band": {k: s[k] for k in keep}})
    taus = paper002_taus()
    quick = bool(s.get("quick"))
    got, table, ledger = measure_bands(partial(_run002, s=dict(s)), reconstructed_inputs("002"), list(taus), taus, store, executor,
                                       budget, COST_002["quick" if quick else "full"],
                                       screen_fn=None if quick else partial(_run002, s=screen_s), papers=paper002_values())
    # the speed trend's band would rerun the speed diagram at each point: its cost, stated
    n_pts = ledger["ran"] + ledger["resumed"] + ledger["not_reached"]
    per_run = (ledger["cpu_s"] + ledger["cpu_stored_s"]) / max(ledger["ran"] + ledger["resumed"], 1) / (
        len(KIND_CLEARANCES) + len(KIND_SPEEDS) + 4 * s["response t_end [s]"] / max(s["cycles"] + s["transient cycles"], 1))
    got.setdefault("trend w", NotReached(n_pts * len(s["speeds [pi rad/s]"]) * per_run, "the speed diagram"))
    return got, [t for t in (table,) if t], ledger
