"""``pinclear view`` and ``pinclear plot`` (wired into pinclear.cli by the lead)."""
from __future__ import annotations

import argparse
import sys
import tempfile
import zipfile
from pathlib import Path

import yaml


def _overrides(pairs, file="--set"):
    from pinclear.cli import parse_kv

    return parse_kv(pairs, file)


def _sidecar_clearances(path) -> list[str]:
    try:
        sc = yaml.safe_load(Path(path).read_text(encoding="utf-8")) or {}
    except (OSError, yaml.YAMLError):
        return []
    return [c.get("name") for c in (sc.get("clearances") or []) if isinstance(c, dict)]


def load_run(npz, mech_path=None):
    """A saved trajectory and the mechanism it was run on (same options and active clearances
    as recorded in its metadata)."""
    import pinclear
    from pinclear.errors import ModelFileError

    npz = Path(npz)
    if not npz.exists():
        raise ModelFileError(str(npz), "path", "no such file")
    try:
        traj = pinclear.Trajectory.load(npz)
    except (OSError, ValueError, KeyError, zipfile.BadZipFile) as exc:
        raise ModelFileError(str(npz), "npz", f"not a pinclear trajectory ({type(exc).__name__}: {exc})") from None
    meta = traj.meta or {}
    recorded = mech_path or traj.mech_path
    if not recorded:
        raise ModelFileError(str(npz), "mech_path", "the run does not name its mechanism file; pass --mech FILE.yaml")
    cand = [Path(recorded), npz.parent / recorded, npz.parent / Path(recorded).name]
    path = next((p for p in cand if p.exists()), None)
    if path is None:
        raise ModelFileError(str(npz), "mech_path", f"mechanism file {recorded!r} not found "
                             f"(looked at {', '.join(map(str, cand))}); pass --mech FILE.yaml")
    la = meta.get("load_args")
    if la:                                   # recorded by pinclear.load: reload the same variant
        mech = pinclear.load(path, options=la.get("options") or None, overrides=la.get("overrides") or None,
                             clearances=la.get("clearances") or None)
    else:
        forces = {f.get("name") for f in meta.get("mechanism", {}).get("forces", []) if isinstance(f, dict)}
        active = [n for n in _sidecar_clearances(path) if n in forces]
        mech = pinclear.load(path, options=meta.get("options") or None, clearances=active or None)
    traj.mech = mech
    return traj, mech


def _scene_args(ap):
    ap.add_argument("--slowdown", type=float, default=None,
                    help="playback seconds per simulated second (default: real time, or slowed by a round "
                         "factor so that runs shorter than 5 s play for 5 s)")
    ap.add_argument("--fps", type=float, default=30.0, help="animation frames per playback second")
    ap.add_argument("--max-frames", type=int, default=1500, help="cap on animation frames (resampled)")
    ap.add_argument("--ecc-scale", type=float, default=None,
                    help="magnification of the clearance eccentricity vector (default: a 1-2-5 factor that "
                         "draws the clearance at most 8 %% of the mechanism's size; printed)")
    ap.add_argument("--force-scale", type=float, default=None,
                    help="metres of arrow per newton (default: longest force arrow = 1/4 of the mechanism)")
    ap.add_argument("--no-urdf-visuals", action="store_true", help="automatic primitives even if the URDF has visuals")


def view_main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(prog="pinclear view",
                                 description="Show a mechanism (FILE.yaml / FILE.urdf) or animate a saved run "
                                             "(trajectory.npz) with meshcat.")
    ap.add_argument("file", help="sidecar .yaml, .urdf, or a trajectory .npz")
    ap.add_argument("--html", help="write a standalone HTML page (plays offline) instead of starting a server")
    ap.add_argument("--screenshot", help="also render the page to this PNG with headless Chromium")
    ap.add_argument("--t", type=float, default=None, help="simulated time shown in the screenshot")
    ap.add_argument("--size", default="960x720", help="screenshot size WxH (default 960x720)")
    ap.add_argument("--no-block", action="store_true", help="start the server, print its URL and return")
    ap.add_argument("--open", action="store_true", help="open the viewer in a web browser")
    ap.add_argument("--zmq-url", default=None, help="use a running meshcat server")
    ap.add_argument("--mech", default=None, help="mechanism file of a run (default: recorded in the .npz)")
    ap.add_argument("--clearance", action="append", default=[], metavar="NAME", help="activate a clearance joint")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="NAME.key=value (clearance key) or option=value (scene option)")
    ap.add_argument("--option", action="append", default=[], metavar="KEY=VALUE", help="set a scene option")
    _scene_args(ap)
    a = ap.parse_args(argv)

    import pinclear
    from pinclear.errors import PinclearError

    from . import build_scene, export_html, screenshot, start_viewer, wait_forever

    try:
        traj = None
        if a.file.lower().endswith(".npz"):
            traj, mech = load_run(a.file, a.mech)
        else:
            mech = pinclear.load(a.file, options=_overrides(a.option, "--option") or None,
                                 overrides=_overrides(a.set) or None, clearances=a.clearance or None)
        scene = build_scene(mech, traj, fps=a.fps, slowdown=a.slowdown, max_frames=a.max_frames,
                            ecc_scale=a.ecc_scale, force_scale=a.force_scale,
                            use_urdf_visuals=not a.no_urdf_visuals)
    except PinclearError as exc:
        print(f"pinclear: error: {exc}", file=sys.stderr)
        return 2
    _report(scene)
    if a.html or a.screenshot:
        html = Path(a.html) if a.html else Path(tempfile.mkdtemp(prefix="pinclear-view-")) / "scene.html"
        export_html(scene, html)
        if a.html:
            print(f"wrote {html}")
        if a.screenshot:
            w, h = (int(x) for x in a.size.lower().split("x"))
            try:
                png = screenshot(html, a.screenshot, t=a.t, size=(w, h))
            except (FileNotFoundError, RuntimeError) as exc:
                print(f"pinclear: error: screenshot: {exc}", file=sys.stderr)
                return 2
            print(f"wrote {png}")
        return 0
    start_viewer(scene, zmq_url=a.zmq_url, open_browser=a.open)
    if not a.no_block:
        wait_forever()
    return 0


def _report(scene):
    info = scene.info
    line = f"{info['name']}: {len(scene.body_paths)} bodies"
    if scene.clearances:
        fs = info.get("force_scale")
        line += (f"; clearances {', '.join(el.name for el in scene.clearances)}: eccentricity x{info['ecc_scale']:g}"
                 + (f", forces {1.0 / fs:.4g} N per m of arrow" if fs else ""))
    if "animation" in info:
        an = info["animation"]
        line += (f"; {an['frames']} frames for t = {an['t0']:.4g}..{an['t1']:.4g} s "
                 f"({an['samples']} samples), {an['fps']:.3g} fps, slowdown {an['slowdown']:g}")
    print(line)


def plot_main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(prog="pinclear plot", description="Write the standard figures of a saved run.")
    ap.add_argument("file", help="trajectory .npz (from pinclear simulate --out)")
    ap.add_argument("--out", required=True, help="output directory")
    ap.add_argument("--ref", default=None, help="a second run (e.g. ideal joints) drawn dashed on the platform plot")
    ap.add_argument("--mech", default=None, help="mechanism file (default: recorded in the .npz)")
    ap.add_argument("--frame", default=None,
                    help="frame plotted as the platform (default: the sidecar's platform frame)")
    ap.add_argument("--format", default="png", choices=["png", "pdf", "svg"], help="image format")
    a = ap.parse_args(argv)

    from pinclear.errors import PinclearError

    from .plots import save_all

    try:
        traj, mech = load_run(a.file, a.mech)
        ref = load_run(a.ref, a.mech)[0] if a.ref else None
        written, skipped = save_all(traj, a.out, mech=mech, ref=ref, fmt=a.format, frame=a.frame)
    except PinclearError as exc:
        print(f"pinclear: error: {exc}", file=sys.stderr)
        return 2
    for name, path in written.items():
        print(f"wrote {path}")
    for name, why in skipped.items():
        print(f"skipped {name}: {why}")
    return 0


if __name__ == "__main__":      # python -m pinclear.viz.cli view|plot ...
    cmd, rest = (sys.argv[1], sys.argv[2:]) if len(sys.argv) > 1 else ("", [])
    sys.exit({"view": view_main, "plot": plot_main}.get(cmd, lambda _: (print("usage: view|plot ..."), 2)[1])(rest))
