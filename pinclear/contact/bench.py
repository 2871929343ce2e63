"""``pinclear bench restitution``: effective restitution of every normal law in the 1-DOF impact.

Every damped law here has the form F = f(d) (1 + chi dd/dd0). Along an impact, with the elastic
work W(d) = int f as the independent variable, m v dv/dW = -(1 + chi v/v0): the speed ratio
depends on chi alone, not on the elastic curve f, the mass or the speed. The table therefore
depends only on the law's chi(ce); the line and plane rows (paper 003, with the
Lankarani-Nikravesh hysteresis) repeat the Lankarani-Nikravesh row, as they must.
"""
from __future__ import annotations

import argparse
import json
import sys

from pinclear.errors import InputError

from .laws import HYSTERESIS, effective_modulus, make_normal_law, restitution_1dof

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


def restitution_main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="pinclear bench restitution",
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


if __name__ == "__main__":
    sys.exit(restitution_main())
