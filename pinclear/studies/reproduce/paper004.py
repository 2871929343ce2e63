"""Paper 004 (4-UPS/UPR parallel mechanism, screw-theory inverse dynamics, Geng et al. 2014),
sec. 4, in the paper's order:

* sec. 4.1, the first-order influence coefficients G_q^p at the initial configuration
  (:func:`influence_rows`);
* sec. 4.2, the drive-force peaks of its three cases, gravity off as in the paper's example
  (low speed with the platform only, high speed with the platform only, high speed with the
  limbs), for each reading of the motion law's units (:func:`peak_rows`). As printed, both laws
  cross singular configurations of the Table 1 layout, where the drive forces are unbounded;
  a peak then exists only below a cut-off of the actuation map's condition number, and the row's
  band is the peak over the cut-offs. Readings that remove the crossings are compared in full;
* the time scaling and the limbs' share (:func:`ratio_rows`);
* Fig. 2's hinge layouts (:func:`layout_notes`).

``bands=True`` varies the reconstructed inputs (limb centres of mass, platform centre of mass:
docs/papers.md and pinclear/reproduce/reconstructed.yaml) one at a time and in a small
space-filling sample (pinclear.studies.reproduce.bands).
"""
from __future__ import annotations

import numpy as np

from pinclear.core import safeio
from pinclear.dynamics import screw
from pinclear.mechanisms import four_ups_upr as mod
from pinclear.studies.reproduce.bands import design, reconstructed_inputs, run_points, within_budget
from pinclear.studies.reproduce.verdicts import row

#: paper 004 sec. 4.1, G_q^p at the initial configuration (columns P1..P4, virtual 1, virtual 2)
PAPER_G = np.array([[0.8237, 0.8237, -0.8673, -0.8673, 0.0, 0.4628],
                    [-7.7204, 7.7204, -6.5346, 6.5346, 0.9231, 0.0],
                    [0, 0, 0, 0, 1.0, 0],
                    [4.6366, -4.6366, 4.8741, -4.8741, -0.6544, 0.0],
                    [0, 0, 0, 0, 0, 0.38],
                    [0.3066, 0.3066, 0.3229, 0.3229, 0.0, 0.0]])
#: paper 004 sec. 4.2: (law, limbs, peak as printed). The text says 'about 85 N' (约 85 N), '2 080 N,
#: about 24.5 times', 'about 2 560 N': read off Figs. 7-9
PAPER_PEAKS = {"low speed, platform only": ("low", False, "85"),
               "high speed, platform only": ("high", False, "2080"),
               "high speed, with limbs": ("high", True, "2560")}
#: reading precision of the peaks (N): 'about 85 N' is a round number read off Fig. 7 (5 N steps);
#: the four-digit values are given to 10 N
READING = {"85": 2.5, "2080": 5.0, "2560": 5.0}
#: condition-number cut-offs of the actuation map over which a peak is followed where the motion
#: crosses singular configurations
CUTOFFS = (10.0, 15.0, 20.0, 30.0, 50.0, 75.0, 100.0, 150.0, 200.0)
#: readings of the motion law's units (scale factors of the amplitudes of alpha, beta, dx, dz).
#: As printed (0.2 rad, 0.2 rad, 0.1 m, 0.2 m) the platform crosses singular configurations; a
#: dz amplitude of 0.02 m (a decimal slip) or angles of 0.1 rad remove the crossings
READINGS = {"as printed": (1.0, 1.0, 1.0, 1.0), "dz amplitude 0.02 m": (1.0, 1.0, 1.0, 0.1),
            "angles 0.1 rad": (0.5, 0.5, 1.0, 1.0)}
#: drive colours: none of them red or grey (the ill-conditioned spans are marked in grey)
COLOURS = ("C0", "C1", "C2", "C4")

GROUPS = {
    "G": "G's actuated columns follow from Table 1 and H alone (no reconstructed input enters them). The limbs' "
         "rows J of the actuation Jacobian, computed from Table 1 alone, give J G = I to {ours:.0e} for ours; the "
         "paper's printed G misses it by {res:.1%} at best over every vertical reference point of the twist "
         "(|h| <= 2 m; {res0:.1%} at the origin). A difference beyond tau is the paper's residual, not our geometry",
    "peak": "as printed, both laws cross singular configurations of the Table 1 layout twice per period (drive "
            "forces unbounded there); the band is the peak below the condition-number cut-off over "
            "{cuts}, a free choice the paper does not make. Readings of the law's units that remove the "
            "crossings are compared in full (no cut-off). Limb rod lengths and centres of mass are "
            "reconstructed (docs/papers.md, paper 004)",
    "ratio": "the high-speed law is the low-speed law 5 times faster: without gravity and limbs every force scales "
             "by exactly 25 for any geometry and mass, so the high-speed platform-only peak carries no fact beyond "
             "the low-speed one and this ratio",
}


def reading_motion(law, scale):
    """The platform motion t -> (SE3, V, A) of ``law`` with its amplitudes scaled by ``scale``."""
    amp, w = mod.LAWS[law]
    a = amp * np.asarray(scale, float)

    def motion(t):
        s, c = np.sin(w * t), np.cos(w * t)
        x = a * s
        V, A = mod.coupled_accel(x, a * w * c, -a * w * w * s, mod.H0)
        return mod.coupled_pose(*x, H=mod.H0), V, A
    return motion


def peak_below(res, cutoff):
    """Largest |drive force| where cond < cutoff, and the fraction of the period that keeps."""
    well = res.cond < cutoff
    return (float(np.abs(res.tau[well]).max()) if well.any() else float("nan")), float(well.mean())


def actuation_rows(h=0.0):
    """The four UPS limbs' rows of the actuation Jacobian at the initial configuration, from
    Table 1 alone: the rate of limb i's length is s_i . (v_r + omega x (b_i - r)) = [(b_i - r) x s_i,
    s_i] . (omega; v_r), with r = (0, 0, h) the twist's reference point (the origin: h = 0)."""
    r = np.array([0.0, 0.0, h])
    b = mod.LAYOUTS["f"] + np.array([0.0, 0.0, mod.H0])
    rows = []
    for ai, bi in zip(mod.BASE_POINTS, b):
        u = (bi - ai) / np.linalg.norm(bi - ai)
        rows.append(np.r_[np.cross(bi - r, u), u])
    return np.array(rows)


def inverse_residual(G, h=0.0):
    """max |J_act G[:, :4] - I|: how far G's actuated columns are from inverting the limbs' rows."""
    return float(np.abs(actuation_rows(h) @ np.asarray(G)[:, :4] - np.eye(4)).max())


def influence_rows(mech, system):
    """Sec. 4.1: G at the initial configuration against the printed G, and the groups' paragraph."""
    G, _ = system.influence_coefficients(mech.q0)
    # the printed G against the Jacobian its own Table 1 implies, at the reference point that suits it best
    res_paper = min(inverse_residual(PAPER_G, h) for h in np.linspace(-2.0, 2.0, 4001))
    ours = inverse_residual(G)
    rows = [row(f"G[{i + 1},{j + 1}] (limb P{j + 1})", "influence coefficient", G[i, j], PAPER_G[i, j],
                band_from="exact: Table 1 and H only", printed=f"{PAPER_G[i, j]:.4f}", group="G")
            for j in range(4) for i in range(6) if abs(PAPER_G[i, j]) > 0.1]
    return rows, GROUPS["G"].format(res=res_paper, res0=inverse_residual(PAPER_G), ours=max(ours, 1e-16))


def case_peaks(mech, system, n, reading):
    """{case: (inverse-dynamics result, times)} of the three cases under one reading of the law."""
    out = {}
    for label, (law, limbs, _) in PAPER_PEAKS.items():
        t = np.linspace(0.0, mod.PERIODS[law], n)
        res = screw.inverse_dynamics(mech, reading_motion(law, READINGS[reading]), t, limbs=limbs, gravity=False,
                                     system=system)
        out[label] = (res, t)
    return out


def peak_of(res):
    """(central peak, band lo, band hi, band_from): over the whole period when the motion does
    not cross a singular configuration, else below the cut-offs (central: cut-off 20)."""
    if not res.crossings:
        pk = float(np.abs(res.tau).max())
        return pk, pk, pk, ""
    curve = [peak_below(res, c)[0] for c in CUTOFFS]
    return peak_below(res, 20.0)[0], min(curve), max(curve), f"cut-off {CUTOFFS[0]:g}-{CUTOFFS[-1]:g}"


def peak_rows(runs, bands=None):
    """Sec. 4.2: per reading, the low-speed and the with-limbs peaks (the high-speed platform-only
    peak is 25 x the low-speed one: :func:`ratio_rows`). ``bands``: {(reading, case): (lo, hi, what)}
    measured by --bands over the reconstructed inputs."""
    rows = []
    for reading, cases in runs.items():
        for label in ("low speed, platform only", "high speed, with limbs"):
            res, _ = cases[label]
            pk, lo, hi, what = peak_of(res)
            b = (bands or {}).get((reading, label))
            if b is not None:
                lo, hi, what = min(lo, b[0]), max(hi, b[1]), ", ".join(x for x in (what, b[2]) if x)
            printed = PAPER_PEAKS[label][2]
            rows.append(row(f"peak drive force, {label}, law {reading}"
                            + (f" ({len(res.crossings)} singular crossings)" if res.crossings else ""),
                            "drive force peak", pk, float(printed), "N", band=(lo, hi), band_from=what,
                            reading=READING[printed], group="peak"))
    return rows


def ratio_rows(runs, bands=None):
    """The 5x time scaling (25x forces) and the limbs' share of the high-speed peak, per reading."""
    rows = []
    p_lo, p_hi, p_limbs = (float(PAPER_PEAKS[k][2]) for k in PAPER_PEAKS)
    # the paper's ratio and its reading precision from those of its two peaks
    r_paper = p_hi / p_lo
    r_prec = r_paper * (READING["85"] / p_lo + READING["2080"] / p_hi)
    for reading, cases in runs.items():
        lo_res, hi_res = cases["low speed, platform only"][0], cases["high speed, platform only"][0]
        ratio = float(np.abs(hi_res.tau).max() / np.abs(lo_res.tau).max()) if not lo_res.crossings else \
            peak_below(hi_res, 20.0)[0] / peak_below(lo_res, 20.0)[0]
        rows.append(row(f"high / low speed peak, platform only, law {reading}", "force ratio", ratio, r_paper,
                        band_from="exact for any reconstruction (time scaling)", reading=r_prec, group="ratio"))
        if not hi_res.crossings:
            limbs = cases["high speed, with limbs"][0]
            share = float(np.abs(limbs.tau).max() / np.abs(hi_res.tau).max())
            b = (bands or {}).get((reading, "limbs share"))
            rows.append(row(f"with limbs / platform only, high speed, law {reading}", "force ratio", share,
                            p_limbs / p_hi, band=None if b is None else b[:2], band_from="" if b is None else b[2],
                            reading=(p_limbs / p_hi) * (5.0 / p_limbs + 5.0 / p_hi), group="peak"))
    return rows


def layout_notes():
    notes = []
    for lay in "abcdef":
        m = mod.load(layout=lay)
        sg = screw.singularity(m, m.q0)
        notes.append(f"hinge layout ({lay}) of Fig. 2 at the initial configuration: rank {sg['rank']} of 6, "
                     f"condition {sg['cond']:.3g}")
    return notes


def sensitivity_table(runs):
    rows = []
    for label, (law, limbs, printed) in PAPER_PEAKS.items():
        res, _ = runs["as printed"][label]
        for c in CUTOFFS:
            pk, kept = peak_below(res, c)
            rows.append([label, c, 100.0 * kept, pk, float(printed), 100.0 * (pk - float(printed)) / float(printed)])
    return {"title": "peak drive force against the condition-number cut-off, law as printed (the singular "
                     "crossings are excluded only by the cut-off)",
            "columns": ["case", "cut-off", "share of the period kept [%]", "peak [N]", "paper [N]", "deviation [%]"],
            "rows": rows,
            "note": "no single cut-off is the paper's: it does not say how (or whether) it excluded the singular "
                    "crossings; the table shows how far each peak moves with that choice"}


def readings_table(runs):
    rows = []
    for reading, cases in runs.items():
        for label, (res, _) in cases.items():
            rows.append([reading, label, len(res.crossings), float(np.max(res.cond)), float(np.abs(res.tau).max()),
                         float(PAPER_PEAKS[label][2])])
    return {"title": "the motion law's readings: singular crossings and the peak over the whole period",
            "columns": ["reading", "case", "singular crossings", "largest cond", "peak over the period [N]",
                        "paper [N]"],
            "rows": rows,
            "note": "the paper's peaks are finite and checked in ADAMS, which suggests its motion did not cross a "
                    "singular configuration; each reading that removes the crossings is compared in full"}


def run(out, quick=False, workers=None, scheduler=None, bands=False, budget=None):
    n = 201 if quick else 2001
    mech = mod.load()
    system = screw.screw_system(mech)
    g_rows, why_g = influence_rows(mech, system)
    runs = {reading: case_peaks(mech, system, n, reading) for reading in READINGS}
    band = None
    if bands:
        # 501 samples per period: the peaks of the crossing-free readings move by < 0.1 % from 2001
        band, band_table = paper004_bands(min(n, 501), workers=workers, scheduler=scheduler, budget=budget)
    results = g_rows + peak_rows(runs, band) + ratio_rows(runs, band)
    notes = ["the virtual-joint columns 5 and 6 of G depend on how the UPR limb's virtual joints are chosen "
             "(the paper's list of them is not legible in its sec. 4.1); they are not compared"]
    for label, (res, _) in runs["as printed"].items():
        notes.append(f"{label}, law as printed: peak over the whole period {np.abs(res.tau).max():.4g} N, because "
                     "the motion crosses singular configurations at t = "
                     + ", ".join(f"{tc:.4f} s" for tc, _ in res.crossings))
    notes += layout_notes()
    plot_drive_forces(out, runs)
    sens = [sensitivity_table(runs), readings_table(runs)] + ([band_table] if bands else [])
    groups = {"G": why_g, "peak": GROUPS["peak"].format(cuts=", ".join(f"{c:g}" for c in CUTOFFS)),
              "ratio": GROUPS["ratio"]}
    return {"title": "Paper 004: screw-theory inverse dynamics of the 4-UPS/UPR mechanism", "paper": "004",
            "settings": {"samples per period": n, "gravity": "off (as the paper's example)",
                         "layout": "f (Table 1)", "quick": bool(quick), "bands": bool(bands),
                         "cut-offs": ", ".join(f"{c:g}" for c in CUTOFFS), "readings": ", ".join(READINGS)},
            "results": results, "groups": groups, "notes": notes,
            "figures": ["drive_forces.png", "peak_vs_cutoff.png"], "sensitivity": sens}


def plot_drive_forces(out, runs, show=20.0):
    """drive_forces.png (time histories, law as printed and the crossing-free readings) and
    peak_vs_cutoff.png (the peak against the cut-off, law as printed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(PAPER_PEAKS), 1, figsize=(9, 10.5))
    for ax, (label, (_, _, printed)) in zip(axes, PAPER_PEAKS.items()):
        paper = float(printed)
        res, t = runs["as printed"][label]
        lim = 2.0 * paper
        for i, name in enumerate(res.drive_names):
            ax.plot(t, np.clip(res.tau[:, i], -lim, lim), color=COLOURS[i % len(COLOURS)], lw=1.0, label=name)
        for k, reading in enumerate(r for r in runs if r != "as printed"):
            rr, tr = runs[reading][label]
            ax.plot(tr, np.abs(rr.tau).max(axis=1), color="k", lw=0.7, ls=(":", "-.")[k % 2],
                    label=f"max |drive force|, law {reading}")
        ax.set_ylim(-1.05 * lim, 1.05 * lim)
        ax.axhline(paper, color="k", ls="--", lw=0.8)
        ax.axhline(-paper, color="k", ls="--", lw=0.8)
        clipped = np.abs(res.tau).max(axis=1) > lim
        for mask, kw in ((res.cond >= show, dict(color="0.85", alpha=0.6)),
                         (clipped, dict(color="0.35", alpha=0.45, hatch="xx"))):
            edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(int), 0]))
            for a, b in zip(edges[::2], edges[1::2]):
                ax.axvspan(t[a], t[min(b, len(t) - 1)], lw=0, **kw)
        ax.set_title(f"{label}, law as printed. Light grey: cond >= {show:g}; dark hatched: forces beyond the frame "
                     f"(peak {np.abs(res.tau).max():.3g} N\nat the singular crossings); dashed: the paper's peak "
                     f"{paper:g} N; black: the readings without crossings", fontsize=9)
        ax.set_ylabel("drive force [N]")
    axes[0].legend(fontsize=7, ncol=3, loc="upper center", bbox_to_anchor=(0.5, -0.08), framealpha=1.0)
    axes[-1].set_xlabel("t [s]")
    fig.tight_layout()
    safeio.savefig(fig, out / "drive_forces.png", dpi=100)
    plt.close(fig)
    figc, axc = plt.subplots(1, len(PAPER_PEAKS), figsize=(14, 4.2))
    for ax, (label, (_, _, printed)) in zip(axc, PAPER_PEAKS.items()):
        res, _ = runs["as printed"][label]
        curve = [peak_below(res, c) for c in CUTOFFS]
        ax.plot(CUTOFFS, [p for p, _ in curve], "o-", color="C0", label="ours (left axis)")
        ax.plot([], [], "s:", color="C7", ms=3, label="share of the period kept (right axis)")
        ax.axhline(float(printed), color="k", ls="--", lw=1.0, label=f"paper {printed} N")
        ax.set_xscale("log")
        ax.set_xlabel("condition-number cut-off [-]")
        ax.set_ylabel("peak |drive force| below the cut-off [N]")
        ax.set_title(label, fontsize=10)
        tw = ax.twinx()
        tw.plot(CUTOFFS, [100 * f for _, f in curve], "s:", color="C7", ms=3)
        tw.set_ylabel("share of the period below the cut-off [%]", color="C7")
        tw.set_ylim(0, 100)
        ax.legend(fontsize=7, loc="upper left")
    figc.tight_layout()
    safeio.savefig(figc, out / "peak_vs_cutoff.png", dpi=100)
    plt.close(figc)


def paper004_point(values, n=2001):
    """The peaks of paper 004's three cases under each reading of the motion law, with the limb
    centres of mass moved along their rods and the platform's along its normal (module-level:
    it pickles to worker processes)."""
    import pinocchio as pin

    from pinclear.dynamics import screw
    from pinclear.mechanisms import four_ups_upr as mod

    mech = mod.load()
    model = mech.model
    for key, joints in _JOINTS_004.items():
        for name in joints:
            j = model.getJointId(name)
            y = model.inertias[j]
            model.inertias[j] = pin.Inertia(y.mass, np.asarray(y.lever) * float(values[key]), y.inertia)
    j = model.getJointId("upr_r")
    y = model.inertias[j]
    model.inertias[j] = pin.Inertia(y.mass, np.asarray(y.lever) + np.array([0.0, 0.0, float(values["com:platform"])]),
                                    y.inertia)
    system = screw.screw_system(mech)
    out = {}
    for reading in READINGS:
        cases = case_peaks(mech, system, n, reading)
        for label, (res, _) in cases.items():
            pk, lo, hi, _ = peak_of(res)
            out[f"{reading}|{label}|lo"], out[f"{reading}|{label}|hi"] = lo, hi
        limbs, plat = cases["high speed, with limbs"][0], cases["high speed, platform only"][0]
        if not plat.crossings:
            out[f"{reading}|limbs share|lo"] = out[f"{reading}|limbs share|hi"] = float(
                np.abs(limbs.tau).max() / np.abs(plat.tau).max())
    return out


def paper004_bands(n, workers=None, scheduler=None, budget=None):
    """({(reading, case): (lo, hi, what)}, sensitivity table) of paper 004 over its inputs."""

    inputs = reconstructed_inputs("004")
    pts = within_budget(design(inputs), COST_004, budget)
    res = run_points(_Point004(n), pts, workers, scheduler)
    what = f"{len(pts)} input sets: {sum(not p[0].startswith('space') for p in pts)} one-at-a-time, " \
           f"{sum(p[0].startswith('space') for p in pts)} space-filling"
    bands, rows = {}, []
    keys = [(r, c) for r in READINGS for c in list(PAPER_PEAKS) + ["limbs share"]]
    for reading, case in keys:
        lo = [v[f"{reading}|{case}|lo"] for v in res.values() if isinstance(v, dict) and f"{reading}|{case}|lo" in v]
        hi = [v[f"{reading}|{case}|hi"] for v in res.values() if isinstance(v, dict) and f"{reading}|{case}|hi" in v]
        if lo:
            bands[(reading, case)] = (min(lo), max(hi), what)
    for label, v in res.items():
        if isinstance(v, dict):
            rows.append([label] + [v.get(f"{r}|{c}|hi", float("nan")) for r in READINGS
                                   for c in ("low speed, platform only", "high speed, with limbs")])
        else:
            rows.append([label, str(v)] + [float("nan")] * (2 * len(READINGS) - 1))
    table = {"title": "bands (--bands): the peaks over the reconstructed inputs of reconstructed.yaml",
             "columns": ["input set"] + [f"{c.split(',')[0]} {c.split(', ')[1]}, {r} [N]" for r in READINGS
                                         for c in ("low speed, platform only", "high speed, with limbs")],
             "rows": rows,
             "note": f"{what}; a law with singular crossings lists its peak at the largest cut-off"}
    return bands, table


class _Point004:
    """paper004_point at another sample count (picklable)."""

    def __init__(self, n):
        self.n = n

    def __call__(self, values):
        return paper004_point(values, self.n)


# ------------------------------------------------------------------------------- paper 004
#: a 004 design point's cost (CPU s, three cases x three readings at 2001 samples; measured ~3 s)
COST_004 = 5.0
_JOINTS_004 = {"com:ups_swing": [f"ups{i}_u2" for i in range(1, 5)], "com:ups_rod": [f"ups{i}_p" for i in range(1, 5)],
               "com:upr_swing": ["upr_u2"], "com:upr_rod": ["upr_p"]}
