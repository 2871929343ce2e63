"""Per-turn wear increments of paper 002's nine-bar with A and B worn (docs/wear_lubrication.md,
'Why the fixed factor did not converge'): how much one simulated turn's Archard increment varies
from turn to turn, and how it depends on the bearings' wear depth.

    python docs/study/paper002/diagnose_wear_rate.py C_MM PROFILE SCALE TURNS

C_MM the nominal clearance [mm]; PROFILE a wear run's profile.csv (A and B columns) or 'new';
SCALE the multiple of that profile the bearings are worn to; TURNS the turns measured after 10
transient turns. The numbers in docs/wear_lubrication.md were measured with the profile of the
earlier fixed-factor study (git show a13f9ea:docs/study/paper002/c0.1mm/profile.csv, 8.4 um deep).
"""
import sys
import time

import numpy as np

import pinclear
from pinclear.contact.wear import block_increment
from pinclear.study import WEAR
from pinclear.wearing import read_profile, with_profile, worn_joint


class _Turn:
    """One turn's samples of a trajectory (what block_increment reads)."""

    def __init__(self, tr, keep):
        self.t, self.outputs = tr.t[keep], {k: v[keep] for k, v in tr.outputs.items()}


def main(c_mm, profile, scale, turns):
    ov = {f"{j}.{k}": v for j in ("A", "B") for k, v in (("clearance", c_mm * 1e-3), ("mu", 0.3), ("wear", WEAR))}
    mech = pinclear.load("nine_bar", clearances=["A", "B"], overrides=ov)
    if profile != "new":
        mech = with_profile(mech, {n: scale * d for n, d in read_profile(profile).items()}, profile)
    c0 = time.process_time()
    tr = pinclear.simulate(mech, 10 + turns, rtol=1e-6, dt_out=1e-4)
    print(f"status {tr.status}, {time.process_time() - c0:.0f} CPU s")
    for n in ("A", "B"):
        wm = worn_joint(mech, n)[1].wear
        inc = np.array([block_increment(wm, n, _Turn(tr, (tr.t >= p - 1e-9) & (tr.t <= p + 1 + 1e-9)))
                        for p in range(10, 10 + turns)])
        vol, top = inc.sum(1) * wm.R1 * wm.spacing * wm.L, inc.max(1)
        mean = inc.mean(0)
        print(f"{n}: largest nodal increment per turn {top.mean():.3g} m (std/mean {top.std() / top.mean():.1%}); "
              f"mean profile's largest {mean.max():.3g} m at {np.degrees(wm.angles()[mean.argmax()]):.0f} deg; "
              f"worn volume per turn {vol.mean():.3g} m^3 (std/mean {vol.std() / vol.mean():.1%}); "
              f"profile max/mean {mean.max() / mean.mean():.2g}")


if __name__ == "__main__":
    main(float(sys.argv[1]), sys.argv[2], float(sys.argv[3]), int(sys.argv[4]))
