"""The clearance scenes of the papers, shared by examples/*_clearance.py and
benchmarks/bench_clearance.py. The clearance parameters live in the mechanisms' sidecars
(``clearances:`` entries, inactive by default); a scene names which to activate.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from pinclear.core.errors import InputError
from pinclear.core.models import model_path
from pinclear.dynamics.simulate import simulate
from pinclear.io import sidecar


@dataclass(frozen=True)
class Scene:
    mechanism: str              # bundled model name (pinclear.core.models)
    clearances: tuple
    t_end: float
    source: str
    overrides: MappingProxyType = field(default_factory=lambda: MappingProxyType({}))


SCENES = MappingProxyType({
    "four_ups_upu_S2": Scene("four_ups_upu", ("S2",), 4.0,
                             "paper 000, sec. 4: clearance at S2, c = 0.5 mm, mu = 0.1 (two periods)"),
    "nine_bar_A": Scene("nine_bar", ("A",), 1.0, "paper 002, sec. 3.1: clearance at A, 0.5 mm (one crank turn)"),
    "nine_bar_B": Scene("nine_bar", ("B",), 1.0, "paper 002, sec. 3.1: clearance at B, 0.5 mm"),
    "nine_bar_AB": Scene("nine_bar", ("A", "B"), 1.0, "paper 002, sec. 3.3: clearances at A and B, 0.5 mm"),
    "three_upru_up_P": Scene("three_upru_up", ("P_UP",), 0.3,
                             "paper 003, sec. 4: prismatic clearance of the UP branch, 0.1 mm, eq. 3 friction"),
})


def scene(name) -> Scene:
    if name not in SCENES:
        raise InputError(f"unknown clearance scene {name!r}", key="scene", choices=SCENES)
    return SCENES[name]


def load(name, overrides=None):
    """(ideal mechanism, clearance mechanism) of a scene; ``overrides`` as pinclear.load takes them
    (``{"S2.mu": 0.05}``)."""
    sc = scene(name)
    path = model_path(sc.mechanism)
    ideal = sidecar.load(path)
    overrides = {**sc.overrides, **(overrides or {})}
    return ideal, sidecar.load(path, clearances=list(sc.clearances), overrides=overrides)


def run(name, *, t_end=None, integrator="RK45", rtol=1e-6, dt_out=None, max_cpu=None, overrides=None,
        ideal=True, max_step=np.inf):
    """Simulate a scene with and (optionally) without its clearances; returns a dict with the
    mechanisms, trajectories and CPU seconds.

    ``max_step`` (s) optionally bounds the steps (the simulator restarts after every impact with
    a step the integrator chooses afresh, and rejects trial stages that overflow inside a stiff
    contact, so no bound is needed)."""
    sc = scene(name)
    t_end = sc.t_end if t_end is None else t_end
    dt_out = dt_out or t_end / 1000
    m_ideal, m_clr = load(name, overrides)
    out = {"scene": name, "source": sc.source, "t_end": t_end, "mech": m_clr, "mech_ideal": m_ideal}
    if ideal:
        c0 = time.process_time()
        out["ideal"] = simulate(m_ideal, t_end, integrator="RK45", rtol=min(rtol, 1e-8), dt_out=dt_out)
        out["cpu_ideal"] = time.process_time() - c0
    c0 = time.process_time()
    out["clearance"] = simulate(m_clr, t_end, integrator=integrator, rtol=rtol, dt_out=dt_out,
                                         max_cpu=max_cpu, max_step=max_step)
    out["cpu"] = time.process_time() - c0
    return out


def summary(res):
    """One line per clearance: peak contact force, impacts, CPU per simulated second."""
    tr = res["clearance"]
    lines = [f"{res['scene']}: {res['source']}",
             f"  status {tr.status} ({tr.message}); t = {tr.t[-1]:.4g} s; CPU {res['cpu']:.2f} s "
             f"= {res['cpu'] / max(tr.t[-1], 1e-12):.2f} s per simulated s; rhs {tr.stats['rhs_evals']}, "
             f"steps {tr.stats['steps']}, events {len(tr.stats['events'])}"]
    for el in res["mech"].forces:
        if not el.is_clearance:
            continue
        fn = tr.outputs[f"{el.name}.fn"]
        pen = tr.outputs[f"{el.name}.penetration"]
        cont = tr.outputs[f"{el.name}.contact"]
        lines.append(f"  {el.name}: peak normal force {fn.max():.1f} N, max penetration {pen.max() * 1e6:.2f} um, "
                     f"in contact {100 * cont.mean():.0f} % of samples, dissipated "
                     f"{tr.outputs[f'{el.name}.dissipated'][-1]:.4g} J")
    return "\n".join(lines)
