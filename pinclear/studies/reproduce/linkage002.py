"""Paper 002's linkage fitted to its printed ideal kinematics, and the family of linkages the fit leaves.

Paper 002 (Chen & Pan 2021, sec. 3.2 and 3.4) prints four numbers of the ideal mechanism: slider 9's
displacement peak, 0.115 m at 0.616 s, and its velocity peak, 0.653 m/s at 0.512 s (the displacement
measured from the start position, as pinclear.studies.reproduce.paper002 measures it; both peaks
in the first crank turn). Its eq. 15 names the dimensions (Ls1..Ls8, L5, L72, L8, Hx, Hy, beta,
beta1..3), its Tables 1-2, which held them, are lost.

The fit: least squares of the four numbers, each in units of its print precision (half a unit of
the last printed digit), over :data:`FREE`: the two cranks (``L1``, ``L4``: the five-bar's
asymmetry sets the instants of the peaks) and the plate pivot ``Hx``, ``Hy`` (the stroke and the
speed), each inside its plausible range (:data:`BOUNDS`), every dyad's transmission sine along the
drive law at least :data:`MIN_SINE`. The other dimensions are pinclear.mechanisms.nine_bar's
reconstructed values; its committed dimensions are this fit's nominal member.

Eq. 15's symbols outnumber the four printed numbers: the fit leaves a family. :data:`FAMILY` spans
a two-parameter one: links 6 and 8 pinned anywhere in their ranges, the four fitted dimensions
solved again, every member hits the four numbers. :func:`linkage_family` returns the members as
override dicts of pinclear.mechanisms.nine_bar.Dimensions; :func:`model_for` writes a member's
URDF and sidecar with the generator the committed urdf/nine_bar.* come from (the band machinery
varies the linkage through them).
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from pathlib import Path

import numpy as np

from pinclear.core.errors import InputError
from pinclear.mechanisms import nine_bar

#: paper 002 sec. 3.2 (and 3.4, the same numbers): the ideal slider's peaks, as printed
PRINTED = {"displacement peak": (0.115, "m", "0.115"), "instant of the displacement peak": (0.616, "s", "0.616"),
           "velocity peak": (0.653, "m/s", "0.653"), "instant of the velocity peak": (0.512, "s", "0.512")}
#: the fitted parameters (pinclear.mechanisms.nine_bar.Dimensions fields)
FREE = ("L1", "L4", "Hx", "Hy")
#: plausible ranges (m, rad): links of a bench linkage 0.1-0.5 m wide, cranks shorter than the
#: frame, the plate's angle between a right angle and 160 deg
BOUNDS = {"L4": (0.05, 0.15), "L3": (0.22, 0.45), "Hy": (0.35, 0.75), "L72": (0.10, 0.30),
          "beta": (math.radians(90.0), math.radians(160.0)), "L1": (0.05, 0.15), "L2": (0.22, 0.45),
          "L5": (0.25, 0.45), "Hx": (0.30, 0.70), "L6": (0.25, 0.55), "L71": (0.15, 0.40), "L8": (0.25, 0.55)}
#: the parameters that span the family and their ranges (m): beyond them the fit fails (link 6
#: shorter than 0.30 m cannot reach, link 8 longer than 0.48 m pushes the slider dyad's sine below
#: MIN_SINE)
FAMILY = {"L6": (0.30, 0.46), "L8": (0.40, 0.48)}
#: least transmission sine of the three dyads along the drive law (the reconstruction's criterion:
#: no dyad within 27 deg of a stretched or folded position)
MIN_SINE = 0.45
#: a member's fit above this largest residual (print precisions) is retried by continuation
FIT_RETRY = 0.01
#: samples per crank turn of the closed-form analysis (peaks refined by a parabola through the
#: three samples around the largest: its error is O(dt^3 y''') ~ 1e-9 of the values)
SAMPLES = 2000


def precision(name):
    """Print precision of the printed number ``name``: half a unit of its last digit."""
    _, _, printed = PRINTED[name]
    return 0.5 * 10.0 ** -len(printed.split(".")[1])


def _refined(t, y):
    """(|y| at its largest, its instant) by the parabola through the three samples around the
    largest |y| (uniform t)."""
    a = np.abs(y)
    if not np.all(np.isfinite(a)):
        return math.nan, math.nan
    i = int(np.argmax(a))
    if 0 < i < len(a) - 1:
        y0, y1, y2 = a[i - 1], a[i], a[i + 1]
        den = y0 - 2.0 * y1 + y2
        s = 0.5 * (y0 - y2) / den if den < 0.0 else 0.0
        return float(y1 - 0.25 * (y0 - y2) * s), float(t[i] + s * (t[1] - t[0]))
    return float(a[i]), float(t[i])


def ideal_peaks(d=nine_bar.DIMS, omega=nine_bar.OMEGA1):
    """The four printed quantities of the ideal linkage ``d`` (closed form, eq. 15) and the
    least dyad sine along the drive law: {name: value} with the names of :data:`PRINTED` and
    'least sine'. Velocity by central differences in time (h = 1e-6 s: error ~1e-10 m/s)."""
    period = 2.0 * math.pi / abs(omega)
    t = np.linspace(0.0, period, SAMPLES + 1)
    h = 1e-6

    def x(tt):
        return nine_bar.slider_positions(omega * tt + nine_bar.THETA1_0, -omega * tt + nine_bar.THETA4_0, d)

    xs, sines = x(t)
    v = (x(t + h)[0] - x(t - h)[0]) / (2.0 * h)
    dp, td = _refined(t, xs - xs[0])
    vp, tv = _refined(t, v)
    return {"displacement peak": dp, "instant of the displacement peak": td, "velocity peak": vp,
            "instant of the velocity peak": tv, "least sine": float(np.min(sines)) if np.all(np.isfinite(sines))
            else math.nan}


def residuals(d):
    """(ours - printed) / print precision of the four printed numbers (NaN if a dyad cannot close)."""
    p = ideal_peaks(d)
    return np.array([(p[k] - PRINTED[k][0]) / precision(k) for k in PRINTED])


def dimensions(overrides=None):
    """pinclear.mechanisms.nine_bar.Dimensions with ``overrides`` {field: value} applied."""
    overrides = dict(overrides or {})
    fields = {f.name for f in dataclasses.fields(nine_bar.Dimensions)}
    bad = sorted(set(overrides) - fields)
    if bad:
        raise InputError(f"linkage002: unknown dimension(s) {bad}", choices=sorted(fields))
    return dataclasses.replace(nine_bar.DIMS, **overrides)


def fit(free=FREE, fixed=None, start=None):
    """Least squares of :func:`residuals` over the ``free`` dimensions inside :data:`BOUNDS`,
    the others from ``fixed`` (then nine_bar.DIMS). A dyad whose sine along the law falls below
    :data:`MIN_SINE` costs a penalty that grows with the shortfall. Returns (overrides of the
    free and fixed fields, info: residuals in print precisions, least sine, cost)."""
    from scipy.optimize import least_squares

    fixed = dict(fixed or {})
    base = dimensions(fixed)
    for f in free:
        if f not in BOUNDS:
            raise InputError(f"linkage002: no plausible range for {f!r}", choices=sorted(BOUNDS))
    lo = np.array([BOUNDS[f][0] for f in free])
    hi = np.array([BOUNDS[f][1] for f in free])
    x0 = np.clip(np.array([(start or {}).get(f, getattr(base, f)) for f in free]), lo, hi)

    def fun(x):
        d = dataclasses.replace(base, **dict(zip(free, x.tolist())))
        p = ideal_peaks(d)
        r = np.array([(p[k] - PRINTED[k][0]) / precision(k) for k in PRINTED])
        short = MIN_SINE - p["least sine"] if np.isfinite(p["least sine"]) else 1.0
        r = np.where(np.isfinite(r), r, 1e3)
        return np.append(r, 1e3 * max(short, 0.0))

    sol = least_squares(fun, x0, bounds=(lo, hi), x_scale=hi - lo, diff_step=1e-7, xtol=1e-12, ftol=1e-12)
    over = {**fixed, **{f: float(v) for f, v in zip(free, sol.x)}}
    d = dimensions(over)
    p = ideal_peaks(d)
    return over, {"residuals": residuals(d).tolist(), "least sine": p["least sine"], "peaks": p,
                  "max |residual|": float(np.max(np.abs(residuals(d))))}


def _key(over):
    return json.dumps({k: round(float(v), 12) for k, v in sorted(over.items())})


_MEMBERS = {}


def member(pinned):
    """The family member with the :data:`FAMILY` parameters ``pinned`` {name: value}: (overrides
    of the pinned and fitted dimensions, info of :func:`fit`), the fit started from the nominal
    linkage with the pivot H moved by link 6's change of length (link 6 runs near the x axis, so H
    follows its length: without the move, a short link 6 starts where it cannot reach the plate).
    Cached: a fit takes a fraction of a second."""
    bad = sorted(set(pinned) - set(FAMILY))
    if bad:
        raise InputError(f"linkage002: {bad} do not span the family", choices=sorted(FAMILY))
    k = _key(pinned)
    if k not in _MEMBERS:
        start = {f: getattr(nine_bar.DIMS, f) for f in FREE}
        start["Hx"] += pinned.get("L6", nine_bar.DIMS.L6) - nine_bar.DIMS.L6
        got = fit(FREE, fixed=dict(pinned), start=start)
        if got[1]["max |residual|"] > FIT_RETRY:
            # the peaks are sampled maxima, so the least squares' finite differences see a rough
            # cost and round-off can strand a start in a local minimum (one member on one machine):
            # continue from the fit half-way between the nominal links 6 and 8 and the pinned ones
            half = {f: 0.5 * (getattr(nine_bar.DIMS, f) + v) for f, v in pinned.items()}
            mid = member(half)[0]
            again = fit(FREE, fixed=dict(pinned), start={f: mid[f] for f in FREE})
            got = min(got, again, key=lambda g: g[1]["max |residual|"])
        _MEMBERS[k] = got
    return _MEMBERS[k]


def family_points(n=3):
    """The pinned values of an n x n grid over :data:`FAMILY`'s ranges (corners and centre
    included for odd n)."""
    if n < 1:
        raise InputError(f"linkage002: the family's grid needs n >= 1, got {n}")
    axes = [np.linspace(lo, hi, n) if n > 1 else np.array([0.5 * (lo + hi)]) for lo, hi in FAMILY.values()]
    return [dict(zip(FAMILY, (float(a), float(b)))) for a in axes[0] for b in axes[1]]


def linkage_family(n=3, tol=0.05):
    """Override dicts {Dimensions field: value} of the linkages that hit the four printed numbers:
    an n x n grid over :data:`FAMILY`, each member's :data:`FREE` dimensions fitted; members whose
    largest residual exceeds ``tol`` print precisions or whose least sine falls below
    :data:`MIN_SINE` are left out (:func:`family_table` lists them all)."""
    out = []
    for pinned in family_points(n):
        over, info = member(pinned)
        if info["max |residual|"] <= tol and info["least sine"] >= MIN_SINE - 1e-9:
            out.append(over)
    return out


def family_table(n=3):
    """The family as a report table: pinned and fitted dimensions, residuals, least sine."""
    rows = []
    for pinned in family_points(n):
        over, info = member(pinned)
        rows.append([*(1e3 * over[f] for f in FAMILY), *(1e3 * over[f] for f in FREE),
                     float(info["max |residual|"]), float(info["least sine"])])
    nominal = residuals(nine_bar.DIMS)
    return {"title": "paper 002's linkage fitted to its printed ideal slider peaks (0.115 m at 0.616 s, 0.653 m/s at "
                     "0.512 s): the family of linkages that hit them",
            "columns": [*(f"{f} [mm] (pinned)" for f in FAMILY), *(f"{f} [mm] (fitted)" for f in FREE),
                        "largest |residual| [print precisions]", "least dyad sine"],
            "rows": rows,
            "note": ("residuals in units of the print precision (0.0005 m, s, m/s); the nominal linkage "
                     f"(urdf/nine_bar.*): residuals {', '.join(f'{r:+.2g}' for r in nominal)} "
                     "(displacement peak, its instant, velocity peak, its instant; the dimensions rounded to "
                     "0.1 um); pinclear.studies.reproduce.linkage002.linkage_family returns the members as "
                     "override dicts")}


def model_for(overrides, folder):
    """Path of the sidecar (urdf/nine_bar.yaml's generator, pinclear.mechanisms.nine_bar) of
    the linkage with ``overrides``, written under ``folder`` in a subfolder named by the
    overrides' digest (written once; the sidecar names its URDF ``nine_bar.urdf`` beside it)."""
    d = dimensions(overrides)
    sub = Path(folder) / ("nine_bar_" + hashlib.sha256(_key(overrides).encode()).hexdigest()[:12])
    sidecar = sub / "nine_bar.yaml"
    if not sidecar.exists():
        sub.mkdir(parents=True, exist_ok=True)
        nine_bar.write_urdf(sub / "nine_bar.urdf", d)
        nine_bar.write_sidecar(sidecar, d)
    return sidecar
