"""Study paper000: paper 000's next step (its sec. 5: "the influence of wear factor and lubrication
effect on dynamic characteristics"), run on pinclear's lubricated spherical joint
(pinclear.contact.lubricated_spherical, docs/wear_lubrication.md sec. 4) and its worn socket
(pinclear.contact.wear_spherical, pinclear.analysis.wear_life; docs/wear_lubrication.md sec. 6). Not a reproduction
(``pinclear reproduce 000`` owns that): this study writes its own findings.

The 4UPS-UPU of paper 000 (urdf/four_ups_upu.yaml; masses and platform joint angles reconstructed,
docs/papers.md) with its clearance at S2 (c = 0.5 mm, ball radius 20 mm, mu 0.1, the sidecar's dry
law: Lankarani-Nikravesh with K as printed, modified Coulomb), once dry (the new joint) and once
filled with oil at each of VISCOSITIES (a decade), the film blended into the same dry law below the
asperity height. Per case, over the last ``window`` periods of the platform's law: the joint force
band (dry contact + film, raw and its T/20 moving average as the reproduction reads it), the share of
time in asperity contact, the film's dissipation, and the platform's deviation from its motion law.
The worn case: S2 worn over WEAR_CYCLES (Archard, WEAR_S2: k and H stated, paper 000 gives none) by
the iterative scheme with the update factor from its convergence test, then run and measured as the
others from the same start.

    python -m pinclear.studies.wear_paper000 [--quick] [--out DIR]   # writes DIR/README.md, results.json
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from pinclear import analysis
from pinclear.core import safeio
from pinclear.core.models import model_path
from pinclear.core.version import provenance
from pinclear.dynamics.simulate import simulate
from pinclear.io.sidecar import load
from pinclear.mechanisms import four_ups_upu as mod
from pinclear.studies.reproduce.paper000 import SMOOTH, T, moving_average

#: Pa s: a light spindle oil to a medium gear oil at operating temperature (ISO VG 10-100 at ~40 C)
VISCOSITIES = (0.01, 0.03, 0.1)
#: the S2 sidecar entry's friction (paper 000 sec. 4.5's ADAMS check), kept in every case
MU = 0.1
#: the worn case's wear law: the paper-002 study's stated choices (pinclear.studies.wear.WEAR: k 1e-5, mild wear
#: of unlubricated steel on steel, Archard 1953 and Rabinowicz 1995's table; H 2 GPa, a through-hardened
#: steel ball seat); paper 000 gives none. 72 x 144 socket nodes (2.5 deg cells, about the contact
#: radius), pole on frame1 z, away from the contact (S2's ball rests near frame1 -x)
WEAR_S2 = {"model": "archard", "k": 1e-5, "hardness": 2e9, "nodes": 72, "pole": "z"}
#: service life (platform periods of 2 s): 1e6 (about 23 days of continuous running); quick 1e5
WEAR_CYCLES = (1e5, 1e6)


def _settings(quick, smoke=False):
    if smoke:
        # the whole path in about a minute (CI): one period per case, a 16-period wear life in 2 then 4 updates
        return {**_settings(True), "periods": 1, "wear cycles": 16.0, "wear first updates": 2, "wear max rounds": 2,
                "smoke": True}
    return {"periods": 3 if quick else 54, "window": 1 if quick else 4, "dt_out [s]": 2e-3, "mu": MU,
            "viscosities [Pa s]": list(VISCOSITIES), "asperity": "0.02 x clearance (10 um), band 10 um (defaults)",
            "wear": WEAR_S2, "wear cycles": WEAR_CYCLES[0 if quick else 1], "wear first updates": 16,
            "wear max rounds": 4 if quick else 6, "wear tol": 0.05, "wear dt_out [s]": 1e-3, "quick": quick}


def cases():
    """(label, sidecar overrides of S2) of the study: the dry new joint first, then the oils."""
    out = [("dry (new joint)", {"S2.mu": MU})]
    out += [(f"oil {v:g} Pa s", {"S2.mu": MU, "S2.type": "lubricated_spherical", "S2.viscosity": v})
            for v in VISCOSITIES]
    return out


def run_case(overrides, s, mech=None):
    """The measures of one case (module doc) over the last ``window`` periods of ``periods``
    (mech: an already built mechanism, e.g. the worn one, instead of the sidecar with ``overrides``)."""
    mech = mech if mech is not None else load(model_path("four_ups_upu"), clearances=["S2"], overrides=overrides)
    t_end = s["periods"] * T
    t_eval = np.arange(t_end - s["window"] * T, t_end + 1e-12, s["dt_out [s]"])
    t_eval[-1] = min(t_eval[-1], t_end)
    cpu = time.process_time()
    # the squeeze film near contact is stiff (damping of order 1e13 N s/m): an oiled run takes an
    # implicit integrator (benchmarks/lubrication.md: BDF costs 0.36x the dry RK45 run, RK45 ~1000x)
    oiled = str((overrides or {}).get("S2.type", "")).startswith("lubricated")
    tr = simulate(mech, t_end, t_eval=t_eval, integrator="BDF" if oiled else "RK45")
    cpu = time.process_time() - cpu
    r = {"status": tr.status, "cpu_s": cpu}
    if tr.status != "success":
        return {**r, "message": getattr(tr, "message", "")}
    out = tr.outputs
    film = out.get("S2.film_force", 0.0)
    Fm = np.linalg.norm(out["S2.normal_force"] + out["S2.friction_force"] + film, axis=1)
    smooth = moving_average(Fm, int(round(SMOOTH / s["dt_out [s]"])))
    law = np.array([np.concatenate(mod.platform_position(t)[:2]) for t in tr.t])
    dev = {}
    for j, c in enumerate("xyz"):
        se = analysis.series(tr, f"platform.{c}", mech)
        dev[c] = (float(np.abs(se.x - law[:, j]).max()), float(np.abs(se.xdot - law[:, 3 + j]).max()),
                  float(np.mean(se.x - law[:, j])))
    b = tr.energy_balance()
    # the landing from the centred start: the integrator's located peak of the dry contact force and
    # the first asperity contact (events); the dissipation states are cumulative from t = 0
    peak = tr.stats.get("peaks", {}).get("contact_forces", {}).get("S2", {})
    touch = [e["t"] for e in tr.stats.get("events", ()) if e.get("element") == "S2"]
    r.update(peak_dry_N=float(peak.get("value", float("nan"))), peak_t=float(peak.get("t", float("nan"))),
             first_contact_s=min(touch) if touch else float("nan"),
             film_J_run=float(out["S2.film_dissipated"][-1]) if "S2.film_dissipated" in out else 0.0,
             dissipated_J_run=float(out["S2.dissipated"][-1]))
    r.update(force_min=float(Fm.min()), force_max=float(Fm.max()), force_mean=float(Fm.mean()),
             smooth_min=float(smooth.min()), smooth_max=float(smooth.max()),
             dry_share=float(np.mean(out["S2.contact"] > 0)),
             film_weight=float(np.mean(out["S2.film_weight"])) if "S2.film_weight" in out else 0.0,
             film_J=float(out["S2.film_dissipated"][-1] - out["S2.film_dissipated"][0])
             if "S2.film_dissipated" in out else 0.0,
             dissipated_J=float(out["S2.dissipated"][-1] - out["S2.dissipated"][0]),
             platform_um={c: 1e6 * v[0] for c, v in dev.items()},
             platform_mm_s={c: 1e3 * v[1] for c, v in dev.items()},
             x_offset_mm=1e3 * dev["x"][2], audit_ok=bool(b["ok"]), audit_error=float(b["error"]),
             audit_bound=float(b["bound"]))
    return r


def paper000(out, quick=False, smoke=False):
    """Run every case into ``out`` (README.md, results.json); returns the rows (smoke: the whole
    path on a few periods, numbers meaningless)."""
    out = Path(out)
    s = _settings(quick, smoke)
    t0 = time.process_time()
    rows = [{"case": label, **run_case(over, s)} for label, over in cases()]
    safeio.make_dirs(out)
    rows.append(worn_case(s, out))
    cpu = time.process_time() - t0
    safeio.write_text(out / "results.json", json.dumps({"settings": s, "rows": rows, "cpu_s": cpu, "versions": provenance()}, indent=1) + "\n")
    safeio.write_text(out / "README.md", _report(s, rows, cpu))
    return rows


def worn_case(s, out, work=None):
    """S2 worn over s["wear cycles"] (pinclear.analysis.wear_life.converged: the update factor halved until the final
    depth changes by <= 5 %), then run from the start like the other cases. Writes the worn profile,
    history and plots (socket depth map, growth) into ``out``; the checkpoints go to ``work`` (a
    temporary folder by default: never under docs/)."""
    import tempfile

    from pinclear.analysis.wear_life import WearSettings, _tables, converged, plot

    mech = load(model_path("four_ups_upu"), clearances=["S2"], overrides={"S2.mu": MU, "S2.wear": WEAR_S2})
    ws = WearSettings(cycles=s["wear cycles"], period=T, updates=s["wear first updates"], block_periods=1,
                      transient_periods=2, rtol=1e-6, dt_out=s["wear dt_out [s]"])
    c0 = time.process_time()
    with tempfile.TemporaryDirectory(prefix="pinclear_wear_") as tmp:
        res = converged(mech, "S2", ws, tol=s["wear tol"], max_rounds=s["wear max rounds"], out=Path(work or tmp))
    cpu_wear = time.process_time() - c0
    wm = mech.forces[-1].wear
    _tables(out, {"S2": wm}, res["depth"], res["history"])
    plot(res, out)
    h = res["history"]
    d = res["depth"]["S2"]
    grid = d.reshape(wm.rows, wm.cols)
    i, j = np.unravel_index(int(np.argmax(grid)), grid.shape)
    wear = {"converged": bool(res["converged"]), "rounds": res["rounds"], "update_factor": res["settings"].factor,
            "max_depth_um": 1e6 * float(d.max()), "worn_volume_mm3": 1e9 * wm.volume(d),
            "deepest_theta_deg": float(np.degrees((i + 0.5) * wm.dtheta)),
            "deepest_phi_deg": float(np.degrees(j * wm.dphi)),
            "cpu_wear_s": cpu_wear, "cpu_sim_s": float(sum(h["cpu_sim"])), "cpu_update_s": float(sum(h["cpu_update"])),
            "max_jump_J": float(np.max(np.abs(h["jump"]))), "max_block_audit_error": float(np.max(h["audit_error"])),
            "max_block_audit_bound": float(np.max(h["audit_bound"]))}
    label = f"worn {s['wear cycles']:.0e} cycles"
    r = run_case(None, s, mech=res["mech"])
    return {"case": label, **r, "cpu_s": r["cpu_s"] + cpu_wear, "wear": wear}


def _findings(rows):
    """One line per lubricated case against the dry new joint (numbers of this run)."""
    dry = rows[0]
    lines = []
    for r in rows[1:]:
        if "wear" in r:
            lines.append(_worn_finding(r, dry))
            continue
        if r["status"] != "success" or dry["status"] != "success":
            lines.append(f"- {r['case']}: run {r['status']} ({r.get('message', '')}); no comparison")
            continue
        span, span0 = r["force_max"] - r["force_min"], dry["force_max"] - dry["force_min"]
        text = (f"- {r['case']}: landing from the centred start: first asperity contact at "
                f"{r['first_contact_s']:.4f} s vs {dry['first_contact_s']:.4f} s dry, peak dry contact force "
                f"{r['peak_dry_N']:.0f} N vs {dry['peak_dry_N']:.0f} N dry; the film took {r['film_J_run']:.3g} J of "
                f"the {r['dissipated_J_run']:.3g} J dissipated over the run. In the window: averaged force band "
                f"{r['smooth_min']:.0f}-{r['smooth_max']:.0f} N vs {dry['smooth_min']:.0f}-{dry['smooth_max']:.0f} N "
                f"dry, raw span {span:.0f} N vs {span0:.0f} N, asperity contact {100 * r['dry_share']:.0f} % of the "
                f"window, mean film weight "
                f"{100 * r['film_weight']:.0f} %; platform deviation X/Y/Z "
                + "/".join(f"{r['platform_um'][c]:.0f}" for c in "xyz") + " um vs "
                + "/".join(f"{dry['platform_um'][c]:.0f}" for c in "xyz") + " um dry.")
        lines.append(text)
    resting = [r["case"] for r in rows[1:] if r["status"] == "success" and r["dry_share"] > 0.99 and "wear" not in r
               and r["film_weight"] < 0.01]
    if resting and dry["status"] == "success":
        first = next(r for r in rows[1:] if r["case"] == resting[0])
        ratio = first["platform_um"]["z"] / dry["platform_um"]["z"]
        lines += ["", f"Reading ({', '.join(resting)}): the ball rests on its asperities all through the "
                  "window. The squeeze film cannot hold S2's steady one-sided load (it only slows the approach), and "
                  "the wedge of the ball's spin relative to its socket (the limbs' slow swing) does not lift it: the "
                  "oiled joint runs as a dry joint of clearance c - asperity. Its platform deviation "
                  f"({resting[0]}) is {ratio:.3f} of the dry joint's (Z), close to (c - asperity) / c = 0.49 / 0.50 "
                  "mm. The raw spans differ from the dry joint's by the impact ringing of each history, not by the "
                  "oil (the film is faded out); the oil shows in the landing."]
    return lines


def _worn_finding(r, dry):
    """The worn case against the dry new joint: the wear run, then force band and platform deviation."""
    w = r["wear"]
    trials = ", ".join(f"{t['updates']} updates {1e6 * t['max_depth']['S2']:.3g} um" for t in w["rounds"])
    conv = (f"converged (halving the factor changed the depth by <= 5 %: {trials})" if w["converged"]
            else f"NOT converged within the trials ({trials}): not a finding")
    text = (f"- {r['case']}: the update factor {w['update_factor']:.3g} cycles per simulated cycle {conv}; "
            f"deepest {w['max_depth_um']:.3g} um at theta {w['deepest_theta_deg']:.1f} deg, phi "
            f"{w['deepest_phi_deg']:.0f} deg from the frame1 z pole (the ball's resting side, frame1 -x), worn volume "
            f"{w['worn_volume_mm3']:.3g} mm^3; blocks' audit error <= {w['max_block_audit_error']:.1g} (bound "
            f"{w['max_block_audit_bound']:.1g}), reshape jumps <= {w['max_jump_J']:.1g} J; wear updates cost "
            f"{w['cpu_update_s'] / max(w['cpu_sim_s'], 1e-9):.2f} x the periods they follow.")
    if r["status"] != "success" or dry["status"] != "success":
        return text + f" Worn run {r['status']} ({r.get('message', '')}); no comparison."
    span, span0 = r["force_max"] - r["force_min"], dry["force_max"] - dry["force_min"]
    return text + (f" Run from the start in the worn socket: averaged force band {r['smooth_min']:.0f}-"
                   f"{r['smooth_max']:.0f} N vs {dry['smooth_min']:.0f}-{dry['smooth_max']:.0f} N new, raw span "
                   f"{span:.0f} N vs {span0:.0f} N, landing peak {r['peak_dry_N']:.0f} N vs {dry['peak_dry_N']:.0f} N; "
                   "platform deviation X/Y/Z " + "/".join(f"{r['platform_um'][c]:.0f}" for c in "xyz") + " um vs "
                   + "/".join(f"{dry['platform_um'][c]:.0f}" for c in "xyz") + f" um new (X offset "
                   f"{r['x_offset_mm']:.3f} vs {dry['x_offset_mm']:.3f} mm).")


def _report(s, rows, cpu):
    lines = ["# Study: paper 000's 4UPS-UPU with S2 lubricated and worn (pinclear.studies.wear_paper000)", "",
             "Generated by `python -m pinclear.studies.wear_paper000"
             + (" --smoke" if s.get("smoke") else " --quick" if s["quick"] else "") + "`; the "
             "lubricated joint is docs/wear_lubrication.md sec. 4. The mechanism is paper 000's with reconstructed "
             "masses and platform joint angles (docs/papers.md): the numbers are this model's, not the paper's. "
             "Paper 000 gives no oil: the viscosities span a decade of common oils (stated). The worn socket is "
             "docs/wear_lubrication.md sec. 6; paper 000 gives no wear data: k = "
             f"{s['wear']['k']:g}, H = {s['wear']['hardness']:g} Pa (stated, as the paper-002 study), "
             f"{s['wear']['nodes']} x {2 * s['wear']['nodes']} socket nodes, service life {s['wear cycles']:.0e} "
             f"periods, the update factor chosen by the convergence test (first {s['wear first updates']} updates, "
             f"doubled up to {s['wear max rounds']} trials, tol {s['wear tol']:.0%}); worn socket: depth_map_S2.png, "
             "growth.png, profile.csv, history.csv.", "",
             f"S2: c = 0.5 mm, ball radius 20 mm, friction mu = {s['mu']} (modified Coulomb), Lankarani-Nikravesh "
             f"with K as printed (the sidecar's dry law, also below the asperity height of the oiled joint); asperity "
             f"{s['asperity']}. Each case runs {s['periods']} periods of {T:g} s from the sidecar's start and is read "
             f"over the last {s['window']}; force = |dry contact + film| at S2, averaged band over {SMOOTH:.2g} s "
             "windows (as docs/reproduce/000 reads it); platform deviation = max |position - law| over the window.",
             "", "| case | status | force raw min-max [N] | averaged band [N] | mean [N] | asperity contact [%] | "
             "film weight [%] | film / all dissipated in the window [J] | platform dev. X/Y/Z [um] | X offset [mm] | "
             "landing: first asperity contact [s], peak dry force [N] | film / all dissipated, whole run [J] | "
             "audit error (bound) | CPU [s] |", "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if r["status"] != "success":
            lines.append(f"| {r['case']} | {r['status']} |  |  |  |  |  |  |  |  |  |  |  | {r['cpu_s']:.0f} |")
            continue
        lines.append(
            f"| {r['case']} | ok | {r['force_min']:.0f}-{r['force_max']:.0f} | {r['smooth_min']:.0f}-"
            f"{r['smooth_max']:.0f} | {r['force_mean']:.0f} | {100 * r['dry_share']:.0f} | "
            f"{100 * r['film_weight']:.0f} | {r['film_J']:.3g} / {r['dissipated_J']:.3g} | "
            + "/".join(f"{r['platform_um'][c]:.0f}" for c in "xyz")
            + f" | {r['x_offset_mm']:.3f} | {r['first_contact_s']:.4f}, {r['peak_dry_N']:.0f} | "
            f"{r['film_J_run']:.3g} / {r['dissipated_J_run']:.3g} | {r['audit_error']:.1g} ({r['audit_bound']:.1g}) | "
            f"{r['cpu_s']:.0f} |")
    lines += ["", "Findings (from the table above, this run; quick mode: a short transient, read as a first look):",
              ""] + _findings(rows)
    lines += ["", f"CPU of the whole study: {cpu:.0f} s (one core; the lubricated joint evaluates in Python, the "
              "dry one compiled, the worn one compiled; the worn case's CPU includes its wear run). Not run here: "
              "the bifurcation diagrams in mu and clearance with oil or wear.", ""]
    return "\n".join(lines)


def build_parser():
    p = argparse.ArgumentParser(prog="python -m pinclear.studies.wear_paper000",
                                description="paper 000's 4UPS-UPU with S2 dry, lubricated at three viscosities, "
                                "and worn over a service life")
    p.add_argument("--out", default=None, help="output folder (default docs/study/paper000)")
    p.add_argument("--quick", action="store_true", help="3 periods, the last one read; wear over 1e5 periods "
                   "(minutes)")
    return p


def cli_main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    rows = paper000(args.out or Path("docs") / "study" / "paper000", quick=args.quick)
    print(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(cli_main())
