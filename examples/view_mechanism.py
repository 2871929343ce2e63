"""Animate one period of a source mechanism as a standalone HTML page, optionally with a
clearance joint active and a PNG screenshot (headless Chromium).

    python examples/view_mechanism.py four_ups_upu --clearance S2 --html out/four_ups_upu_S2.html \
        --screenshot docs/viz_four_ups_upu.png
    python examples/view_mechanism.py nine_bar --clearance A --html out/nine_bar_A.html \
        --screenshot docs/viz_nine_bar.png

Nothing opens a browser; open the HTML file yourself (it plays offline).
``--quick``: a 0.05 s smoke run; ``--out DIR``: where the page goes when --html is not given.
"""
import argparse
from pathlib import Path

import pinclear
from pinclear.viz import show
from pinclear.viz.animate import loudest_frame_time
from pinclear.viz.html import screenshot

#: one period of each motion law [s], and the screenshot time without a clearance [s]
PERIODS = {"four_ups_upu": (2.0, 0.5), "nine_bar": (1.0, 0.25), "three_upru_up": (25.1327, 5.0),
           "four_ups_upr": (2.0 * 3.14159265, 0.5)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mechanism", choices=sorted(PERIODS))
    ap.add_argument("--html", default=None, help="output page (default out/MECHANISM.html)")
    ap.add_argument("--screenshot", default=None, help="PNG of the page at --t")
    ap.add_argument("--t", type=float, default=None,
                    help="simulated time of the screenshot [s] (default: the largest contact force "
                         "if a clearance is active)")
    ap.add_argument("--clearance", action="append", default=[], help="activate a clearance joint (e.g. S2, A)")
    ap.add_argument("--t-end", type=float, default=None, help="simulated time (default: one period)")
    ap.add_argument("--out", default="out", help="folder of the page when --html is not given")
    ap.add_argument("--quick", action="store_true", help="smoke run: 0.05 s simulated")
    a = ap.parse_args(argv)
    period, t_shot = PERIODS[a.mechanism]
    mech = pinclear.load(a.mechanism, clearances=a.clearance or None)      # a bundled model by name
    t_end = a.t_end or (0.05 if a.quick else period)
    traj = pinclear.simulate(mech, t_end, dt_out=1e-3, rtol=1e-7)   # impacts last ~ms
    print(traj.summary()["status"], traj.message)
    html = Path(a.html or f"{a.out}/{a.mechanism}.html")
    html.parent.mkdir(parents=True, exist_ok=True)
    scene = show(mech, traj, html=str(html), slowdown=None)
    print(f"wrote {scene.html_path}")
    if a.screenshot:
        t = a.t if a.t is not None else (loudest_frame_time(scene, traj) or min(t_shot, t_end))
        print(f"wrote {screenshot(scene.html_path, a.screenshot, t=t)} (t = {t:g} s)")


if __name__ == "__main__":
    main()
