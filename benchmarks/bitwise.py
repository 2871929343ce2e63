"""Bit-for-bit check of a refactoring: run one fixed matrix of simulations and paper studies on
whichever pinclear is imported, store every result, and compare two such folders byte for byte
(benchmarks/bitwise.md).

    PYTHONPATH=/tmp/base python3 benchmarks/bitwise.py run /tmp/work/bit_base      # the tree before
    python3 benchmarks/bitwise.py run /tmp/work/bit_main                           # the tree after
    python3 benchmarks/bitwise.py compare /tmp/work/bit_base /tmp/work/bit_main    # exit 1 on a difference

``run OUTDIR [--quick]``: every bundled scene (the sidecars of the repository's urdf/ folder, read
with PyYAML; the scene loaded by its bundled name), ideal and with each declared clearance; every
formulation x every integrator (invalid pairs recorded as their error) on one scene of each
clearance type; the lubricated (short and long bearing, spherical film) and worn (Archard key,
reshaped bearing / socket) variants, the prismatic models, the friction and normal laws, scene
options, starts, the Python reference paths, checkpoint + resume, Trajectory save/load, input
errors; then the paper studies and a few other commands through ``pinclear.cli.main`` in a
subprocess (``--quick`` skips the two slow studies, reproduce 000 and 002). One .npz (every array)
and one .json (status, failure, summary(), energy_balance(), stats, meta) per run; CPU and wall
times go to OUTDIR/timing.json, which ``compare`` does not read.

The script only uses interfaces a module move keeps: ``pinclear.load``, ``pinclear.simulate``,
``pinclear.Trajectory`` (load of a saved run), the objects they return (Trajectory attributes and
methods; the Mechanism's ``replace`` and a worn joint's ``with_depth`` to reshape a bearing, as the
tests do; a Checkpoint handed to the callback), and ``pinclear.cli.main``. No ``pinclear.<module>``
import, no module or class path recorded (an exception is recorded by its class name and message).

``compare DIR_A DIR_B``: every .npz array (dtype, shape and bytes; NaN equal to NaN at the same
place), every .json field recursively (also the JSON metadata stored inside .npz files) and every
.csv cell, except the fields listed in IGNORED below (each with its reason); paths are compared
after replacing each folder's own roots (OUTDIR, the pinclear tree, this repository) by
placeholders. Prints the counts and every difference; exit 1 on any difference or missing file.
"""
from __future__ import annotations

import argparse
import csv
import enum
import io
import json
import math
import re
import resource
import subprocess
import sys
import time
import traceback
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parent                       # the repository holding this script (its urdf/ lists the scenes)
FORMAT = "pinclear-bitwise/1"

# ============================================================================ the matrix
METHODS = ("lagrange", "projection", "pinocchio", "proximal", "manifold")
INTEGRATORS = ("RK45", "DOP853", "ROS34PW2", "Radau", "BDF", "LSODA", "RK4")

#: simulated seconds of a scene's ideal run (lagrange + RK45): a hundred to a few hundred steps
T_IDEAL = {"squeezer": 0.01, "slider_crank_clearance": 0.05, "four_ups_upr": 0.3, "cassie": 0.02,
           "cassie_reduced": 0.05, "cassie_simple": 0.05, "cassie_v2": 0.05, "cassie_wo_gearbox_spring": 0.05}
T_IDEAL_DEFAULT = 1.0
#: simulated seconds of a clearance run (lagrange + RK45, rtol 1e-8, ideal start): a few hundred steps
T_CLEARANCE = {"clr_hinge+R": 0.02, "clr_pendulum+S": 0.03, "clr_planar_pendulum+A": 0.03, "clr_slider+P": 0.03,
               "four_ups_upu+S2": 0.1, "nine_bar+A": 0.03, "nine_bar+B": 0.03, "rrr3+P2": 0.05,
               "slider_crank_clearance+P": 0.003, "three_upru_up+P_UP": 0.012, "clr_ball+S": 0.01}
T_CLEARANCE_DEFAULT = 0.02
#: a start for the scenes whose ideal start does not move the clearance (no gravity, no drive):
#: the free ball off centre with a velocity, not assembled (as tests/contact/test_wear_spherical.py starts it)
BALL_START = {"q0": [2e-5, 0.0, 0.0, 0.0, 0.0, 0.0], "v0": [0.05, 0.03, -0.1, 30.0, 5.0, 0.0], "assemble": False}

#: every formulation x every integrator on one scene of each clearance type and one rigid scene
#: (scene, clearance or None, t_end, RK4's h)
#: (the windows hold the first impacts: S2 at 12.6 ms, P2 at 15.3 and 19.6 ms, R from 4.5 ms, P_UP from 7.3 ms)
CROSS = [("four_ups_upu", None, 0.1, 1e-3),
         ("four_ups_upu", "S2", 0.025, 1e-4),         # spherical (pinocchio can hold the other closures)
         ("rrr3", "P2", 0.022, 2e-5),                 # planar_revolute (pinocchio refuses planar_point)
         ("clr_hinge", "R", 0.01, 5e-6),              # spatial revolute
         ("three_upru_up", "P_UP", 0.012, 1e-5)]      # prismatic

LUB_REV = {"type": "lubricated_revolute", "viscosity": 0.01}
LUB_SPH = {"type": "lubricated_spherical", "viscosity": 0.01}
WEAR_PLANAR = {"k": 1e-5, "hardness": 2e9, "nodes": 72}
WEAR_SPH = {"k": 1e-5, "hardness": 2e9, "nodes": 12, "pole": "z"}


def _ov(clr, d):
    """{"NAME.key": value} overrides of clearance ``clr``."""
    return {f"{clr}.{k}": v for k, v in d.items()}


def _case(cid, scene, t_end, *, group, clearances=(), overrides=None, options=None, sim=None, worn=None,
          special=None, load_by="name", variant="dry", state_from=None):
    return {"id": cid, "group": group, "scene": scene, "clearances": list(clearances), "overrides": overrides or {},
            "options": options or {}, "t_end": t_end, "sim": dict(sim or {}), "worn": worn, "special": special,
            "load_by": load_by, "variant": variant, "state_from": state_from}


def _integrator_kw(integ, h):
    return {"integrator": integ, "h": h} if integ == "RK4" else {"integrator": integ}


def bundled_scenes():
    """[(scene name, [declared clearance names])] from the sidecars of the repository's urdf/ folder."""
    import yaml

    out = []
    for f in sorted((REPO / "urdf").glob("*.yaml")):
        sc = yaml.safe_load(f.read_text(encoding="utf-8")) or {}
        names = [c["name"] for c in (sc.get("clearances") or []) if isinstance(c, dict) and "name" in c]
        out.append((f.stem, names))
    return out


def build_cases():
    """The matrix, in the order it runs (a later case may start from an earlier one's state)."""
    cases = []
    add = cases.append
    scenes = bundled_scenes()
    # 1. every bundled scene by name, ideal and with each declared clearance (lagrange + RK45)
    for scene, clrs in scenes:
        add(_case(f"scene/{scene}/ideal", scene, T_IDEAL.get(scene, T_IDEAL_DEFAULT), group="scene", variant="ideal"))
        for c in clrs:
            kw = dict(sim=BALL_START) if scene == "clr_ball" else {}
            add(_case(f"scene/{scene}/{c}", scene, T_CLEARANCE.get(f"{scene}+{c}", T_CLEARANCE_DEFAULT),
                      group="scene", clearances=[c], **kw))
    # names the README and docs use, loaded by path and as a bare URDF (the minimal sidecar)
    add(_case("scene/path/rrr3.yaml+P2", "urdf/rrr3.yaml", 0.02, group="scene", clearances=["P2"], load_by="path"))
    add(_case("scene/path/four_bar.urdf", "four_bar.urdf", 0.2, group="scene", variant="ideal"))
    add(_case("scene/nine_bar/A+B", "nine_bar", 0.03, group="scene", clearances=["A", "B"]))

    # 2. every formulation x every integrator (an invalid pair is recorded as its error)
    for scene, clr, t_end, h in CROSS:
        tag = f"{scene}+{clr}" if clr else f"{scene}/ideal"
        for m in METHODS:
            for i in INTEGRATORS:
                add(_case(f"cross/{tag}/{m}/{i}", scene, t_end, group="cross", clearances=[clr] if clr else [],
                          sim={"method": m, **_integrator_kw(i, h)}, variant="dry" if clr else "ideal"))

    # 3. lubricated variants: short and long bearing, the film keys, every method and integrator once
    for theory in ("short", "long"):
        add(_case(f"lub/nine_bar+A/{theory}", "nine_bar", 0.03, group="lubricated", clearances=["A"],
                  overrides=_ov("A", {**LUB_REV, "theory": theory}), variant=f"lubricated_{theory}"))
    add(_case("lub/rrr3+P2/short", "rrr3", 0.02, group="lubricated", clearances=["P2"],
              overrides=_ov("P2", LUB_REV), variant="lubricated_short"))
    add(_case("lub/rrr3+P2/asperity_band", "rrr3", 0.02, group="lubricated", clearances=["P2"],
              overrides=_ov("P2", {**LUB_REV, "theory": "long", "asperity": 5e-6, "band": 2e-6}),
              variant="lubricated_long"))
    add(_case("lub/clr_hinge+R/short", "clr_hinge", 0.01, group="lubricated", clearances=["R"],
              overrides=_ov("R", LUB_REV), variant="lubricated_short"))
    add(_case("lub/slider_crank+P/long", "slider_crank_clearance", 0.002, group="lubricated", clearances=["P"],
              overrides=_ov("P", {**LUB_REV, "theory": "long"}), variant="lubricated_long"))
    for m in METHODS:
        for i in (("RK45",) if m != "lagrange" else INTEGRATORS):
            add(_case(f"lub/rrr3+P2/{m}/{i}", "rrr3", 0.022, group="lubricated", clearances=["P2"],
                      overrides=_ov("P2", LUB_REV), sim={"method": m, **_integrator_kw(i, 2e-5)},
                      variant="lubricated_short"))
    add(_case("lub/four_ups_upu+S2", "four_ups_upu", 0.03, group="lubricated", clearances=["S2"],
              overrides=_ov("S2", {**LUB_SPH, "mu": 0.1}), variant="lubricated_spherical"))
    add(_case("lub/four_ups_upu+S2/pinocchio/Radau", "four_ups_upu", 0.025, group="lubricated", clearances=["S2"],
              overrides=_ov("S2", LUB_SPH), sim={"method": "pinocchio", "integrator": "Radau"},
              variant="lubricated_spherical"))
    add(_case("lub/clr_pendulum+S", "clr_pendulum", 0.02, group="lubricated", clearances=["S"],
              overrides=_ov("S", {**LUB_SPH, "asperity": 2e-6}), variant="lubricated_spherical"))
    add(_case("lub/clr_ball+S/ROS34PW2", "clr_ball", 0.005, group="lubricated", clearances=["S"],
              overrides=_ov("S", LUB_SPH), sim={**BALL_START, "integrator": "ROS34PW2"},
              variant="lubricated_spherical"))

    # 4. worn variants: the wear key on a new bearing, and the bearing / socket reshaped (with_depth)
    for scene, clr, t_end, extra in (("nine_bar", "A", 0.03, {}), ("slider_crank_clearance", "P", 0.003, {}),
                                     ("clr_planar_pendulum", "A", 0.03, {"distribution": "uniform"}),
                                     ("rrr3", "P2", 0.02, {"nodes": 360})):
        ov = _ov(clr, {"wear": {**WEAR_PLANAR, **extra}})
        add(_case(f"wear/{scene}+{clr}/new", scene, t_end, group="worn", clearances=[clr], overrides=ov,
                  variant="wear_key"))
        add(_case(f"wear/{scene}+{clr}/worn", scene, t_end, group="worn", clearances=[clr], overrides=ov,
                  worn={"clearance": clr, "depth": 0.3}, variant="worn"))
    for scene, clr, t_end, extra, kw in (("four_ups_upu", "S2", 0.05, {}, {}),
                                         ("clr_pendulum", "S", 0.03, {"pole": "x", "distribution": "uniform"}, {}),
                                         ("clr_ball", "S", 0.01, {"nodes": 16, "pole": "y"}, BALL_START)):
        ov = _ov(clr, {"wear": {**WEAR_SPH, **extra}})
        add(_case(f"wear/{scene}+{clr}/new", scene, t_end, group="worn", clearances=[clr], overrides=ov,
                  sim=kw, variant="wear_key"))
        add(_case(f"wear/{scene}+{clr}/worn", scene, t_end, group="worn", clearances=[clr], overrides=ov,
                  sim=kw, worn={"clearance": clr, "depth": 0.3}, variant="worn"))
    for m in METHODS:
        for i in (("RK45",) if m != "lagrange" else INTEGRATORS):
            add(_case(f"wear/rrr3+P2/worn/{m}/{i}", "rrr3", 0.022, group="worn", clearances=["P2"],
                      overrides=_ov("P2", {"wear": WEAR_PLANAR}), worn={"clearance": "P2", "depth": 0.3},
                      sim={"method": m, **_integrator_kw(i, 2e-5)}, variant="worn"))
    add(_case("wear/four_ups_upu+S2/worn/pinocchio/DOP853", "four_ups_upu", 0.025, group="worn", clearances=["S2"],
              overrides=_ov("S2", {"wear": WEAR_SPH}), worn={"clearance": "S2", "depth": 0.3},
              sim={"method": "pinocchio", "integrator": "DOP853"}, variant="worn"))

    # 5. contact models: prismatic models, friction laws, normal laws, stiffness, materials
    for scene, clr, t_end in (("three_upru_up", "P_UP", 0.012), ("clr_slider", "P", 0.03)):
        for model in ("energy", "paper003"):
            add(_case(f"law/{scene}+{clr}/model_{model}", scene, t_end, group="laws", clearances=[clr],
                      overrides={f"{clr}.model": model}, variant=f"prismatic_{model}"))
    frictions = {"none": "none", "coulomb": {"type": "coulomb", "mu": 0.1},
                 "modified_coulomb": {"type": "modified_coulomb", "mu": 0.1, "v0": 1e-4, "v1": 1e-3},
                 "stick_slip": {"type": "stick_slip", "mu_s": 0.2, "mu_d": 0.1},
                 "lugre": {"type": "lugre", "mu_c": 0.1, "mu_s": 0.15}}
    for name, law in frictions.items():
        add(_case(f"law/rrr3+P2/friction_{name}", "rrr3", 0.02, group="laws", clearances=["P2"],
                  overrides={"P2.friction_law": law}, variant=f"friction_{name}"))
    add(_case("law/clr_pendulum+S/friction_lugre", "clr_pendulum", 0.02, group="laws", clearances=["S"],
              overrides={"S.friction_law": frictions["lugre"]}, variant="friction_lugre"))
    for law in ("hertz", "lankarani_nikravesh", "flores", "hunt_crossley", "gonthier"):
        add(_case(f"law/clr_planar_pendulum+A/normal_{law}", "clr_planar_pendulum", 0.02, group="laws",
                  clearances=["A"], overrides={"A.normal_law": law}, variant=f"normal_{law}"))
    add(_case("law/clr_planar_pendulum+A/normal_power", "clr_planar_pendulum", 0.02, group="laws", clearances=["A"],
              overrides={"A.normal_law": {"type": "hunt_crossley", "K": 1e9, "n": 1.3}}, variant="normal_power"))
    for stiff in ("printed", "conformal", 5e9):
        add(_case(f"law/nine_bar+A/stiffness_{stiff}", "nine_bar", 0.02, group="laws", clearances=["A"],
                  overrides={"A.stiffness": stiff}, variant=f"stiffness_{stiff}"))
    add(_case("law/clr_hinge+R/materials", "clr_hinge", 0.01, group="laws", clearances=["R"],
              overrides={"R.material1": {"E": 1.1e11, "nu": 0.34}, "R.material2": "steel", "R.axial_clearance": 2e-4,
                         "R.clearance": 2e-4, "R.ce": 0.7, "R.v_impact_min": 1e-3}, variant="materials"))

    # 6. options: scene options, key-path overrides, starts, output grids, tolerances, method options
    for opts in ({"law": "low"}, {"limbs": False}, {"layout": "a"}, {"layout": "c"}):
        tag = "_".join(f"{k}={v}" for k, v in opts.items())
        add(_case(f"opt/four_ups_upr/{tag}", "four_ups_upr", 0.1, group="options", options=opts, variant="ideal"))
    add(_case("opt/four_bar/gravity_keypath", "four_bar", 0.5, group="options", overrides={"gravity": [0.0, -3.0, 1.0]},
              variant="ideal"))
    for start in ("ideal", "rest", "least-energy"):
        add(_case(f"opt/rrr3+P2/start_{start}", "rrr3", 0.02, group="options", clearances=["P2"],
                  sim={"start": start}))
    # from the ideal start's last state (t0 its time: the drives' rows hold at t0), journal off centre
    add(_case("opt/rrr3+P2/start_state", "rrr3", 0.01, group="options", clearances=["P2"], sim={"start": "state"},
              state_from="opt/rrr3+P2/start_ideal"))
    add(_case("opt/rrr3+P2/grid", "rrr3", 0.02, group="options", clearances=["P2"],
              sim={"dt_out": 1e-4, "max_step": 1e-4, "first_step": 1e-6, "rtol": 1e-6}))
    add(_case("opt/rrr3+P2/t_eval", "rrr3", 0.02, group="options", clearances=["P2"],
              sim={"t_eval": [0.0, 0.001, 0.0015, 0.007, 0.0199, 0.02], "t0": 0.0, "atol": 1e-9}))
    add(_case("opt/rrr3+P2/t0", "rrr3", 0.03, group="options", clearances=["P2"], sim={"t0": 0.01}))
    add(_case("opt/rrr3+P2/min_mean_step", "rrr3", 0.022, group="options", clearances=["P2"],
              sim={"min_mean_step": 1e-5}))
    add(_case("opt/rrr3+P2/fixed_step_tol_none", "rrr3", 0.022, group="options", clearances=["P2"],
              sim={"integrator": "RK4", "h": 1e-4, "fixed_step_tol": None}))
    add(_case("opt/rrr3+P2/rk4_check_fails", "rrr3", 0.022, group="options", clearances=["P2"],
              sim={"integrator": "RK4", "h": 1e-4}))
    add(_case("opt/rrr3+P2/strict", "rrr3", 0.022, group="options", clearances=["P2"],
              sim={"integrator": "RK4", "h": 1e-4, "strict": True}))
    for loop, outputs in (("python", "compiled"), ("auto", "python"), ("python", "python")):
        for scene, clr, t_end in (("rrr3", "P2", 0.022), ("four_ups_upu", "S2", 0.025)):
            add(_case(f"opt/{scene}+{clr}/loop_{loop}/outputs_{outputs}", scene, t_end, group="options",
                      clearances=[clr], sim={"loop": loop, "outputs": outputs}))
    add(_case("opt/nine_bar+A/lub/outputs_python", "nine_bar", 0.03, group="options", clearances=["A"],
              overrides=_ov("A", LUB_REV), sim={"outputs": "python"}, variant="lubricated_short"))
    add(_case("opt/nine_bar+A/worn/loop_python", "nine_bar", 0.03, group="options", clearances=["A"],
              overrides=_ov("A", {"wear": WEAR_PLANAR}), worn={"clearance": "A", "depth": 0.3},
              sim={"loop": "python"}, variant="worn"))
    for m, mo in (("lagrange", {"alpha": 0.0, "beta": 0.0}), ("lagrange", {"drop_redundant": False}),
                  ("projection", {"tol": 1e-10, "max_iter": 3}), ("proximal", {"project": False}),
                  ("proximal", {"rho": 1e-3, "max_iter": 50}), ("manifold", {"tangent": 0.0, "max_iter": 5}),
                  ("pinocchio", {"mu": 1e-10, "max_iter": 20})):
        tag = "_".join(f"{k}={v}" for k, v in mo.items())
        scene, clr = ("four_ups_upu", "S2") if m == "pinocchio" else ("rrr3", "P2")
        add(_case(f"opt/{scene}+{clr}/{m}/{tag}", scene, 0.025 if m == "pinocchio" else 0.022, group="options",
                  clearances=[clr],
                  sim={"method": m, **mo}))
    add(_case("opt/parallelogram/manifold_singular", "parallelogram", 1.0, group="options",
              sim={"method": "manifold"}, variant="ideal"))
    add(_case("opt/a02_nfourbar_2/proximal", "a02_nfourbar_2", 1.0, group="options", sim={"method": "proximal"},
              variant="ideal"))
    add(_case("opt/cassie/manifold", "cassie", 0.01, group="options", sim={"method": "manifold"}, variant="ideal"))
    # checkpoints every chunk, a resume from one of them (through its file), and a saved trajectory
    for scene, clr, sim in (("rrr3", "P2", {}), ("rrr3", "P2", {"integrator": "ROS34PW2"}),
                            ("four_ups_upu", "S2", {"method": "projection", "integrator": "DOP853"})):
        tag = "_".join(sim.values()) or "default"
        add(_case(f"resume/{scene}+{clr}/{tag}", scene, 0.025, group="resume", clearances=[clr], sim=sim,
                  special="resume"))
    add(_case("save/rrr3+P2", "rrr3", 0.02, group="save", clearances=["P2"], special="save"))
    add(_case("save/nine_bar+A/worn", "nine_bar", 0.03, group="save", clearances=["A"],
              overrides=_ov("A", {"wear": WEAR_PLANAR}), worn={"clearance": "A", "depth": 0.3}, special="save",
              variant="worn"))

    # 7. errors (the exception's class name and message are the result)
    err = [("bad_method", "rrr3", [], {}, {}, {"method": "euler"}),
           ("bad_integrator", "rrr3", [], {}, {}, {"integrator": "Euler"}),
           ("rk4_without_h", "rrr3", [], {}, {}, {"integrator": "RK4"}),
           ("h_with_adaptive", "rrr3", [], {}, {}, {"h": 1e-3}),
           ("rtol_range", "rrr3", [], {}, {}, {"rtol": 1.0}),
           ("dt_out_negative", "rrr3", [], {}, {}, {"dt_out": -1.0}),
           ("bad_method_option", "rrr3", [], {}, {}, {"method": "projection", "alpha": 1.0}),
           ("bad_start", "rrr3", [], {}, {}, {"start": "moving"}),
           ("bad_loop", "rrr3", [], {}, {}, {"loop": "numba"}),
           ("unknown_scene", "no_such_mechanism", [], {}, {}, {}),
           ("unknown_clearance", "rrr3", ["P9"], {}, {}, {}),
           ("unknown_override", "rrr3", ["P2"], {"P2.colour": 1}, {}, {}),
           ("override_inactive", "nine_bar", ["A"], {"B.clearance": 1e-4}, {}, {}),
           ("unknown_type", "rrr3", ["P2"], {"P2.type": "magnetic"}, {}, {}),
           ("lub_without_viscosity", "rrr3", ["P2"], {"P2.type": "lubricated_revolute"}, {}, {}),
           ("wear_bad_key", "rrr3", ["P2"], {"P2.wear": {"k": 1e-5}}, {}, {}),
           ("bad_option", "four_ups_upr", [], {}, {"layout": "z"}, {}),
           ("unknown_option", "rrr3", [], {}, {"colour": 1}, {}),
           ("pinocchio_planar", "four_bar", [], {}, {}, {"method": "pinocchio"}),
           ("lsoda_projection", "four_ups_upu", [], {}, {}, {"method": "projection", "integrator": "LSODA"}),
           ("proximal_refuses", "cassie", [], {}, {}, {"method": "proximal"})]
    for name, scene, clrs, ov, opts, sim in err:
        add(_case(f"error/{name}", scene, 0.01, group="errors", clearances=clrs, overrides=ov, options=opts, sim=sim,
                  variant="error"))
    ids = [c["id"] for c in cases]
    assert len(ids) == len(set(ids)), "case ids must be unique"
    return cases


#: the command-line runs: (name, argv after `pinclear`, quick) -- quick False: skipped by --quick.
#: OUT stands for the run's output folder; STATE for a state file this script writes (q and v of
#: the last sample of STATE_FROM's run: a driverless scene, so the state holds at t = 0).
STATE_FROM = "scene/clr_planar_pendulum/A"
CLI = [("reproduce_000_quick", ["reproduce", "000", "--quick", "--workers", "1", "--out", "OUT"], False),
       ("reproduce_002_quick", ["reproduce", "002", "--quick", "--workers", "1", "--out", "OUT"], False),
       ("reproduce_003_quick", ["reproduce", "003", "--quick", "--workers", "1", "--out", "OUT"], True),
       ("reproduce_004", ["reproduce", "004", "--workers", "1", "--out", "OUT"], True),
       ("simulate_rrr3_P2", ["simulate", "rrr3", "--clearance", "P2", "--t-end", "0.02", "--progress", "off",
                             "--out", "OUT"], True),
       ("simulate_clr_planar_pendulum_A_state", ["simulate", "clr_planar_pendulum", "--clearance", "A", "--t-end",
                                                "0.01", "--start", "state", "STATE", "--integrator", "DOP853",
                                                "--progress", "off", "--out", "OUT"], True),
       ("sweep_rrr3_P2", ["sweep", "rrr3", "--clearance", "P2", "--vary", "P2.clearance=1e-4:3e-4:3",
                          "--t-end", "0.01", "--workers", "1", "--progress", "off", "--out", "OUT"], True),
       ("wear_slider_crank_P", ["wear", "slider_crank_clearance", "--clearance", "P", "--set",
                                "P.wear={k: 1.0e-5, hardness: 2.0e+9, nodes: 72}", "--cycles", "1e4", "--period",
                                "0.012", "--updates", "2", "--max-rounds", "2", "--out", "OUT"], True)]

# ============================================================================ running one case
_PY_CLI = "import sys; from pinclear.cli import main; sys.exit(main(sys.argv[1:]))"


def plain(x):
    """A JSON-safe copy (numpy scalars and arrays to Python; float values exact through repr)."""
    if isinstance(x, dict):
        return {str(k): plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [plain(v) for v in x]
    if isinstance(x, np.ndarray):
        return plain(x.tolist())
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return float(x)
    if x is None or isinstance(x, str):
        return x
    if isinstance(x, enum.Enum):
        return plain(x.value)
    s = str(x)
    # an object without a JSON form: its class name and text (never a memory address or module path)
    return f"<{type(x).__name__}> " + re.sub(r" at 0x[0-9a-f]+", "", s)


def error_record(exc):
    rec = {"type": type(exc).__name__, "message": " ".join(str(exc).split())}
    for k in ("key", "choices"):
        v = getattr(exc, k, None)
        if v is not None:              # choices: the names (a registry's values are classes)
            rec[k] = plain(v if isinstance(v, str) else list(v))
    tr = getattr(exc, "trajectory", None)
    if tr is not None:
        rec["trajectory_status"] = tr.status
        rec["trajectory_samples"] = len(tr.t)
    return rec


def traj_arrays(tr, prefix=""):
    """Every array of a Trajectory: states, multipliers, outputs, energies (the energy() totals too)."""
    arr = {"t": tr.t, "q": tr.q, "v": tr.v, "a": tr.a, "z": tr.z, "residual": tr.residual,
           "drive_error": tr.drive_error}
    for k, v in tr.lam.items():
        arr[f"lam/{k}"] = v
    for k, v in tr.outputs.items():
        arr[f"out/{k}"] = v
    for k, v in tr.energies.items():
        arr[f"energy/{k}"] = v
    if tr.energies:
        arr["energy()/total"] = tr.energy()["total"]
    return {prefix + k: np.asarray(v) for k, v in arr.items()}


def traj_record(tr):
    """Everything a Trajectory says besides its arrays (summary and audit called as a user would)."""
    rec = {"status": tr.status, "message": tr.message, "samples": len(tr.t)}
    for what, fn in (("summary", tr.summary), ("energy_balance", tr.energy_balance),
                     ("tracking_error", tr.tracking_error)):
        try:
            rec[what] = plain(fn())
        except Exception as exc:           # a result too
            rec[what] = {"error": error_record(exc)}
    try:
        rec["drive_forces"] = {k: len(v) for k, v in tr.drive_forces().items()}
    except Exception as exc:
        rec["drive_forces"] = {"error": error_record(exc)}
    f = tr.failure
    rec["failure"] = None if f is None else {"kind": str(getattr(f[0], "value", f[0])), "t": plain(f[1]),
                                             "detail": f[2]}
    rec["stats"] = plain(tr.stats)
    rec["meta"] = plain(tr.meta)
    rec["lam_names"] = list(tr.lam)
    rec["output_names"] = list(tr.outputs)
    return rec


def mech_record(mech, clearances):
    rec = {"name": mech.name, "nq": mech.nq, "nv": mech.nv, "m": mech.m, "describe": plain(mech.describe()),
           "row_names": plain(list(mech.row_names())), "q0": plain(np.asarray(mech.q0)),
           "v0": plain(np.asarray(mech.v0))}
    # the active clearance joints' types (force elements named as the clearances asked for)
    rec["clearance_types"] = [f.describe().get("type") for f in mech.forces if getattr(f, "name", None) in clearances]
    return rec


def _worn(mech, spec):
    """The mechanism with one worn joint reshaped to a smooth, uneven depth (``depth`` x its radial
    clearance at the deepest node, towards -y of the bearing / socket frame; as tests/test_wear*.py
    build worn joints: Mechanism.replace + the joint's with_depth)."""
    joint = next(f for f in mech.forces if getattr(f, "name", None) == spec["clearance"])
    ang = np.asarray(joint.wear.angles())
    if ang.ndim == 1:                                          # planar bearing: node angles theta
        u = np.stack([np.cos(ang), np.sin(ang), np.zeros_like(ang)], 1)
    else:                                                      # socket: (theta, phi) of each node
        th, ph = ang
        u = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], 1)
    depth = spec["depth"] * joint.c * (0.5 * (1.0 + u @ np.array([0.0, -1.0, 0.0]))) ** 2
    worn = mech.replace(forces=[joint.with_depth(depth) if f is joint else f for f in mech.forces])
    return worn, depth


def run_case(case, outdir, finals):
    import pinclear

    rec = {"id": case["id"], "case": plain({k: v for k, v in case.items() if k != "id"})}
    arrays = {}
    scene = case["scene"]
    name = str(REPO / scene) if case["load_by"] == "path" else scene
    try:
        mech = pinclear.load(name, clearances=case["clearances"] or None, overrides=case["overrides"] or None,
                             options=case["options"] or None)
    except Exception as exc:
        rec["load_error"] = error_record(exc)
        return rec, arrays
    if case["worn"]:
        try:
            mech, depth = _worn(mech, case["worn"])
            arrays["worn_depth"] = depth
        except Exception as exc:
            rec["worn_error"] = error_record(exc)
            return rec, arrays
    rec["mechanism"] = mech_record(mech, case["clearances"])
    sim = dict(case["sim"])
    for k in ("q0", "v0", "t_eval", "atol"):
        if isinstance(sim.get(k), list):
            sim[k] = np.array(sim[k], float)
    t_end = case["t_end"]
    if case["state_from"]:
        t, q, v = finals[case["state_from"]]
        sim.update(q0=q, v0=v, t0=t)
        t_end = t + case["t_end"]
    if case["special"] == "resume":
        return _run_resume(case, mech, sim, outdir, rec, arrays)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            tr = pinclear.simulate(mech, t_end, **sim)
        except Exception as exc:
            rec["simulate_error"] = error_record(exc)
            tr = getattr(exc, "trajectory", None)
    rec["warnings"] = [f"{w.category.__name__}: {' '.join(str(w.message).split())}" for w in caught]
    if tr is None:
        return rec, arrays
    rec["trajectory"] = traj_record(tr)
    arrays.update(traj_arrays(tr))
    if len(tr.t):
        finals[case["id"]] = (float(tr.t[-1]), np.array(tr.q[-1]), np.array(tr.v[-1]))
    if case["special"] == "save":
        path = outdir / "runs" / (safe(case["id"]) + ".trajectory.npz")
        tr.save(path)
        back = pinclear.Trajectory.load(path, mech=mech)
        got = traj_arrays(back)
        rec["save_roundtrip"] = {"same_arrays": sorted(k for k, v in got.items() if _same(v, arrays.get(k))),
                                 "differing_arrays": sorted(k for k, v in got.items() if not _same(v, arrays.get(k))),
                                 "loaded": traj_record(back)}
        arrays.update({f"loaded/{k}": v for k, v in got.items()})
    return rec, arrays


def _run_resume(case, mech, sim, outdir, rec, arrays):
    """The run with a checkpoint after every chunk (checkpoint_every=0), then the same run resumed
    from its middle checkpoint read back from its file: both stored, and whether they agree."""
    import pinclear

    cks = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        full = pinclear.simulate(mech, case["t_end"], checkpoint=cks.append, checkpoint_every=0.0, **sim)
        rec["trajectory"] = traj_record(full)
        arrays.update(traj_arrays(full))
        rec["checkpoints"] = [{"t": float(c.t), "samples": len(c.samples), "h_next": plain(c.h_next),
                               "identity": plain(c.identity)} for c in cks]
        if cks:
            ck = cks[len(cks) // 2]
            path = outdir / "runs" / (safe(case["id"]) + ".checkpoint.npz")
            path.parent.mkdir(parents=True, exist_ok=True)
            ck.save(path)
            back = type(ck).load(path)
            resumed = pinclear.simulate(mech, case["t_end"], resume=back, **sim)
            rec["resumed"] = traj_record(resumed)
            got = traj_arrays(resumed, "resumed/")
            arrays.update(got)
            rec["resume_same_as_full"] = {k: _same(v, arrays.get(k[len("resumed/"):])) for k, v in got.items()}
    rec["warnings"] = [f"{w.category.__name__}: {' '.join(str(w.message).split())}" for w in caught]
    return rec, arrays


def _same(a, b):
    return b is not None and a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def safe(cid):
    return re.sub(r"[^A-Za-z0-9_.+=-]", "_", cid.replace("/", "__"))


def write_json(path, obj):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(obj, indent=1, sort_keys=False) + "\n", encoding="utf-8")


def coverage(records):
    """Counts of the matrix (runs that reached simulate; errors counted apart)."""
    cnt = {"method": {}, "integrator": {}, "clearance_type": {}, "variant": {}, "group": {}, "outcome": {}}

    def inc(k, v):
        cnt[k][str(v)] = cnt[k].get(str(v), 0) + 1

    for r in records:
        c = r["case"]
        inc("group", c["group"])
        sim = c["sim"]
        inc("method", sim.get("method", "lagrange"))
        inc("integrator", sim.get("integrator", "RK45"))
        types = (r.get("mechanism") or {}).get("clearance_types") or (["none"] if "mechanism" in r else ["(not loaded)"])
        for t in types:
            inc("clearance_type", t)
        inc("variant", c["variant"])
        if "load_error" in r or "worn_error" in r:
            out = "load error"
        elif "simulate_error" in r:
            out = "simulate error" + (" (trajectory kept)" if "trajectory" in r else "")
        else:
            out = (r.get("trajectory") or {}).get("status", "?")
        inc("outcome", out)
    return cnt


def run_cli(name, argv, outdir, finals):
    """One `pinclear ...` command in a subprocess (this process's environment, PYTHONPATH included)."""
    cli_dir = outdir / "cli"
    out = cli_dir / name
    cli_dir.mkdir(parents=True, exist_ok=True)
    args = []
    for a in argv:
        if a == "OUT":
            args.append(str(out))
        elif a == "STATE":
            if STATE_FROM not in finals:
                return None, 0.0, 0.0
            _, q, v = finals[STATE_FROM]
            p = cli_dir / f"state_{safe(STATE_FROM)}.npz"
            np.savez(p, q=q, v=v)
            args.append(str(p))
        else:
            args.append(a)
    r0, w0 = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", _PY_CLI] + args, cwd=cli_dir, capture_output=True, text=True)
    r1, wall = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter() - w0
    (cli_dir / f"{name}.stdout.txt").write_text(proc.stdout, encoding="utf-8")
    (cli_dir / f"{name}.stderr.txt").write_text(proc.stderr, encoding="utf-8")
    # stdout line by line, a JSON line parsed (so its CPU fields are left out by key like any other);
    # stderr (progress, compile notices) only in its side file
    lines = []
    for line in proc.stdout.splitlines():
        try:
            lines.append({"json": json.loads(line)})
        except ValueError:
            lines.append(line)
    write_json(cli_dir / f"{name}.json", {"argv": argv, "returncode": proc.returncode, "stdout": lines})
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return proc.returncode, cpu, wall


def cmd_run(outdir, quick=False, only=None):
    import pinclear

    outdir = Path(outdir).resolve()
    if outdir.exists() and any(outdir.iterdir()):
        sys.exit(f"bitwise: {outdir} is not empty (give a new folder: the studies resume from what they find)")
    outdir.mkdir(parents=True, exist_ok=True)
    pkg_root = Path(pinclear.__file__).resolve().parent.parent
    cases = build_cases()
    if only:
        cases = [c for c in cases if re.search(only, c["id"])]
    write_json(outdir / "manifest.json", {
        "format": FORMAT, "quick": bool(quick), "cases": [c["id"] for c in cases],
        "cli": [n for n, _, q in CLI if (q or not quick) and not (only and not re.search(only, n))],
        # roots: replaced by placeholders before paths are compared (not compared themselves)
        "roots": {"out": str(outdir), "pinclear": str(pkg_root), "repo": str(REPO)},
        "environment": {"python": sys.version.split()[0], "argv": sys.argv}})
    timing = {"cases": {}, "cli": {}}
    records = []
    finals = {}
    t_all, c_all = time.perf_counter(), time.process_time()
    for k, case in enumerate(cases):
        c0, w0 = time.process_time(), time.perf_counter()
        try:
            rec, arrays = run_case(case, outdir, finals)
        except Exception as exc:          # a bug of this script or an unforeseen failure: recorded, not fatal
            rec, arrays = {"id": case["id"], "case": plain(case), "unexpected_error": error_record(exc),
                           "traceback_last": traceback.format_exc().strip().splitlines()[-1]}, {}
        cpu, wall = time.process_time() - c0, time.perf_counter() - w0
        base = outdir / "runs" / safe(case["id"])
        base.parent.mkdir(parents=True, exist_ok=True)
        np.savez(str(base) + ".npz", **arrays)
        write_json(Path(str(base) + ".json"), rec)
        records.append(rec)
        timing["cases"][case["id"]] = {"cpu_s": cpu, "wall_s": wall}
        status = (rec.get("trajectory") or {}).get("status") or next(
            (rec[k]["type"] for k in ("load_error", "worn_error", "simulate_error", "unexpected_error") if k in rec), "?")
        print(f"[{k + 1}/{len(cases)}] {case['id']}: {status} ({cpu:.2f} CPU s)", flush=True)
    timing["matrix_cpu_s"], timing["matrix_wall_s"] = time.process_time() - c_all, time.perf_counter() - t_all
    cov = coverage(records)
    write_json(outdir / "coverage.json", cov)
    write_json(outdir / "timing.json", timing)
    for name, argv, q in CLI:
        if quick and not q:
            continue
        if only and not re.search(only, name):
            continue
        print(f"[cli] pinclear {' '.join(argv)}", flush=True)
        rc, cpu, wall = run_cli(name, argv, outdir, finals)
        timing["cli"][name] = {"cpu_s": cpu, "wall_s": wall, "returncode": rc}
        print(f"[cli] {name}: exit {rc} ({cpu:.1f} CPU s, {wall:.1f} s wall)", flush=True)
        write_json(outdir / "timing.json", timing)
    timing["total_wall_s"] = time.perf_counter() - t_all
    write_json(outdir / "timing.json", timing)
    print(f"matrix: {len(cases)} runs, {timing['matrix_cpu_s']:.1f} CPU s, {timing['matrix_wall_s']:.1f} s wall; "
          f"cli: {sum(v['cpu_s'] for v in timing['cli'].values()):.1f} CPU s (children); total wall "
          f"{timing['total_wall_s']:.1f} s")
    for k, v in cov.items():
        print(f"  {k}: " + ", ".join(f"{n} {c}" for n, c in v.items()))


# ============================================================================ comparing two folders
#: (regular expression on a field's key / an array's name / a CSV column, reason). A field whose key
#: matches fully (case-insensitive) is left out of the comparison, with everything under it.
IGNORED = [
    (r"(.*[^a-z])?cpu([^a-z].*)?",
     "CPU seconds (cpu_s, setup_cpu_s, cpu_s_total, cpu_per_sim_s, cpu_sim [s], a table's 'CPU [s]' column...): "
     "a measurement of the machine and its load, not a result"),
    (r"compile_s", "kernel compile / cache-load seconds: depends on the kernel cache's state and the machine"),
    (r"(.*[^a-z])?wall([^a-z].*)?|elapsed(_s)?", "wall-clock seconds"),
    (r"pid|hostname", "the process id / machine name of the run"),
    (r"versions", "pinclear / pinocchio / numpy / scipy / python version strings: the environment, not a result"),
    (r"date|created|timestamp", "calendar dates and times of the run"),
    (r"commit|git(_.*)?|revision", "the commit hash of the tree that ran"),
]
#: (regular expression on "PARENT.KEY", reason): a field left out only under that parent
IGNORED_UNDER = [
    (r"sweep_point\.sweep",
     "a sweep point's identity digest: sha256 over the sweep's description, which holds the mechanism file's "
     "absolute path (in the pinclear tree, or in OUTDIR for a sidecar a study writes), so it differs whenever "
     "the folder does; the description (sweep.json, paths normalised) and the point's overrides are compared"),
]
#: files compared (by suffix); the other files are listed with their reason
COMPARED = (".npz", ".json", ".csv", ".yaml")
NOT_COMPARED = {".png": "figures drawn from the compared arrays (renderer metadata)",
                ".md": "reports written from report.json; they quote CPU and wall times in their text",
                ".html": "as .md", ".txt": "stdout / stderr of a command (progress lines, compile notices)",
                ".lock": "a sweep's lock file"}
#: files of this script's own that are not results
SIDE_FILES = {"timing.json": "CPU / wall times of each run (the point of a side file)"}
_IGNORED = [(re.compile(p, re.I), why) for p, why in IGNORED]
_IGNORED_UNDER = [(re.compile(p), why) for p, why in IGNORED_UNDER]
#: keys the rules above would catch that are inputs, not measurements: compared
KEPT = {"max_cpu", "max-cpu", "budget"}


def _ignored(key):
    k = str(key).strip().lstrip("#").strip()
    if k in KEPT:
        return None
    for rx, why in _IGNORED:
        if rx.fullmatch(k):
            return rx.pattern
    return None


class Comparer:
    def __init__(self, roots_a, roots_b, renames=()):
        self.subs = (self._subs(roots_a), self._subs(roots_b))
        # a module moved on purpose (--rename OLD=NEW): A's "OLD." / "OLD:" read as B's "NEW." / "NEW:"
        self.renames = [(re.compile(re.escape(old) + r"(?=[.:])"), new) for old, new in renames]
        self.fields = self.arrays = 0
        self.ignored = {}
        self.diffs = []

    @staticmethod
    def _subs(roots):
        pairs = [(roots.get("out"), "<OUT>"), (roots.get("pinclear"), "<ROOT>"), (roots.get("repo"), "<ROOT>")]
        pairs = [(p, s) for p, s in pairs if p]
        return sorted(pairs, key=lambda ps: -len(ps[0]))

    def norm(self, s, side):
        for p, sub in self.subs[side]:
            s = s.replace(p, sub)
        if side == 0:
            for rx, new in self.renames:
                s = rx.sub(new, s)
        return s

    def skip(self, key, where, parent=None):
        rule = _ignored(key)
        if not rule and parent is not None:
            rule = next((rx.pattern for rx, _ in _IGNORED_UNDER if rx.fullmatch(f"{parent}.{key}")), None)
        if rule:
            self.ignored[rule] = self.ignored.get(rule, 0) + 1
        return rule

    def diff(self, where, what):
        self.diffs.append(f"{where}: {what}")

    # ---------------------------------------------------------------- JSON
    def json(self, a, b, where, parent=None):
        if isinstance(a, dict) and isinstance(b, dict):
            cols = a.get("columns") if isinstance(a.get("columns"), list) else None
            for k in list(dict.fromkeys(list(a) + list(b))):
                if self.skip(k, where, parent):
                    continue
                if k not in a or k not in b:
                    self.diff(f"{where}.{k}", "only in " + ("B" if k not in a else "A"))
                    continue
                if k == "rows" and cols and isinstance(a[k], list) and isinstance(b[k], list):
                    keep = [i for i, c in enumerate(cols) if not self.skip(c, where)]
                    pick = (lambda r: [r[i] for i in keep if i < len(r)] if isinstance(r, list) else r)
                    self.json([pick(r) for r in a[k]], [pick(r) for r in b[k]], f"{where}.rows")
                    continue
                self.json(a[k], b[k], f"{where}.{k}", k)
            return
        if isinstance(a, list) and isinstance(b, list):
            if len(a) != len(b):
                self.diff(where, f"list of {len(a)} vs {len(b)} items")
            for i, (x, y) in enumerate(zip(a, b)):
                self.json(x, y, f"{where}[{i}]")
            return
        self.fields += 1
        if isinstance(a, str) and isinstance(b, str):
            a, b = self.norm(a, 0), self.norm(b, 1)
        same = type(a) is type(b) and (a == b or (isinstance(a, float) and math.isnan(a) and math.isnan(b)))
        if not same:
            self.diff(where, f"{_short(a)} != {_short(b)}" + _rel(a, b))

    # ---------------------------------------------------------------- arrays
    def array(self, a, b, where):
        self.arrays += 1
        if a.dtype.kind == "U" and b.dtype.kind == "U" and a.ndim == 0 and b.ndim == 0:
            sa, sb = str(a), str(b)
            try:
                ja, jb = json.loads(sa), json.loads(sb)
            except ValueError:
                if self.norm(sa, 0) != self.norm(sb, 1):
                    self.diff(where, f"{_short(sa)} != {_short(sb)}")
                return
            self.json(ja, jb, where + "{json}")
            return
        if a.dtype != b.dtype or a.shape != b.shape:
            self.diff(where, f"dtype/shape {a.dtype}{a.shape} vs {b.dtype}{b.shape}")
            return
        if a.dtype.kind == "U":
            na = np.vectorize(lambda s: self.norm(s, 0), otypes=[a.dtype])(a) if a.size else a
            nb = np.vectorize(lambda s: self.norm(s, 1), otypes=[b.dtype])(b) if b.size else b
            if not np.array_equal(na, nb):
                self.diff(where, f"{int(np.sum(na != nb))} of {a.size} strings differ")
            return
        if a.tobytes() == b.tobytes():
            return
        if a.dtype.kind in "fc":
            nan_a, nan_b = np.isnan(a), np.isnan(b)
            if np.array_equal(nan_a, nan_b) and a[~nan_a].tobytes() == b[~nan_b].tobytes():
                return                                    # NaN at the same places (payload aside)
            bad = ~((a == b) | (nan_a & nan_b))
            idx = np.argwhere(bad)
            dv = np.abs(a[bad] - b[bad])
            dv = dv[np.isfinite(dv)]
            first = tuple(int(i) for i in idx[0]) if len(idx) else ()
            self.diff(where, f"{int(bad.sum())} of {a.size} values differ (first at {first}: "
                             f"{a[first]!r} vs {b[first]!r}; largest |difference| "
                             f"{dv.max() if dv.size else float('nan'):.3g})")
            return
        self.diff(where, f"{int(np.sum(a != b))} of {a.size} values differ")

    def text(self, a, b, where):
        la, lb = self.norm(a, 0).splitlines(), self.norm(b, 1).splitlines()
        self.fields += max(len(la), len(lb))
        if len(la) != len(lb):
            self.diff(where, f"{len(la)} vs {len(lb)} lines")
        for n, (x, y) in enumerate(zip(la, lb), 1):
            if x != y:
                self.diff(f"{where}[line {n}]", f"{_short(x)} != {_short(y)}")

    def npz(self, fa, fb, where):
        with np.load(fa, allow_pickle=False) as za, np.load(fb, allow_pickle=False) as zb:
            for k in list(dict.fromkeys(list(za.files) + list(zb.files))):
                if self.skip(k, where):
                    continue
                if k not in za.files or k not in zb.files:
                    self.diff(f"{where}:{k}", "only in " + ("B" if k not in za.files else "A"))
                    continue
                self.array(za[k], zb[k], f"{where}:{k}")

    def csv(self, fa, fb, where):
        ra = list(csv.reader(io.StringIO(Path(fa).read_text(encoding="utf-8"))))
        rb = list(csv.reader(io.StringIO(Path(fb).read_text(encoding="utf-8"))))
        if not ra or not rb:
            if ra != rb:
                self.diff(where, "one file is empty")
            return
        ha, hb = ra[0], rb[0]
        if ha != hb:
            self.diff(where, f"header {ha} != {hb}")
            return
        keep = [i for i, c in enumerate(ha) if not self.skip(re.sub(r"\s*\[[^]]*\]$", "", c.strip()), where)]
        if len(ra) != len(rb):
            self.diff(where, f"{len(ra) - 1} vs {len(rb) - 1} rows")
        for n, (x, y) in enumerate(zip(ra[1:], rb[1:]), 1):
            for i in keep:
                self.fields += 1
                u = self.norm(x[i], 0) if i < len(x) else "<missing>"
                v = self.norm(y[i], 1) if i < len(y) else "<missing>"
                if u != v:
                    self.diff(f"{where}[row {n}].{ha[i]}", f"{_short(u)} != {_short(v)}")


def _short(x, n=140):
    s = repr(x)
    return s if len(s) <= n else s[:n] + "..."


def _rel(a, b):
    if isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool) \
            and not isinstance(b, bool) and math.isfinite(a) and math.isfinite(b) and a != b:
        return f" (relative {abs(a - b) / max(abs(a), abs(b)):.2g})"
    return ""


def cmd_compare(da, db, limit=None, renames=()):
    da, db = Path(da), Path(db)
    ma, mb = (json.loads((d / "manifest.json").read_text(encoding="utf-8")) for d in (da, db))
    cmp = Comparer(ma.get("roots", {}), mb.get("roots", {}), renames)
    for k in ("format", "quick", "cases", "cli"):
        cmp.json(ma.get(k), mb.get(k), f"manifest.{k}")
    fa = {p.relative_to(da).as_posix() for p in da.rglob("*") if p.is_file()}
    fb = {p.relative_to(db).as_posix() for p in db.rglob("*") if p.is_file()}
    skipped = {}
    files = 0
    for rel in sorted(fa | fb):
        name = rel.rsplit("/", 1)[-1]
        suffix = Path(rel).suffix
        if rel == "manifest.json" or rel in SIDE_FILES:
            continue
        if suffix not in COMPARED:
            skipped[suffix or name] = skipped.get(suffix or name, 0) + 1
            continue
        if rel not in fa or rel not in fb:
            cmp.diff(rel, "file only in " + ("B" if rel not in fa else "A"))
            continue
        files += 1
        if suffix == ".npz":
            cmp.npz(da / rel, db / rel, rel)
        elif suffix == ".json":
            cmp.json(json.loads((da / rel).read_text(encoding="utf-8")),
                     json.loads((db / rel).read_text(encoding="utf-8")), rel)
        elif suffix == ".yaml":                          # a sidecar a study writes: its text, paths normalised
            cmp.text((da / rel).read_text(encoding="utf-8"), (db / rel).read_text(encoding="utf-8"), rel)
        else:
            cmp.csv(da / rel, db / rel, rel)
    shown = cmp.diffs if limit is None else cmp.diffs[:limit]
    for d in shown:
        print(d)
    if len(shown) < len(cmp.diffs):
        print(f"... and {len(cmp.diffs) - len(shown)} more")
    print(f"compared {files} files: {cmp.arrays} arrays and {cmp.fields} fields (JSON leaves and CSV cells)")
    print("left out by rule: " + ("; ".join(f"{n} x /{r}/" for r, n in cmp.ignored.items()) or "nothing"))
    if skipped:
        print("files not compared: " + ", ".join(f"{n} {s} ({NOT_COMPARED.get(s, 'not a result format')})"
                                               for s, n in sorted(skipped.items())))
    print(f"{len(cmp.diffs)} difference(s) between {da} and {db}")
    return 1 if cmp.diffs else 0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run", help="run the matrix and the studies into OUTDIR (a new folder)")
    r.add_argument("outdir")
    r.add_argument("--quick", action="store_true", help="skip the two slow studies (reproduce 000, 002 --quick)")
    r.add_argument("--only", help="only the cases / commands whose id matches this regular expression (debugging)")
    c = sub.add_parser("compare", help="compare two OUTDIRs; exit 1 on any difference")
    c.add_argument("a")
    c.add_argument("b")
    c.add_argument("--limit", type=int, default=None, help="print at most this many differences")
    c.add_argument("--rename", action="append", default=[], metavar="OLD=NEW",
                   help="a module moved on purpose, e.g. pinclear.mechanisms=pinclear.models.mechanisms: A's "
                        "strings naming OLD.x or OLD:f (a sidecar's drive-law function) are read as NEW.x / NEW:f "
                        "(repeatable)")
    args = ap.parse_args(argv)
    if args.cmd == "run":
        cmd_run(args.outdir, quick=args.quick, only=args.only)
        return 0
    renames = []
    for r in args.rename:
        if "=" not in r:
            ap.error(f"--rename takes OLD=NEW, got {r!r}")
        renames.append(tuple(r.split("=", 1)))
    return cmd_compare(args.a, args.b, args.limit, renames)


if __name__ == "__main__":
    sys.exit(main())
