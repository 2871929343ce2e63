"""MuJoCo next to pinclear on the same URDF + sidecar (issue 12, "an independent engine on the
same chart").

    python3 benchmarks/peers/run_peers.py                 # the three scenes, ~10 CPU min
    python3 benchmarks/peers/run_peers.py --scenes four_bar --out /tmp/peers

For each scene, in this one process:
1. the translation is checked physically before anything is timed: the initial state maps to
   MuJoCo and back unchanged and satisfies the closures there; a short run converges to
   pinclear's tight reference (projection + DOP853, rtol 1e-12) as the step shrinks, with the
   observed order; the energy of conservative scenes drifts less as the step shrinks;
2. pinclear.studies.bench.atlas.run_atlas times pinclear's cells (lagrange / projection / proximal x RK45 /
   DOP853, rtol 1e-4 .. 1e-10) and the MuJoCo peer's time-step ladder against the atlas's
   reference and draws both on work_precision_<scene>.png;
3. peers.json / peers.md: per scene, the cheapest configuration of each engine reaching an error
   of 1e-6 (and 1e-8) and the CPU ratio, or the best error an engine reached.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
import warnings
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import pinclear  # noqa: E402
from pinclear.studies.bench import atlas, rhs as bench
from pinclear.model import kinematics  # noqa: E402
from pinclear.core.models import model_path  # noqa: E402

from mujoco_peer import MujocoScene, closure_residual, energy, make_peer  # noqa: E402

SCENES = ["four_bar", "a02_nfourbar_2", "four_ups_upu"]
#: verification window: short, and for A02 before its first flat (singular) configuration at
#: t = 0.285 s, where the projection reference cannot pass
VERIFY_T = {"four_bar": 0.5, "a02_nfourbar_2": 0.25, "four_ups_upu": 0.5}
VERIFY_H = [2e-3, 1e-3, 5e-4, 2.5e-4, 1.25e-4, 6.25e-5]
PIN_METHODS = ["lagrange", "projection", "proximal"]
PIN_INTEGRATORS = ["RK45", "DOP853"]
PIN_TOLS = [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10]
TARGETS = [1e-6, 1e-8]


def verify(name, progress=print):
    """Physical checks of the translation (no timing)."""
    mech = pinclear.load(model_path(name))
    T = VERIFY_T[name]
    sc = MujocoScene(mech, T / round(T / 1e-3))
    q_back, v_back = sc.state()
    closure_eq = [i for i in range(sc.m.neq)
                  if not mujoco.mj_id2name(sc.m, mujoco.mjtObj.mjOBJ_EQUALITY, i).startswith("drive_")]
    mj_rows = np.isin(sc.d.efc_id, closure_eq) & (sc.d.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY)
    out = {"t_end": T,
           "roundtrip_q": float(np.max(np.abs(pin.difference(mech.model, sc.q0, q_back)))),
           "roundtrip_v": float(np.max(np.abs(v_back - sc.v0))),
           "initial_closure_residual_pinclear": closure_residual(mech, sc.q0),
           "initial_closure_residual_mujoco": float(np.max(np.abs(sc.d.efc_pos[mj_rows]))) if mj_rows.any() else 0.0,
           "mobility": kinematics.mobility(mech, sc.q0)["mobility"], "drives": len(mech.drives)}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = pinclear.simulate(mech, T, method="projection", integrator="DOP853", rtol=1e-12, atol=1e-14,
                                t_eval=[0.0, T])
    if ref.status != "success":
        raise RuntimeError(f"{name}: reference failed: {ref.message}")
    out["reference"] = "projection + DOP853, rtol 1e-12, atol 1e-14"
    out["reference_start_gap"] = float(np.max(np.abs(pin.difference(mech.model, ref.q[0], sc.q0))))
    conv = []
    for h0 in VERIFY_H:
        h = T / round(T / h0)
        s = MujocoScene(mech, h)
        E0 = energy(mech.model, s.q0, s.v0)
        q, v, n, cpu = s.run(T)
        row = {"h": h, "error": float(np.max(np.abs(pin.difference(mech.model, ref.q[-1], q)))),
               "v_error": float(np.max(np.abs(v - ref.v[-1]))), "residual": closure_residual(mech, q)}
        if mech.conservative:
            row["energy_change"] = (energy(mech.model, q, v) - E0) / abs(E0) if E0 else energy(mech.model, q, v) - E0
        if mech.drives:
            f = mech.driverows.values(T, mech.driverows.create_data())
            row["drive_error"] = float(np.max(np.abs(q[[d.idx_q for d in mech.drives]] - f[0])))
        conv.append(row)
    for a, b in zip(conv, conv[1:]):
        b["order"] = math.log(a["error"] / b["error"]) / math.log(a["h"] / b["h"])
    out["convergence"] = conv
    progress(f"{name}: round trip {out['roundtrip_q']:.1e}, initial closure {out['initial_closure_residual_mujoco']:.1e}; "
             + ", ".join(f"h {r['h']:.2g}: {r['error']:.2e}" for r in conv))
    return out


def best(rows, target):
    ok = [r for r in rows if r["status"] == "success" and r["error"] is not None and np.isfinite(r["error"])
          and r["error"] <= target]
    return min(ok, key=lambda r: r["cpu_s"]) if ok else None


def summarize(res, scenes):
    summary = {}
    for name in scenes:
        rows = [r for r in res["rows"] if r["scene"] == name]
        pin_rows = [r for r in rows if not r["method"].startswith("mujoco")]
        mj_rows = [r for r in rows if r["method"].startswith("mujoco")]
        s = {"t_end": res["scenes"][name]["t_end"], "reference": res["scenes"][name]["reference"]}
        for tgt in TARGETS:
            bp, bm = best(pin_rows, tgt), best(mj_rows, tgt)
            e = {"pinclear": _pick(bp), "mujoco": _pick(bm)}
            if bp and bm:
                e["cpu_ratio_mujoco_over_pinclear"] = bm["cpu_s"] / bp["cpu_s"]
            summary.setdefault(name, s)[f"{tgt:g}"] = e
        fin = [r for r in mj_rows if r["status"] == "success" and np.isfinite(r["error"])]
        s["mujoco_best_error"] = min((r["error"] for r in fin), default=None)
        finp = [r for r in pin_rows if r["status"] == "success" and np.isfinite(r["error"])]
        s["pinclear_best_error"] = min((r["error"] for r in finp), default=None)
        s["mujoco_points"] = [{k: r[k] for k in ("tol", "error", "cpu_s", "steps", "max_residual", "energy_drift")}
                              for r in mj_rows]
        summary[name] = s
    return summary


def _pick(r):
    if r is None:
        return None
    return {k: r[k] for k in ("method", "integrator", "tol", "error", "cpu_s", "rhs_evals")}


def solref_scan(scenes, res, factors=(1.0, 2.0, 4.0), steps=(1e-3, 5e-4)):
    """Sensitivity of MuJoCo's error to its constraint time constant tc = factor x h (factor < 2
    needs MuJoCo's refsafe clamp disabled), on the atlas's window and reference."""
    out = {}
    for name in scenes:
        mech = pinclear.load(model_path(name))
        T = res["scenes"][name]["t_end"]
        q_ref = atlas.reference(mech, name, T)[0]
        out[name] = []
        for fac in factors:
            for h in steps:
                q, v, n, cpu = MujocoScene(mech, T / round(T / h), tc_factor=fac).run(T)
                out[name].append({"tc_factor": fac, "h": T / round(T / h), "error": bench.q_error(mech.model, q_ref, q)})
    return out


def charts(res, scenes, out):
    """Redraw work_precision_<scene>.png with pinclear.studies.bench.rhs._chart (as the atlas does), then tell
    the two MuJoCo peers apart: the chart draws every peer as black stars."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    for name in scenes:
        sc = res["scenes"][name]
        rows = [r for r in res["rows"] if r["scene"] == name]
        fig, ax = plt.subplots(figsize=(8, 6))
        bench._chart(rows, None, f"{name}: error at t = {sc['t_end']:g} s vs CPU time "
                     f"(ref: {sc['reference'].split(':')[0].split(',')[0]})", ax=ax)
        for line in ax.get_lines():
            if line.get_label() == "mujoco_implicitfast":
                line.set(color="0.45", linestyle="--", marker="P")
        ax.legend(fontsize=7, ncol=2)
        fig.tight_layout()
        fig.savefig(out / f"work_precision_{name}.png", dpi=110)
        plt.close(fig)


def markdown(verif, summary, res, scan):
    L = ["# MuJoCo next to pinclear on the same URDF + sidecar", "",
         f"Made by `python3 benchmarks/peers/run_peers.py` on {res['created']} (one process; CPU seconds of the "
         "same run, so ratios are comparable, absolute numbers are this machine's).", "",
         "MuJoCo: peers `mujoco` (RK4) and `mujoco_implicitfast`, time step h (the accuracy knob), equality constraints with solref = (2h, 1), "
         "solimp = (0.9999, 0.9999, 0.001, 0.5, 2); drives as joint equalities on a clock joint "
         "(benchmarks/peers/mujoco_peer.py). pinclear: lagrange / projection / proximal x RK45 / DOP853, "
         "rtol 1e-4 .. 1e-10 (atol 1e-2 rtol), 200 output samples per run, as the atlas.", "",
         "## Verification of the translation (before timing)", "",
         "| scene | q round trip | closure at t=0 (MuJoCo) | window | error vs h (order) | energy change | drive error |",
         "|---|---|---|---|---|---|---|"]
    for name, v in verif.items():
        conv = v["convergence"]
        errs = "; ".join(f"{r['h']:.3g}: {r['error']:.2e}" + (f" ({r['order']:.2f})" if "order" in r else "") for r in conv)
        en = "; ".join(f"{r['energy_change']:.1e}" for r in conv) if "energy_change" in conv[0] else "driven"
        de = "; ".join(f"{r['drive_error']:.1e}" for r in conv) if "drive_error" in conv[0] else "-"
        L.append(f"| {name} | {v['roundtrip_q']:.1e} | {v['initial_closure_residual_mujoco']:.1e} | {v['t_end']} s | "
                 f"{errs} | {en} | {de} |")
    for name, v in verif.items():
        if v["drives"] and v["mobility"] <= v["drives"]:
            L += ["", f"{name}: {v['mobility']} degrees of freedom (closures only), all {v['drives']} driven, so q(t) is fixed by the drive laws "
                  "and the closures alone: its error measures how well each engine keeps the constraints, not the "
                  "dynamics (the drive forces would)."]
    L += ["", "## Cheapest configuration reaching a target error at t_end", "",
          "| scene | t_end | target | pinclear (method + integrator, rtol: error, CPU s) | MuJoCo (peer, h: error, CPU s) | "
          "CPU MuJoCo / pinclear |", "|---|---|---|---|---|---|"]
    for name, s in summary.items():
        for tgt in TARGETS:
            e = s[f"{tgt:g}"]
            p, m = e["pinclear"], e["mujoco"]
            ps = f"{p['method']} + {p['integrator']}, {p['tol']:g}: {p['error']:.1e}, {p['cpu_s']:.3g}" if p else \
                f"not reached (best {s['pinclear_best_error']:.1e})"
            ms = f"{m['method']}, h {m['tol']:g}: {m['error']:.1e}, {m['cpu_s']:.3g}" if m else \
                f"not reached (best {s['mujoco_best_error']:.1e})"
            ratio = f"{e['cpu_ratio_mujoco_over_pinclear']:.3g}" if "cpu_ratio_mujoco_over_pinclear" in e else "-"
            L.append(f"| {name} | {s['t_end']:g} s | {tgt:g} | {ps} | {ms} | {ratio} |")
    L += ["", "## Sensitivity to the constraint time constant tc = factor x h (error at t_end, atlas reference)", "",
          "| scene | " + " | ".join(f"factor {r['tc_factor']:g}, h {r['h']:.3g}" for r in next(iter(scan.values()))) + " |",
          "|---|" + "---|" * len(next(iter(scan.values())))]
    for name, rows in scan.items():
        L.append(f"| {name} | " + " | ".join(f"{r['error']:.2e}" for r in rows) + " |")
    L += ["", "References (the atlas's): " + "; ".join(f"{n}: {s['reference']}" for n, s in summary.items()), "",
          "Charts: work_precision_<scene>.png (both engines), heatmap_<scene>.png; every cell in atlas.json / atlas.csv."]
    return "\n".join(L) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", nargs="+", default=SCENES, choices=SCENES)
    ap.add_argument("--out", default=str(HERE))
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    verif = {name: verify(name) for name in args.scenes}
    res = atlas.run_atlas(files=[str(model_path(n)) for n in args.scenes], out=out,
                          peers=[make_peer(), make_peer("implicitfast")],
                          methods=PIN_METHODS, integrators_=PIN_INTEGRATORS, tols=PIN_TOLS,
                          progress=lambda s: print(s, flush=True))
    summary = summarize(res, args.scenes)
    charts(res, args.scenes, out)
    # the atlas also runs each sidecar's clearance variants (four_ups_upu+S2); no peer has them,
    # their rows stay in atlas.json but their figures are not this benchmark's
    for label in res["scenes"]:
        if label not in args.scenes:
            for kind in ("heatmap", "work_precision"):
                (out / f"{kind}_{atlas._fname(label)}.png").unlink(missing_ok=True)
    scan = solref_scan(args.scenes, res)
    doc = {"created": res["created"], "wall_s": time.perf_counter() - t0,
           "mujoco": mujoco.__version__, "pinocchio": pin.__version__,
           "mujoco_setting": {"integrators": ["RK4 (peer mujoco)", "implicitfast (peer mujoco_implicitfast)"], "solref": "(2 h, 1)", "solimp": "(0.9999, 0.9999, 0.001, 0.5, 2)",
                              "tols": make_peer().tols},
           "pinclear_grid": {"methods": PIN_METHODS, "integrators": PIN_INTEGRATORS, "tols": PIN_TOLS},
           "verification": verif, "summary": summary, "solref_scan": scan,
           "rows": [{k: atlas._clean(r.get(k)) for k in atlas.COLUMNS} for r in res["rows"]]}
    (out / "peers.json").write_text(json.dumps(doc, indent=1, default=str))
    (out / "peers.md").write_text(markdown(verif, summary, res, scan))
    print((out / "peers.md").read_text())


if __name__ == "__main__":
    main()
