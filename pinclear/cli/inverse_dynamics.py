"""``pinclear inverse-dynamics``: drive forces along a platform motion by the screw method, written
as CSV + PNG + peaks JSON, with the condition-number monitor."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from pinclear.core import safeio
from pinclear.core.errors import ModelFileError, PinclearError
from pinclear.core.version import provenance
from pinclear.dynamics.screw.inverse_dynamics import inverse_dynamics
from pinclear.dynamics.screw.section import read_section
from pinclear.dynamics.screw.system import screw_system

#: end time when the motion declares no period
DEFAULT_T_END = 2.0


def _onoff(s):
    s = str(s).lower()
    if s in ("on", "true", "yes", "1"):
        return True
    if s in ("off", "false", "no", "0"):
        return False
    raise argparse.ArgumentTypeError(f"expected on/off, got {s!r}")


def build_parser():
    """The parser of `pinclear inverse-dynamics`."""
    from pinclear.cli.args import OneLineParser, count, number

    p = OneLineParser(prog="pinclear inverse-dynamics",
                      description="screw-theory inverse dynamics (paper 004) along a platform motion")
    p.add_argument("sidecar", help="mechanism sidecar (urdf/NAME.yaml) or a bundled mechanism's name")
    p.add_argument("--law", default=None,
                   help="platform motion named in the sidecar's screw.motions (default: its platform.motion)")
    p.add_argument("--limbs", type=_onoff, default=True, help="limb inertia on|off (default: on)")
    p.add_argument("--gravity", type=_onoff, default=None, help="gravity on|off (default: the sidecar's)")
    p.add_argument("--option", action="append", metavar="KEY=VALUE", help="set a scene option (repeatable)")
    p.add_argument("--trust", action="store_true",
                   help="allow the sidecar to name Python functions outside the pinclear package")
    p.add_argument("--t-end", type=number(unit="s"), default=None,
                   help=f"end time [s] (default: the motion's period when the sidecar declares one, "
                        f"else {DEFAULT_T_END:g} s)")
    p.add_argument("--n", type=count(2), default=1001, help="samples along the motion")
    p.add_argument("--threshold", type=number(), default=1e3,
                   help="condition number above which a sample is marked ill-conditioned")
    p.add_argument("--out", default="inverse_dynamics_out", help="output folder (created if missing)")
    return p


def cli_main(argv=None) -> int:
    """``pinclear inverse-dynamics SIDECAR [--law NAME] [--limbs on|off] [--option KEY=VALUE]
    [--out DIR]``: the law names are the sidecar's ``screw: motions:``; without ``--law`` the
    platform follows the sidecar's ``platform.motion``."""
    p = build_parser()
    args = p.parse_args(argv)
    try:
        from pinclear.io.sidecar import load, parse_assignments

        trust = args.trust or None
        mech = load(args.sidecar, options=parse_assignments(args.option, "--option"), trust=trust)
        system = screw_system(mech, read_section(mech, trust))
        motions = system.section.motions
        if args.law is not None and args.law not in motions:
            raise ModelFileError(system.section.file, "screw.motions", f"unknown motion law {args.law!r} (--law)",
                                 choices=list(motions))
        t_end = args.t_end
        if t_end is None:
            period = motions[args.law].period if args.law is not None else None
            t_end = period or DEFAULT_T_END
        t = np.linspace(0.0, t_end, args.n)
        res = inverse_dynamics(mech, args.law, t, limbs=args.limbs, gravity=args.gravity,
                               threshold=args.threshold, system=system)
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        header = ["t"] + res.drive_names + [f"virtual{k + 1}" for k in range(res.virtual.shape[1])] + ["cond"]
        table = np.column_stack([res.t, res.tau, res.virtual, res.cond])
        safeio.write_atomic(out / "drive_forces.csv",
                            lambda fh: np.savetxt(fh, table, delimiter=",", header=",".join(header), comments=""))
        summ = res.summary()
        summ.update({"mechanism": mech.name, "law": args.law, "options": mech.options, "t_end": t_end,
                     "samples": args.n, "units": "N for prismatic drives, N m for revolute",
                     "versions": provenance()})
        safeio.write_text(out / "peaks.json", json.dumps(summ, indent=2))
        plot(res, out / "drive_forces.png",
             f"{mech.name} {args.law or 'platform.motion'} limbs={'on' if args.limbs else 'off'}")
        outside = summ["peak_abs_outside_intervals"]
        print(f"peak |drive force| {summ['peak_abs_all']:.1f} (outside ill-conditioned intervals: "
              f"{'none' if outside is None else f'{outside:.1f}'}); cond max at samples {summ['cond_max']:.3g}; "
              f"{len(res.intervals)} interval(s) above {args.threshold:g}; written to {out}")
        if res.crossings:
            at = ", ".join(f"{tc:.6f}" for tc, _ in res.crossings)
            print(f"warning: the motion passes through a singular configuration at t = {at} s; "
                  "drive forces there are unbounded (sampled peaks depend on the sampling)", file=sys.stderr)
        return 0
    except PinclearError as exc:
        print(f"pinclear: error: {exc}", file=sys.stderr)
        return 2


def plot(res, path, title):
    """Drive forces (ill-conditioned intervals shaded) over the condition number, to ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for i, n in enumerate(res.drive_names):
        ax[0].plot(res.t, res.tau[:, i], label=n)
    ok = res.outside_intervals()
    if ok.any() and not ok.all():
        lim = 1.5 * float(np.abs(res.tau[ok]).max())
        ax[0].set_ylim(-lim, lim)      # the spikes at singular crossings would hide everything else
    for a, b, _ in res.intervals:
        ax[0].axvspan(a, b, color="r", alpha=0.15)
    ax[0].set_ylabel("drive force [N]")
    ax[0].legend(loc="upper right", fontsize=8)
    ax[0].set_title(title)
    ax[1].semilogy(res.t, res.cond)
    ax[1].axhline(res.threshold, color="r", ls="--", lw=0.8)
    for a, b, _ in res.intervals:
        ax[1].axvspan(a, b, color="r", alpha=0.15)
    ax[1].set_ylabel("cond(G_p^q)")
    ax[1].set_xlabel("t [s]")
    fig.tight_layout()
    safeio.savefig(fig, path, dpi=100)
    plt.close(fig)
