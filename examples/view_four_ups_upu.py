"""Animate one period of the 4UPS-UPU (paper 000) as a standalone HTML page, optionally with
the spherical clearance at S2 and a PNG screenshot (headless Chromium).

    python examples/view_four_ups_upu.py --html out/four_ups_upu.html \
        --screenshot docs/viz_four_ups_upu.png [--clearance S2]

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
    ap.add_argument("--html", default="out/four_ups_upu.html")
    ap.add_argument("--screenshot", default=None, help="PNG of the page at --t")
    ap.add_argument("--t", type=float, default=None,
                    help="simulated time of the screenshot [s] (default: the largest contact force "
                         "if a clearance is active, else 0.5)")
    ap.add_argument("--clearance", action="append", default=[], help="activate a clearance joint (e.g. S2)")
    ap.add_argument("--t-end", type=float, default=2.0, help="simulated time (one period of Y = 0.05 sin(pi t))")
    a = ap.parse_args(argv)
    mech = pinclear.load(HERE.parent / "urdf" / "four_ups_upu.yaml", clearances=a.clearance or None)
    traj = pinclear.simulate(mech, a.t_end, dt_out=1e-3, rtol=1e-7)   # impacts last ~ms
    print(traj.summary()["status"], traj.message)
    scene = show(mech, traj, html=a.html, slowdown=None)
    print(f"wrote {scene.html_path}")
    if a.screenshot:
        t = a.t if a.t is not None else (loudest_frame_time(scene, traj) or 0.5)
        print(f"wrote {screenshot(scene.html_path, a.screenshot, t=t)} (t = {t:g} s)")


if __name__ == "__main__":
    main()
