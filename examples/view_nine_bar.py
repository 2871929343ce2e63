"""Animate one crank turn of the planar nine-bar (paper 002) as a standalone HTML page,
optionally with the revolute clearance at A (and/or B), and a PNG screenshot (headless Chromium).

    python examples/view_nine_bar.py --html out/nine_bar.html \
        --screenshot docs/viz_nine_bar.png [--clearance A]

Nothing opens a browser; open the HTML file yourself (it plays offline).
"""
import argparse
from pathlib import Path

import pinclear
from pinclear.viz import show
from pinclear.viz.animate import loudest_frame_time
from pinclear.viz.html import screenshot

HERE = Path(__file__).resolve().parent


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--html", default="out/nine_bar.html")
    ap.add_argument("--screenshot", default=None, help="PNG of the page at --t")
    ap.add_argument("--t", type=float, default=None,
                    help="simulated time of the screenshot [s] (default: the largest contact force "
                         "if a clearance is active, else 0.25)")
    ap.add_argument("--clearance", action="append", default=[], help="activate a clearance joint (A, B)")
    ap.add_argument("--t-end", type=float, default=1.0, help="simulated time (one crank turn at 2 pi rad/s)")
    a = ap.parse_args(argv)
    mech = pinclear.load(HERE.parent / "urdf" / "nine_bar.yaml", clearances=a.clearance or None)
    traj = pinclear.simulate(mech, a.t_end, dt_out=1e-3, rtol=1e-7)   # impacts last ~ms
    print(traj.summary()["status"], traj.message)
    scene = show(mech, traj, html=a.html, slowdown=None)
    print(f"wrote {scene.html_path}")
    if a.screenshot:
        t = a.t if a.t is not None else (loudest_frame_time(scene, traj) or 0.25)
        print(f"wrote {screenshot(scene.html_path, a.screenshot, t=t)} (t = {t:g} s)")


if __name__ == "__main__":
    main()
