"""Wear studies (``pinclear study``; docs/wear_lubrication.md): what the seed papers name as their
next step, run on pinclear's worn joints. Not a reproduction (``pinclear reproduce`` owns those):
each study writes its own findings.

paper002: the paper-002 nine-bar (Chen & Pan 2021; urdf/nine_bar.yaml, every dimension
reconstructed, docs/papers.md) with both clearances A and B worn together by Archard's law over a
service life (pinclear.analysis.wear_life's depth-limited update, its step chosen by the convergence test), at two nominal
clearances, friction 0.3 as in the paper's sec. 4: how A and B grow, and the 0-1 test K (Gottwald &
Melbourne) of the journals' stroboscopic eccentricities, new vs worn, at each clearance (does the
chaos window move).
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from pinclear.core import safeio
from pinclear.core.registry import Entry, Registry
from pinclear.core.version import provenance

#: the study's wear law: k for mild wear of lubricated-free steel on steel, hardness of a through-
#: hardened pin (both stated, not from paper 002, which gives none)
WEAR = {"model": "archard", "k": 1e-5, "hardness": 2e9, "nodes": 360}
#: Archard's k / H (1/Pa), the stated ranges both studies read their depths over: dry mild wear of
#: steel on steel k 1e-6 - 1e-4 (Archard & Hirst 1956; Rabinowicz 1995, table of wear coefficients)
#: over H 2-8 GPa (through-hardened to bearing steel, HV 200-800); boundary-lubricated steel k
#: 1e-9 - 1e-7 (the same table, two to three decades below dry) over the same H
K_OVER_H = {"dry": (1e-6 / 8e9, 1e-4 / 2e9), "lubricated": (1e-9 / 8e9, 1e-7 / 2e9)}
#: name -> "module:function" of each study (function(out, quick=False, smoke=False) -> rows)
STUDIES = Registry("study", {e.name: e for e in (
    Entry("paper002", "pinclear.studies.wear:paper002", "the nine-bar linkage worn at A and B"),
    Entry("paper000", "pinclear.studies.wear_paper000:paper000", "the 4UPS-UPU's spherical joint S2 worn"))},
    record=Entry)


def _settings(quick, smoke=False):
    # the depth scheme (pinclear.analysis.wear_life): the worn profile changes this linkage's motion (the deepest
    # node's rate grows ~30 x over the first 10 um at 0.1 mm, docs/study/paper002/README.md), so the
    # updates are limited in depth, first at 0.2 % of the clearance, the step halved per trial
    return {"clearances [mm]": [0.1, 0.8], "cycles": 1e6 if not quick else 1e5, "period [s]": 1.0,
            "scheme": "depth", "first step [fraction of c]": 2e-3, "max rounds": 3, "max updates": 4000,
            "block tol": 0.025, "max block periods": 16,
            "chaos periods": 100 if not quick else 60, "transient periods": 10,
            "rtol": 1e-6, "dt_out [s]": 1e-4, "mu": 0.3, "wear": WEAR, "quick": quick} if not smoke else {
        # the whole path in about a minute (CI's check that the command runs), not a result
        "clearances [mm]": [0.8], "cycles": 400.0, "period [s]": 1.0, "scheme": "depth",
        "first step [fraction of c]": 2e-3, "max rounds": 2, "max updates": 40, "block tol": 0.025,
        "max block periods": 2, "chaos periods": 24, "transient periods": 2, "rtol": 1e-6, "dt_out [s]": 1e-4,
        "mu": 0.3, "wear": WEAR, "quick": True, "smoke": True}


def previous_rows(out):
    """The rows of the results.json this run is about to replace in ``out`` (None if there is none
    or it does not parse): the README says what moved, so a conclusion the new run does not keep is
    withdrawn in writing, not overwritten in silence."""
    try:
        old = json.loads((Path(out) / "results.json").read_text())
        made = old.get("versions", {}).get("commit")
        return old["rows"], (f"commit {made[:12]}" if made else "a build before the results recorded their commit")
    except (OSError, ValueError, KeyError, TypeError):
        return None


def moved_lines(previous, rows, key, heads):
    """Lines of the headline numbers ``heads`` ({label: function(row) -> text}) per row (matched by
    ``key``) that changed from ``previous`` (previous_rows) to this run."""
    if not previous:
        return []
    old_rows, commit = previous
    old = {r.get(key): r for r in old_rows}
    lines = []
    for r in rows:
        o = old.get(r[key])
        if o is None:
            lines.append(f"- {r[key]}: new in this run")
            continue
        diffs = []
        for label, f in heads.items():
            try:
                a = f(o)
            except (KeyError, TypeError, ValueError, ZeroDivisionError):
                continue
            try:
                b = f(r)
            except (KeyError, TypeError, ValueError, ZeroDivisionError):
                b = "not measured in this run"
            if a != b:
                diffs.append(f"{label} {a} -> {b}")
        if diffs:
            lines.append(f"- {r[key]}: " + "; ".join(diffs))
    if not lines:
        return []
    return ["", f"Against the run this one replaces (results.json of {commit}; a conclusion there that "
            "the numbers below no longer carry is withdrawn):", ""] + lines


def chaos_K(mech, periods, transient, period, rtol, start=None):
    """(largest 0-1 test K over the four eccentricity components of A and B sampled once per
    period, their spread per joint, and the run's kind by analysis.classify_state: period within
    the run's integration error bound, 'below resolution' under CLEARANCE_FRACTION x the
    clearance, else the 0-1 test; K alone never says chaos)."""
    from pinclear.analysis import poincare
    from pinclear.analysis.classify import CLEARANCE_FRACTION, chaos_01, classify_state
    from pinclear.dynamics.simulate import simulate

    T = (periods + transient) * period
    kw = {} if start is None else {"q0": start[0], "v0": start[1]}
    tr = simulate(mech, T, rtol=rtol, dt_out=period, **kw)
    if tr.status != "success":
        return float("nan"), {}, "failed"
    keep = tr.t >= transient * period - 1e-9
    K, spread = 0.0, {}
    for j in ("A", "B"):
        e = tr.outputs[f"{j}.eccentricity"][keep]
        for k in (0, 1):
            K = max(K, float(chaos_01(e[:, k])))
        spread[j] = float(np.max(np.std(e[:, :2], axis=0)))
    secs = [poincare(tr, period, f"{j}.eccentricity[{k}]", skip_transient=transient, mech=mech)
            for j in ("A", "B") for k in (0, 1)]
    c = min(el.c for el in mech.clearances if el.name in ("A", "B"))
    kind = classify_state(secs, sim_rtol=rtol, steps_per_period=max(tr.stats.get("steps", 1), 1) / (periods + transient),
                          resolution=CLEARANCE_FRACTION * c).kind
    return K, spread, kind


def paper002(out, quick=False, smoke=False):
    from dataclasses import replace

    from pinclear.analysis.wear_life import WearSettings, _tables, block_length, converged, plot, worn_joint
    from pinclear.io.sidecar import load

    from pinclear.dynamics.simulate import simulate

    s = _settings(quick, smoke)
    out = safeio.make_dirs(Path(out))
    before = previous_rows(out)
    rows, cpu0 = [], time.process_time()
    # every run starts from the assembled ideal linkage at rest on its law (the journals centred):
    # the sidecar's pose is assembled for the ideal joints only and can press a small clearance's
    # journal into its bearing (paper 002's reproduction starts the same way)
    ideal = simulate(load("nine_bar"), 1e-3, dt_out=1e-3)
    start = (ideal.q[0].copy(), ideal.v[0].copy())
    for c_mm in s["clearances [mm]"]:
        ov = {f"{j}.{k}": v for j in ("A", "B") for k, v in (("clearance", c_mm * 1e-3), ("mu", s["mu"]),
                                                              ("wear", WEAR))}
        mech = load("nine_bar", clearances=["A", "B"], overrides=ov)
        ws = WearSettings(cycles=s["cycles"], period=s["period [s]"], scheme=s["scheme"],
                          step=s["first step [fraction of c]"], max_updates=s["max updates"], rtol=s["rtol"],
                          dt_out=s["dt_out [s]"])
        folder = safeio.make_dirs(out / f"c{c_mm:g}mm")
        c1 = time.process_time()
        # blocks long enough that their mean wear rate is a converged average (on the new bearing)
        n, n_ok, n_table = block_length(mech, ["A", "B"], ws, tol=s["block tol"], max_periods=s["max block periods"],
                                        start=start)
        ws = replace(ws, block_periods=n)
        res = converged(mech, ["A", "B"], ws, max_rounds=s["max rounds"], out=folder, start=start)
        plot(res, folder)
        _tables(folder, {n: worn_joint(res["mech"], n)[1].wear for n in res["depth"]}, res["depth"], res["history"])
        c2 = time.process_time()
        h = res["history"]
        K_new, sp_new, kind_new = chaos_K(mech, s["chaos periods"], s["transient periods"], s["period [s]"], s["rtol"],
                                          start)
        K_worn, sp_worn, kind_worn = chaos_K(res["mech"], s["chaos periods"], s["transient periods"], s["period [s]"],
                                             s["rtol"], start)
        rows.append({"clearance_mm": c_mm, "converged": res["converged"], "rounds": res["rounds"],
                     "step": res["settings"].step, "updates": len(h["factor"]), "block_periods": n,
                     "block_converged": n_ok, "block_table": n_table,
                     "update_factor": [min(h["factor"]), max(h["factor"])],
                     "A_growth_um": 1e6 * float(res["depth"]["A"].max()), "B_growth_um": 1e6 * float(res["depth"]["B"].max()),
                     "A_angle_deg": float(np.degrees(res["angles"]["A"][np.argmax(res["depth"]["A"])])),
                     "B_angle_deg": float(np.degrees(res["angles"]["B"][np.argmax(res["depth"]["B"])])),
                     "max_audit_error": float(np.nanmax(h["audit_error"])),
                     "max_reshape_jump_J": float(np.max(np.abs(h["jump"]))),
                     "update_over_sim_cpu": float(sum(h["cpu_update"]) / sum(h["cpu_sim"])),
                     "K_new": K_new, "K_worn": K_worn, "kind_new": kind_new, "kind_worn": kind_worn,
                     "spread_new_um": {k: 1e6 * v for k, v in sp_new.items()},
                     "spread_worn_um": {k: 1e6 * v for k, v in sp_worn.items()},
                     "mesh": res.get("mesh"), "k_over_h": _k_over_h(h, s),
                     "cpu_wear_s": c2 - c1, "cpu_chaos_s": time.process_time() - c2})
    cpu = time.process_time() - cpu0
    safeio.write_text(out / "results.json", json.dumps({"settings": s, "rows": rows, "cpu_s": cpu, "versions": provenance()}, indent=1) + "\n")
    safeio.write_text(out / "README.md", _report(s, rows, cpu, out, before))
    return rows


def k_over_h_ends(h, names, k0, life):
    """{regime end: {k/H, cycles at nominal, name: (largest depth, worn volume) or None}} of a
    wear run's history ``h`` at the ends of K_OVER_H, for a life of ``life`` cycles at the nominal
    k/H ``k0`` (pinclear.analysis.wear_life.at_wear_ratio; None beyond the run's life). Both wear
    studies' k/H tables."""
    from pinclear.analysis.wear_life import at_wear_ratio

    out = {}
    for regime, ends in K_OVER_H.items():
        for end, kh in zip(("low", "high"), ends):
            out[f"{regime} {end}"] = {"k/H": kh, "cycles at nominal": kh / k0 * life,
                                      **{n: at_wear_ratio(h, n, life, kh / k0) for n in names}}
    return out


def _k_over_h(h, s):
    """{regime end: {k/H, cycles at nominal, A and B largest depth [um] or None}} after the study's life."""
    ends = k_over_h_ends(h, ("A", "B"), WEAR["k"] / WEAR["hardness"], s["cycles"])
    return {k: {"k/H": v["k/H"], "cycles at nominal": v["cycles at nominal"],
                **{f"{j}_um": None if v[j] is None else 1e6 * v[j][0] for j in ("A", "B")}} for k, v in ends.items()}


def _mesh_lines(rows, tol=0.05):
    lines = ["", "Mesh half of the convergence test (pinclear.analysis.wear_life.mesh_change: the converged trial rerun "
             "with the bearing's nodes doubled; changes relative to the finer mesh's largest depth, tolerance "
             f"{tol:.0%}):", "", "| clearance [mm] | joint | nodes | largest depth [um] | RMS depth [um] | change of the "
             "largest / of the RMS [%] | converged in mesh |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        m = r.get("mesh")
        if not m:
            lines.append(f"| {r['clearance_mm']:g} | A, B | not run (the step did not converge first) |  |  |  |  |")
            continue
        for j, v in m["joints"].items():
            lines.append(f"| {r['clearance_mm']:g} | {j} | {v['nodes'][0]} -> {v['nodes'][1]} | "
                         f"{1e6 * v['max_depth'][0]:.3g} -> {1e6 * v['max_depth'][1]:.3g} | {1e6 * v['l2'][0]:.3g} -> "
                         f"{1e6 * v['l2'][1]:.3g} | {100 * v['d_max']:.1f} / {100 * v['d_l2']:.1f} | "
                         f"{'yes' if v['d_max'] <= tol and v['d_l2'] <= tol else 'no'} |")
    return lines


def _k_over_h_lines(rows, s):
    k0 = WEAR["k"] / WEAR["hardness"]
    lines = ["", f"Growth over the stated k/H ranges (Archard: the wear depends on (k/H) x cycles only, so a life of "
             f"{s['cycles']:g} turns at r x k/H is this run's history at r x {s['cycles']:g} turns; nominal k/H = "
             f"{k0:.3g} 1/Pa; the lubricated range read on the dry joint's load history, an upper reading):", "",
             "| clearance [mm] | regime, end | k/H [1/Pa] | equivalent turns at nominal | A growth [um] | B growth [um] |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        for key, v in (r.get("k_over_h") or {}).items():
            cell = [("beyond this run's life" if v[f"{j}_um"] is None else f"{v[f'{j}_um']:.3g}") for j in ("A", "B")]
            lines.append(f"| {r['clearance_mm']:g} | {key} | {v['k/H']:.3g} | {v['cycles at nominal']:.3g} | "
                         f"{cell[0]} | {cell[1]} |")
    return lines


def _volumes(trial):
    v = trial.get("worn_volume")
    return f" (worn volume A {1e9 * v['A']:.3g}, B {1e9 * v['B']:.3g} mm^3)" if v else ""


def _report(s, rows, cpu, out, before=None):
    lines = ["# Study: paper 002's nine-bar with A and B worn together (pinclear study paper002)", "",
             "Generated by `pinclear study paper002" + (" --smoke" if s.get("smoke") else " --quick" if s["quick"] else "")
             + "`; the method is in "
             "docs/wear_lubrication.md. The linkage is paper 002's topology with reconstructed dimensions "
             "(docs/papers.md): the numbers are this linkage's, not the paper's.", "",
             f"Wear law: Archard, k = {WEAR['k']:g}, H = {WEAR['hardness']:g} Pa (stated, not from the paper), "
             f"{WEAR['nodes']} nodes; service life {s['cycles']:g} crank turns of {s['period [s]']:g} s; friction "
             f"{s['mu']} (sec. 4). Depth-limited update (docs/wear_lubrication.md; the wear step sized by the "
             "largest nodal increment as in Podra & Andersson 1999, Tribol. Int. 32, 71 and Mukras et al. 2009, Wear "
             "266, 822): each update's largest nodal increment is a step x the joint's clearance; the step halved from "
             f"{s['first step [fraction of c]']:g} until halving it changes each joint's final depth by <= 5 %, at "
             f"most {s['max rounds']} trials of at most {s['max updates']} updates. Each update simulates a block of "
             "turns long enough that its mean wear rate is a converged average: on the new bearing, the block "
             f"doubled from 1 turn until doubling it changes each joint's largest mean nodal rate by <= "
             f"{100 * s['block tol']:g} % (at most {s['max block periods']} turns; pinclear.analysis.wear_life.block_length).", "",
             "| clearance [mm] | step converged | block [turns] | step [x c] | updates | factor [cycles] "
             "| A growth [um] at [deg] "
             "| B growth [um] at [deg] | K (kind) new | K (kind) worn | audit error (max, per block) "
             "| max reshape jump [J] | update / sim CPU |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        f0, f1 = r["update_factor"]
        blk = f"{r.get('block_periods', 1)}" + ("" if r.get("block_converged", True) else " (not converged)")
        lines.append(f"| {r['clearance_mm']:g} | {'yes' if r['converged'] else 'no'} | {blk} | {r['step']:.3g} | "
                     f"{r['updates']} | {f0:.3g}-{f1:.3g} | "
                     f"{r['A_growth_um']:.3g} at {r['A_angle_deg']:.0f} | {r['B_growth_um']:.3g} at "
                     f"{r['B_angle_deg']:.0f} | {r['K_new']:.2f} ({r['kind_new']}) | {r['K_worn']:.2f} ({r['kind_worn']}) | {r['max_audit_error']:.2g} | "
                     f"{r['max_reshape_jump_J']:.2g} | {r['update_over_sim_cpu']:.3f} |")
    lines += ["", "Trials of the convergence test (step, updates made, final max depth A / B):", ""]
    for r in rows:
        trials = "; ".join(f"step {t['step']:.3g}: {t['updates']} updates, A {1e6 * t['max_depth']['A']:.3g} um, "
                           f"B {1e6 * t['max_depth']['B']:.3g} um" + _volumes(t)
                           + ("" if t["complete"] else " (stopped)")
                           for t in r["rounds"])
        trial_cpu = sum(t.get("cpu_s", 0.0) for t in r["rounds"])
        lines.append(f"- c = {r['clearance_mm']:g} mm (the trials' blocks and updates {trial_cpu:.0f} CPU s): {trials}")
    lines += ["", "Block length (pinclear.analysis.wear_life.block_length, new bearing: the largest mean nodal increment per "
              "turn, A / B, over the first n turns):", ""]
    for r in rows:
        table = ", ".join(f"{n}: {1e12 * m['A']:.3g} / {1e12 * m['B']:.3g} pm" for n, m in r.get("block_table", []))
        lines.append(f"- c = {r['clearance_mm']:g} mm: {table}; block {r.get('block_periods', 1)} turns"
                     + ("" if r.get("block_converged", True) else " (the largest allowed, not converged: the "
                        "growth still depends on the block length)"))
    lines += _mesh_lines(rows) + _k_over_h_lines(rows, s)
    lines += ["", "Findings (from the table above, this run):", ""]
    for r in rows:
        faster = "A" if r["A_growth_um"] > r["B_growth_um"] else "B"
        ratio = max(r["A_growth_um"], r["B_growth_um"]) / max(min(r["A_growth_um"], r["B_growth_um"]), 1e-30)
        moved = (f"the same kind of motion ({r['kind_new']})" if r["kind_new"] == r["kind_worn"] else
                 f"the motion changes from {r['kind_new']} to {r['kind_worn']} (analysis.classify_state; "
                 "'irregular' is the 0-1 test without a Lyapunov check, not chaos)")
        m = r.get("mesh")
        if r["converged"]:
            conv = ""
        elif m is not None and not m["ok"]:
            conv = (" The depth step converged but the mesh did not (table above): the growth is the coarser "
                    "mesh's and moves with the node count.")
        else:
            conv = (" The depth step did not converge within the trials: the growth is the finest trial's, the "
                    "trials above show the spread.")
        lines.append(f"- c = {r['clearance_mm']:g} mm: {faster} wears {ratio:.2g} x faster; K {r['K_new']:.2f} new vs "
                     f"{r['K_worn']:.2f} worn: {moved}.{conv}")
    lines += moved_lines(before, rows, "clearance_mm", {
        "A growth [um]": lambda r: f"{r['A_growth_um']:.3g}", "B growth [um]": lambda r: f"{r['B_growth_um']:.3g}",
        "kind new": lambda r: f"{r['kind_new']} (K {r['K_new']:.2f})", "kind worn": lambda r: f"{r['kind_worn']} (K {r['K_worn']:.2f})",
        "converged": lambda r: "yes" if r["converged"] else "no"})
    lines += ["", f"CPU of this run of the study: {cpu:.0f} s (one core; a run resumed from the trials' checkpoints "
              "counts only what it computed); per clearance: "
              + ", ".join(f"{r['clearance_mm']:g} mm wear {r['cpu_wear_s']:.0f} s + 0-1 test {r['cpu_chaos_s']:.0f} s"
                          for r in rows) + ".",
              "Figures: c*mm/depth_vs_angle.png (worn profiles), c*mm/growth.png (clearance growth vs cycles); "
              "histories and profiles: c*mm/history.csv, c*mm/profile.csv (the finest trial's).", "",
              "The worn bearings in the meshcat view (depth magnified by the printed, labelled factor):", ""]
    return "\n".join(lines + _view_lines(rows, out) + [""])


def _view_lines(rows, out):
    """The meshcat command of each clearance's worn bearings."""
    wear = "{k: %g, hardness: %g, nodes: %d}" % (WEAR["k"], WEAR["hardness"], WEAR["nodes"])
    lines = []
    for r in rows:
        c = r["clearance_mm"] * 1e-3
        lines.append(f"    pinclear view nine_bar --clearance A --clearance B --set A.clearance={c:g} "
                     f"--set B.clearance={c:g} --set 'A.wear={wear}' --set 'B.wear={wear}' "
                     f"--wear {Path(out).as_posix()}/c{r['clearance_mm']:g}mm "
                     f"--html out/worn_c{r['clearance_mm']:g}mm.html")
    return lines
