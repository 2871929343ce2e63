"""``pinclear view`` and ``pinclear plot`` (wired into pinclear.cli.commands by the lead)."""
from __future__ import annotations

import sys
import tempfile
import zipfile
from pathlib import Path

from pinclear.viz.elements import recorded_clearances


def _trust(flag: bool):
    """--trust given: trust; absent: defer to PINCLEAR_TRUST (pinclear.load's own default)."""
    return True if flag else None


def _recorded_load_args(traj) -> dict:
    """How the run's mechanism was loaded (options, overrides, active clearances), from its
    metadata; runs saved before pinclear recorded ``load_args`` give their options and the
    clearance joints their description lists."""
    la = traj.meta.get("load_args")
    if isinstance(la, dict):
        return {"options": la.get("options") or None, "overrides": la.get("overrides") or None,
                "clearances": la.get("clearances") or None}
    return {"options": traj.meta.get("options") or None, "overrides": None,
            "clearances": list(recorded_clearances(traj.meta)) or None}


def check_run_mechanism(traj, mech, file):
    """Refuse to show or plot a run with a mechanism other than the one it was made with: the
    description recorded in the run (name, sizes, joints, closures, drives, force elements and
    active clearances) must match; equal sizes are not enough."""
    traj.check_mechanism(mech, str(file))


def _same_value(a, b) -> bool:
    """A recorded value and the user's spelling of it: equal as data, or as numbers (YAML reads
    2e-4 as a string, the run recorded 0.0002)."""
    if a == b:
        return True
    if isinstance(a, bool) or isinstance(b, bool):
        return False
    try:
        return float(a) == float(b)
    except (TypeError, ValueError):
        return str(a) == str(b)


def _given_load_args(recorded: dict, given: dict, npz) -> dict:
    """The run's recorded load arguments with the entries the user repeated on the command line
    (``given``: {"overrides": {...} from --set, "options": {...} from --option}) taken as the
    user's: a recorded entry that adds code or a file is refused (check_recorded_args) unless the
    user names it with the same value (then it is the user's word, under --trust like the file).
    A --set the run was made without, or with another value, would show another mechanism than
    the run's: refused, one line."""
    from pinclear.core.errors import InputError
    from pinclear.core.jsonsafe import jsonable

    kept = dict(recorded)
    for part, flag in (("overrides", "--set"), ("options", "--option")):
        rec = dict(recorded.get(part) or {})
        for k, v in (given.get(part) or {}).items():
            if k not in rec:
                raise InputError(f"{flag} {k}={v}: the run {npz} was made without it (its recorded {part}: "
                                 f"{', '.join(sorted(map(str, rec))) or 'none'}); {flag} here only repeats the run's own")
            if not _same_value(jsonable(rec[k]), jsonable(v)):
                raise InputError(f"{flag} {k}={v}: the run {npz} was made with {k} = {rec[k]!r}")
            del rec[k]
        kept[part] = rec or None
    return kept


def load_run(npz, mech_path=None, trust=None, prog=None, overrides=None, options=None, clearances=None):
    """A saved trajectory and the mechanism it was run on (same options and active clearances
    as recorded in its metadata), checked to be that mechanism (:func:`check_run_mechanism`).

    Without ``mech_path`` only a bundled mechanism is loaded again, by the name the run
    records: a path recorded in a results file is never opened. ``trust`` covers the file at
    ``mech_path`` (named by the user) only; the recorded options and overrides never add code
    or files (pinclear.core.trust.check_recorded_args; docs/security.md). ``prog``: the
    subcommand asking, whose --help the error of a run without ``mech_path`` points to.
    ``overrides`` / ``options`` (--set / --option): recorded entries the user repeats, taken as
    the user's (:func:`_given_load_args`)."""
    from pinclear.core.errors import ModelFileError, PinclearError
    from pinclear.core.trust import check_recorded_args, recorded_mechanism
    from pinclear.dynamics.trajectory import Trajectory
    from pinclear.io.sidecar import load

    npz = Path(npz)
    if not npz.exists():
        raise ModelFileError(str(npz), "path", "no such file")
    try:
        traj = Trajectory.load(npz)
    except (PinclearError, OSError, ValueError, KeyError, zipfile.BadZipFile) as exc:
        why = str(exc).removeprefix(f"{npz}: ")
        raise ModelFileError(str(npz), "npz", f"not a pinclear trajectory ({why})") from None
    # recorded options and overrides never add code or files (with --trust neither), and a
    # recorded path is never opened: the user names the file, or the run's is a bundled one
    given = {"overrides": overrides or {}, "options": options or {}}
    la = check_recorded_args(_given_load_args(_recorded_load_args(traj), given, npz), npz)
    for part in ("overrides", "options"):
        la[part] = {**(la.get(part) or {}), **given[part]} or None
    if clearances:          # the user's list: for a run saved before pinclear recorded its load arguments
        if la.get("clearances") and sorted(la["clearances"]) != sorted(clearances):
            from pinclear.core.errors import InputError

            raise InputError(f"--clearance {', '.join(clearances)}: the run {npz} was made with the clearances "
                             f"{', '.join(la['clearances'])} active")
        la["clearances"] = list(clearances)
    if mech_path is None:
        mech_path, trust = recorded_mechanism(traj.meta, npz, prog=prog), False
    mech = load(mech_path, **la, trust=trust)
    check_run_mechanism(traj, mech, npz)
    traj.mech = mech
    return traj, mech


def check_same_tree(mech, ref_mech, file, ref_file):
    """A reference run is drawn with the main run's model (its platform frame, its joint order),
    so it must come from the same kinematic tree: same joints, types, sizes and placements. Its
    joints may differ in clearances, closures, drives and forces (e.g. ideal joints)."""
    from pinclear.core.errors import InputError

    a, b = mech.model, ref_mech.model
    why = None
    if (a.nq, a.nv) != (b.nq, b.nv):
        why = f"nq/nv {b.nq}/{b.nv} instead of {a.nq}/{a.nv}"
    elif list(a.names) != list(b.names):
        why = "other joint names"
    elif [j.shortname() for j in a.joints] != [j.shortname() for j in b.joints]:
        why = "other joint types"
    elif not all(x.isApprox(y, 1e-12) for x, y in zip(a.jointPlacements, b.jointPlacements)):
        why = "other joint placements"
    if why is not None:
        raise InputError(f"--ref {ref_file}: the run was made with mechanism {ref_mech.name!r} ({ref_mech.path}), "
                         f"{file} with {mech.name!r} ({mech.path}): {why}; --ref takes a run of the same mechanism "
                         "(e.g. with ideal joints)")


def _scene_args(ap):
    from pinclear.cli.args import count, number

    ap.add_argument("--slowdown", type=number(), default=None,
                    help="playback seconds per simulated second (default: real time, or slowed by a round "
                         "factor so that runs shorter than 5 s play for 5 s)")
    ap.add_argument("--fps", type=number(unit="1/s"), default=30.0, help="animation frames per playback second")
    ap.add_argument("--max-frames", type=count(2), default=1500, help="cap on animation frames (resampled)")
    ap.add_argument("--ecc-scale", type=number(), default=None,
                    help="magnification of the clearance eccentricity vector (default: a 1-2-5 factor that "
                         "draws the clearance at most 8 %% of the mechanism's size; printed)")
    ap.add_argument("--force-scale", type=number(unit="m/N"), default=None,
                    help="metres of arrow per newton (default: longest force arrow = 1/4 of the mechanism)")
    ap.add_argument("--no-urdf-visuals", action="store_true", help="automatic primitives even if the URDF has visuals")


#: absurd but finite display options are refused, not drawn: (lowest, highest, why) per option.
#: Playback faster than 1000 frames per second or slowed beyond 1e6 shows nothing a screen can;
#: a scale beyond 1e12 turns millimetre clearances and newton forces into coordinates of 1e9 m
#: and more, which WebGL's single-precision floats draw as noise or infinity.
DISPLAY_BOUNDS = {"fps": (1e-3, 1000.0, "frames per playback second a screen can show"),
                  "slowdown": (1e-6, 1e6, "playback seconds per simulated second"),
                  "ecc_scale": (1e-12, 1e12, "a magnification WebGL's float32 coordinates can draw"),
                  "force_scale": (1e-12, 1e12, "metres of arrow per newton WebGL's float32 coordinates can draw"),
                  "wear_scale": (1e-12, 1e12, "a magnification WebGL's float32 coordinates can draw")}
#: most animation frames (each holds every body's placement: 20 000 frames of 30 bodies are
#: about 60 MB of page)
MAX_FRAMES = 20_000
#: largest screenshot side in pixels
MAX_SIDE_PX = 8192


def _checked_scene_args(a):
    """Refuse scene options the animation cannot use, as one line, before anything is loaded;
    returns the screenshot size (width, height)."""
    import math

    from pinclear.core.errors import InputError

    for name in ("slowdown", "fps", "ecc_scale", "force_scale", "wear_scale"):
        v = getattr(a, name, None)
        if v is not None and not (math.isfinite(v) and v > 0):
            raise InputError(f"--{name.replace('_', '-')} must be a positive number, got {v:g}")
        lo, hi, why = DISPLAY_BOUNDS[name]
        if v is not None and not lo <= v <= hi:
            raise InputError(f"--{name.replace('_', '-')} {v:g} is outside {lo:g}..{hi:g} ({why})")
    if a.max_frames < 2 or a.max_frames > MAX_FRAMES:
        raise InputError(f"--max-frames must be 2..{MAX_FRAMES} (every frame holds every body's placement in the "
                         f"page), got {a.max_frames}")
    w, x, h = a.size.lower().partition("x")
    if not (x and w.isdigit() and h.isdigit() and len(w) <= 6 and len(h) <= 6 and int(w) > 0 and int(h) > 0):
        raise InputError(f"--size expects WIDTHxHEIGHT in pixels (e.g. 960x720), got {a.size[:40]!r}")
    if int(w) > MAX_SIDE_PX or int(h) > MAX_SIDE_PX:
        raise InputError(f"--size {w}x{h}: at most {MAX_SIDE_PX} pixels a side (a {MAX_SIDE_PX}^2 screenshot is "
                         f"{MAX_SIDE_PX ** 2 * 4 / 2 ** 20:.0f} MiB of pixels in the browser)")
    return int(w), int(h)


def build_view_parser():
    """The parser of `pinclear view`."""
    from pinclear.cli.args import MECH_HELP, OneLineParser, add_mech_option, number

    ap = OneLineParser(prog="pinclear view",
                       description="Show a mechanism (FILE.yaml / FILE.urdf) or animate a saved run "
                                   "(trajectory.npz) with meshcat.")
    ap.add_argument("file", help="sidecar .yaml, .urdf, or a trajectory .npz")
    ap.add_argument("--html", help="write a standalone HTML page (plays offline) instead of starting a server")
    ap.add_argument("--screenshot", help="also render the page to this PNG with headless Chromium")
    ap.add_argument("--t", type=number("nonnegative", "s"), default=None,
                    help="simulated time shown in the screenshot (default: the run's start)")
    ap.add_argument("--size", default="960x720", help="screenshot size WxH in pixels")
    ap.add_argument("--no-block", action="store_true",
                    help="with --zmq-url: push the scene to that server and return (the viewer's own server "
                         "stops with the command, so without --zmq-url this is refused)")
    ap.add_argument("--open", action="store_true", help="open the viewer in a web browser")
    ap.add_argument("--zmq-url", default=None, help="use a running meshcat server (default: start one on loopback)")
    add_mech_option(ap, MECH_HELP + "; with a trajectory .npz only")
    ap.add_argument("--clearance", action="append", default=[], metavar="NAME", help="activate a clearance joint")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="NAME.key=value (clearance key) or option=value (scene option); with a run, repeat an "
                         "override the run recorded that a results file may not apply itself (code or a file)")
    ap.add_argument("--option", action="append", default=[], metavar="KEY=VALUE", help="set a scene option")
    ap.add_argument("--trust", action="store_true",
                    help="trust the mechanism file named on the command line (FILE or --mech): allow its "
                         "Python functions outside pinclear and URDF meshes outside its folders; never a "
                         "run's recorded file or arguments, which are not opened or applied as code "
                         "(docs/security.md)")
    ap.add_argument("--wear", default=None, metavar="OUT",
                    help="draw the worn bearings of a wear run (OUT/profile.csv of `pinclear wear` or `pinclear "
                         "study`); load the mechanism with that run's --clearance and --set")
    ap.add_argument("--wear-scale", type=number(), default=None,
                    help="magnification of the worn depth (default: a 1-2-5 factor drawing the deepest wear a "
                         "quarter of its bearing's radius; printed)")
    _scene_args(ap)
    return ap


def view_main(argv: list[str]) -> int:
    try:
        a = build_view_parser().parse_args(argv)
    except SystemExit as exc:          # --help (0) or a one-line usage error (2): a return code
        return int(exc.code or 0)

    from pinclear.core.errors import PinclearError
    from pinclear.io.sidecar import load, parse_assignments
    from pinclear.viz import build_scene, export_html, screenshot, start_viewer, wait_forever

    trust = _trust(a.trust)
    if a.no_block and a.zmq_url is None and not (a.html or a.screenshot):
        # the server pinclear starts stops when the command returns: its URL would serve nothing
        print("pinclear: error: --no-block needs --zmq-url (a meshcat server you run); pinclear's own viewer "
              "server stops when the command returns, so omit --no-block or use --html", file=sys.stderr)
        return 2
    try:
        size = _checked_scene_args(a)
        traj = None
        if a.file.lower().endswith(".npz"):
            traj, mech = load_run(a.file, a.mech, trust=trust, prog="pinclear view",
                                  overrides=parse_assignments(a.set, "--set"),
                                  options=parse_assignments(a.option, "--option"))
        else:
            if a.mech is not None and Path(a.mech).resolve() != Path(a.file).resolve():
                from pinclear.core.errors import InputError

                raise InputError(f"view {a.file}: FILE is the mechanism, --mech {a.mech} names a second one; "
                                 "--mech goes with a trajectory .npz (give one mechanism)")
            mech = load(a.file, options=parse_assignments(a.option, "--option") or None,
                                 overrides=parse_assignments(a.set, "--set") or None,
                                 clearances=a.clearance or None, trust=trust)
        if a.wear is not None:
            from pinclear.analysis.wear_life import read_profile, with_profile

            mech = with_profile(mech, read_profile(a.wear), a.wear)
            if traj is not None:
                traj.mech = mech
        scene = build_scene(mech, traj, fps=a.fps, slowdown=a.slowdown, max_frames=a.max_frames,
                            ecc_scale=a.ecc_scale, force_scale=a.force_scale,
                            use_urdf_visuals=not a.no_urdf_visuals, trust=trust, wear_scale=a.wear_scale)
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
            try:
                png = screenshot(html, a.screenshot, t=a.t, size=size)
            except (FileNotFoundError, RuntimeError) as exc:
                print(f"pinclear: error: screenshot: {exc}", file=sys.stderr)
                return 2
            print(f"wrote {png}")
        return 0
    try:
        vis = start_viewer(scene, zmq_url=a.zmq_url, open_browser=a.open)
        print(f"viewer at {vis.url()}", flush=True)
        if not a.no_block:
            wait_forever()
    except RuntimeError as exc:          # the server did not start (LocalServer says why)
        print(f"pinclear: error: viewer: {exc}", file=sys.stderr)
        return 2
    finally:
        scene.close()
    return 0


def _report(scene):
    info = scene.info
    line = f"{info['name']}: {len(scene.body_paths)} bodies"
    if scene.clearances:
        fs = info.get("force_scale")
        line += (f"; clearances {', '.join(el.name for el in scene.clearances)}: eccentricity x{info['ecc_scale']:g}"
                 + (f", forces {1.0 / fs:.4g} N per m of arrow" if fs else ""))
    if info.get("worn"):
        line += "; worn bearings " + ", ".join(f"{n} ({1e6 * d:.3g} um deep)" for n, d in info["worn"].items()) + \
            f": depth x{info['wear_scale']:g}"
    if "animation" in info:
        an = info["animation"]
        line += (f"; {an['frames']} frames for t = {an['t0']:.4g}..{an['t1']:.4g} s "
                 f"({an['samples']} samples), {an['fps']:.3g} fps, slowdown {an['slowdown']:g}")
    print(line)


def build_plot_parser():
    """The parser of `pinclear plot`."""
    from pinclear.cli.args import MECH_HELP, OneLineParser, add_mech_option

    ap = OneLineParser(prog="pinclear plot", description="Write the standard figures of a saved run.")
    ap.add_argument("file", help="trajectory .npz (from pinclear simulate --out)")
    ap.add_argument("--out", required=True, help="output folder (created if missing)")
    ap.add_argument("--ref", default=None, help="a second run (e.g. ideal joints) drawn dashed on the platform plot")
    add_mech_option(ap, MECH_HELP + "; also of the --ref run")
    ap.add_argument("--frame", default=None,
                    help="frame plotted as the platform (default: the sidecar's platform frame)")
    ap.add_argument("--format", default="png", choices=["png", "pdf", "svg"], help="image format")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="repeat an override the run recorded (NAME.key=value) that a results file may not apply "
                         "itself (code or a file): your word for it, with --trust (docs/security.md)")
    ap.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                    help="repeat a scene option the run recorded, as --set")
    ap.add_argument("--trust", action="store_true",
                    help="trust the mechanism file given with --mech (allow its Python functions outside "
                         "pinclear); a run's recorded file and arguments are never trusted (docs/security.md)")
    return ap


def plot_main(argv: list[str]) -> int:
    try:
        a = build_plot_parser().parse_args(argv)
    except SystemExit as exc:          # --help (0) or a one-line usage error (2): a return code
        return int(exc.code or 0)

    from pinclear.core.errors import PinclearError
    from pinclear.viz.plots import save_all

    try:
        from pinclear.core.bounded import check_regular

        for f in (a.file, a.ref):
            if f is not None:               # a FIFO or a device would block or never end
                check_regular(f, "path", "trajectory")
        from pinclear.io.sidecar import parse_assignments

        given = {"overrides": parse_assignments(a.set, "--set"), "options": parse_assignments(a.option, "--option")}
        traj, mech = load_run(a.file, a.mech, trust=_trust(a.trust), prog="pinclear plot", **given)
        ref = None
        if a.ref:
            ref, ref_mech = load_run(a.ref, a.mech, trust=_trust(a.trust), prog="pinclear plot")
            check_same_tree(mech, ref_mech, a.file, a.ref)
        written, skipped = save_all(traj, a.out, mech=mech, ref=ref, fmt=a.format, frame=a.frame)
        from pinclear.core.version import write_provenance

        write_provenance(a.out, command="plot", run=str(a.file), ref=a.ref, mech=a.mech,
                         run_versions=traj.meta.get("versions"))
    except PinclearError as exc:
        print(f"pinclear: error: {exc}", file=sys.stderr)
        return 2
    for name, path in written.items():
        print(f"wrote {path}")
    for name, why in skipped.items():
        print(f"skipped {name}: {why}")
    return 0


if __name__ == "__main__":      # python -m pinclear.cli.view view|plot ...
    cmd, rest = (sys.argv[1], sys.argv[2:]) if len(sys.argv) > 1 else ("", [])
    sys.exit({"view": view_main, "plot": plot_main}.get(cmd, lambda _: (print("usage: view|plot ..."), 2)[1])(rest))
