"""``pinclear bench restitution``: effective restitution of every normal law in the 1-DOF impact;
``pinclear bench contact-laws``: the contact physics against closed forms (Hertz impacts of a ball
in a socket and a journal in a bearing, the prismatic foundation's edge and corner against the
Winkler integrals, convergence with the integration tolerance), one table.

Every damped law here has the form F = f(d) (1 + chi dd/dd0). Along an impact, with the elastic
work W(d) = int f as the independent variable, m v dv/dW = -(1 + chi v/v0): the speed ratio
depends on chi alone, not on the elastic curve f, the mass or the speed. The table therefore
depends only on the law's chi(ce); the line and plane rows (paper 003, with the
Lankarani-Nikravesh hysteresis) repeat the Lankarani-Nikravesh row, as they must.
"""
from __future__ import annotations

import argparse
import json
import math
import sys

import numpy as np

from pinclear.contact.laws import HYSTERESIS, effective_modulus, make_normal_law, restitution_1dof
from pinclear.core.errors import InputError
from pinclear.mechanisms import bench_scenes as scenes

DAMPED = [n for n in HYSTERESIS if n != "hertz"]


def restitution_table(ces=(0.3, 0.6, 0.9), v0=0.1, m=1.0, rtol=1e-12):
    """{law: [effective restitution at each ce]} from the 1-DOF integration."""
    Es = effective_modulus(200e9, 0.3, 200e9, 0.3)
    table = {}
    for name in ["hertz"] + DAMPED + ["line", "plane"]:
        row = []
        for ce in ces:
            if name == "line":
                law = make_normal_law({"type": "line", "ce": ce}, line=(Es, 0.1, 1e-3))
            elif name == "plane":
                law = make_normal_law({"type": "plane", "ce": ce}, plane=(200e9, 5e-3, 0.05))
            else:
                law = make_normal_law({"type": name, "ce": ce, "K": 1e10})
            row.append(restitution_1dof(law, v0=v0, m=m, rtol=rtol))
        table[name] = row
    return table


def restitution_main(argv=None, parser=argparse.ArgumentParser) -> int:
    """`pinclear bench restitution`; ``parser``: the command line's parser class (its one-line
    errors, pinclear.cli.args.OneLineParser)."""
    p = parser(prog="pinclear bench restitution",
               description="Effective restitution of each normal-force law (1-DOF impact).")
    p.add_argument("--ce", type=float, nargs="+", default=[0.3, 0.6, 0.9], help="nominal restitution values")
    p.add_argument("--v0", type=float, default=0.1, help="impact speed, m/s (line/plane laws only)")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    a = p.parse_args(argv)
    for ce in a.ce:
        if not 0 < ce <= 1:
            raise InputError(f"--ce {ce}: restitution coefficient outside (0, 1]")
    if not a.v0 > 0:
        raise InputError(f"--v0 {a.v0}: impact speed must be > 0")
    table = restitution_table(tuple(a.ce), v0=a.v0)
    if a.json:
        print(json.dumps({"ce": a.ce, "effective": table}, indent=1))
        return 0
    head = "law".ljust(22) + "".join(f"ce={ce:<8g}" for ce in a.ce)
    print("effective restitution of the 1-DOF impact (DOP853, rtol 1e-12)")
    print(head)
    for name, row in table.items():
        print(name.ljust(22) + "".join(f"{e:<11.4f}" for e in row))
    return 0


# ------------------------------------------------------------------------------- contact-laws
def hertz_impact(m, K, v):
    """(max penetration, peak force, contact duration) of an undamped Hertz impact F = K d^1.5 of
    a mass m at speed v (Hertz 1882; Johnson, Contact Mechanics, 1985, sec. 11.4):
    d_max = (5 m v^2 / (4 K))^(2/5), F_max = K d_max^1.5, and from the energy equation
    t_c = 2 (d_max / v) int_0^1 (1 - x^(5/2))^(-1/2) dx = 2 (d_max / v) (2/5) B(2/5, 1/2)
    = 3.218 (m^2 / (K^2 v))^(1/5)."""
    dmax = (5.0 * m * v * v / (4.0 * K)) ** 0.4
    beta = math.gamma(0.4) * math.gamma(0.5) / math.gamma(0.9)
    return dmax, K * dmax ** 1.5, 2.0 * dmax / v * 0.4 * beta


#: the two impacts: {what they test: (scene, clearance, mass of the moving body [kg], velocity
#: direction (q-space), clearance gap)}, the bundled scenes' (pinclear.mechanisms.bench_scenes)
IMPACTS = scenes.IMPACTS


def measured_impact(model, name, nv, axis, v=0.2, rtol=1e-10):
    """(peak normal force, contact duration, K, m, stiffness note) of one central impact of the
    bundled test mechanism ``model`` (gravity off, undamped Hertz law, no friction) at speed v,
    read from a run sampled every 1/4000 of the closed-form duration; the duration from the
    onset event to the separation, located by linear interpolation of the penetration."""
    import pinocchio as pin

    from pinclear.dynamics.simulate import simulate
    from pinclear.io.sidecar import load

    mech = load(model, clearances=[name], overrides={f"{name}.normal_law": "hertz"})
    mech.model.gravity = pin.Motion.Zero()
    el = mech.forces[-1]
    m = float(sum(mech.model.inertias[j].mass for j in range(1, mech.model.njoints)))
    _, _, tc = hertz_impact(m, el.law.K, v)
    gap = el.describe()["clearance"]
    v0 = np.zeros(nv)
    v0[axis] = v if axis == 0 else -v
    t_on = gap / v
    t_end = t_on + 1.3 * tc
    tr = simulate(mech, t_end, integrator="DOP853", rtol=rtol, atol=1e-14, q0=np.zeros(nv), v0=v0,
                           assemble=False, t_eval=np.linspace(t_on - 0.01 * tc, t_end, 5301))
    if tr.status != "success":
        raise InputError(f"bench contact-laws: the {model} impact failed: {tr.message}")
    d = tr.outputs[f"{name}.penetration"]
    F = np.linalg.norm(np.atleast_2d(tr.outputs[f"{name}.normal_force"]).reshape(len(tr.t), -1), axis=1)
    out = np.flatnonzero((d[:-1] > 0) & (d[1:] <= 0))
    if not len(out) or not tr.stats["events"]:
        raise InputError(f"bench contact-laws: no complete contact in the {model} run")
    i = out[0]
    t_off = tr.t[i] + d[i] / (d[i] - d[i + 1]) * (tr.t[i + 1] - tr.t[i])
    return float(F.max()), float(t_off - tr.stats["events"][0]["t"]), el.law.K, m, el.stiffness_note


def winkler_rows(hx=0.025, hy=0.05, kf=4e12, g=2e-4, s=1e-7):
    """The prismatic energy model's face (contact._kernels.foundation_face) at an edge and a
    corner against the Winkler integrals of a linear foundation p = kf d over the penetrated
    part: edge strip (width s/g, length 2 hy): F = kf hy s^2 / g, U = kf hy s^3 / (3 g); corner
    triangle (legs s/gx, s/gy): F = kf s^3 / (6 gx gy), U = kf s^4 / (24 gx gy); flat face
    (paper 003 eq. 4): F = kf A d."""
    from pinclear.contact import prismatic_geometry

    poly, F = np.zeros((7, 4)), np.zeros(4)

    def face(d):
        U = prismatic_geometry.foundation_face(np.asarray(d, float), hx, hy, kf, poly, F)
        return F.sum(), U

    e = 2 * hx * g                                    # the tilt's drop across the face
    edge = face([s - e, s - e, s, s])
    corner = face([s - e - 2 * hy * g, s - 2 * hy * g, s - e, s])
    flat = face([s] * 4)
    return [("prismatic energy model: edge force (Winkler strip)", edge[0], kf * hy * s * s / g),
            ("prismatic energy model: edge energy", edge[1], kf * hy * s ** 3 / (3 * g)),
            ("prismatic energy model: corner force (Winkler triangle)", corner[0], kf * s ** 3 / (6 * g * g)),
            ("prismatic energy model: corner energy", corner[1], kf * s ** 4 / (24 * g * g)),
            ("prismatic energy model: flat face, E A d / l (Winkler plane law, docs/contact_models.md)", flat[0],
             kf * 4 * hx * hy * s)]


def contact_laws_table(rtols=(1e-6, 1e-8, 1e-10), v=0.2):
    """Rows (check, ours, closed form, relative error): the Hertz impacts at each tolerance,
    then the Winkler edge/corner/face."""
    rows = []
    for label, (model, name, nv, axis) in IMPACTS.items():
        for rtol in rtols:
            Fm, tc, K, m, note = measured_impact(model, name, nv, axis, v=v, rtol=rtol)
            _, F_ref, t_ref = hertz_impact(m, K, v)
            tag = f"{label}, K = {K:.4g} N/m^1.5 ({note}), m = {m:g} kg, v = {v:g} m/s, rtol {rtol:g}"
            rows += [(f"{tag}: peak force", Fm, F_ref), (f"{tag}: contact duration", tc, t_ref)]
    rows += winkler_rows()
    return [(c, float(a), float(b), abs(a - b) / abs(b)) for c, a, b in rows]


def contact_laws_main(argv=None, parser=argparse.ArgumentParser) -> int:
    """`pinclear bench contact-laws`; ``parser`` as for :func:`restitution_main`."""
    p = parser(prog="pinclear bench contact-laws",
               description="Contact physics against closed forms (Hertz impact, Winkler foundation).")
    p.add_argument("--v", type=float, default=0.2, help="impact speed, m/s")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    a = p.parse_args(argv)
    if not a.v > 0:
        raise InputError(f"--v {a.v}: impact speed must be > 0")
    rows = contact_laws_table(v=a.v)
    if a.json:
        print(json.dumps([dict(check=c, ours=o, closed_form=r, relative_error=e) for c, o, r, e in rows], indent=1))
        return 0
    w = max(len(c) for c, *_ in rows)
    print("contact physics against closed forms (pinclear.studies.bench.restitution; docs/contact_models.md)")
    print("check".ljust(w) + "  " + "ours".rjust(12) + "  " + "closed form".rjust(12) + "  rel. error")
    for c, o, r, e in rows:
        print(c.ljust(w) + f"  {o:12.6g}  {r:12.6g}  {e:.2e}")
    return 0


if __name__ == "__main__":
    sys.exit(restitution_main())
