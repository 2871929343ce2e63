"""Verdicts that can fail: each compared number of a reproduction gets one of six classes.

For a row with our band B = [lo, hi] (the spread of our result over the plausible range of the
reconstructed inputs, docs/papers.md), the paper's value p and a tolerance tau, the class is the
first that applies:

* ``calibration``    the row was used to choose a reconstruction: it does not count;
* ``not comparable`` our quantity is not the paper's (another instant, regime or input);
* ``contradicted``   p lies further than tau from B: no plausible input reaches it;
* ``reproduced``     p lies within tau of B, and B is no wider than 2 tau;
* ``undecided``      p lies within tau of B, but B is wider than 2 tau: the lost inputs decide it;
* ``not measured``   B was not measured (one run, nothing varied): the row can neither reproduce nor
                     contradict; it states the CPU its band would need.

tau = max(the paper's reading precision, the quantity's tolerance in :data:`TOLERANCES`). The
table of tolerances lives here and only here: a change to it is a visible commit.

A band that was not measured can neither reproduce nor contradict: such a row is
``not measured``, kept apart from ``undecided`` (a measured band too wide to decide), and says what
measuring it would cost; ``pinclear reproduce --bands`` measures the bands
(pinclear.studies.reproduce.bands). Every row also carries its nominal verdict, ours at the
nominal inputs against the paper ("+213 %, 21 τ at nominal"): what the row would say were the
band a point, never counted. A categorical row (a kind of motion: period-1,
quasi-periodic, chaotic) has as band the set of kinds seen over the varied inputs: contradicted
when the paper's kind is not in it, reproduced when it is the only one, undecided otherwise.
"""
from __future__ import annotations

import math

from pinclear.core.errors import InputError

CLASSES = ("calibration", "not comparable", "contradicted", "reproduced", "undecided", "not measured")

#: per-quantity tolerance (relative to the paper's value) and its reason, stated before any run.
#: It is the resolution at which a difference is called a difference: the numerical error of our
#: measurement of that quantity plus what the paper's method resolves. The spread that the lost
#: inputs cause is NOT in here: that is the band.
TOLERANCES = {
    "load force": (0.05, "a contact force that follows the joint's steady load: two rigid-body models of one "
                         "mechanism agree on it to a few per cent (the paper checks its model against ADAMS); "
                         "5 % also covers our 2 ms output grid on the high-frequency ringing"),
    "force span": (0.10, "a difference of two read extremes (max - min): the error of each adds"),
    "kinematic peak": (0.02, "a peak of a smooth motion of a given linkage: two codes agree to well below 1 %; "
                             "2 % covers reading the peak's instant on a 1e-4 s grid"),
    "instant": (0.02, "the time of a smooth peak: 2 % of the crank period is the width over which a smooth "
                      "peak changes by less than 0.1 %"),
    "impact peak": (0.10, "an impact spike: our peaks sampled every 1e-4 s lie within 1 % of those sampled every "
                          "2e-6 s (measured on the first impacts); the paper's integration step is not stated, "
                          "10 % covers a spike sampled at its step"),
    "influence coefficient": (0.02, "the paper's printed G violates J G = I by 1.6 % or more for any vertical "
                                    "reference point (J the limbs' rows from its Table 1, which fix the actuated "
                                    "columns): its entries carry that much error, and ours is exact"),
    "drive force peak": (0.05, "the paper reads its peaks off Figs. 7-9 and checks the last against ADAMS "
                               "(agreement 'basically consistent', Fig. 10); 5 %"),
    "force ratio": (0.01, "a ratio of two peaks of the same run family: our integration and grid errors "
                          "cancel to far below 1 %"),
    "platform deviation": (0.10, "an excursion of a few um to mm read off a figure: 10 %"),
    "velocity amplitude": (0.10, "an amplitude read off a figure: 10 %"),
    "acceleration peak": (0.10, "the slider's acceleration peak is an impact spike (as 'impact peak')"),
    "contact force peak": (0.10, "the largest contact force of a run is an impact spike (as 'impact peak')"),
    "threshold": (0.10, "a threshold in a swept parameter is known to half the sweep's step; 10 % of the value "
                        "is the least a reading of the paper's diagrams resolves"),
    "motion kind": (0.0, "a kind of motion (period-k, quasi-periodic, chaotic) is categorical"),
    "ordering": (0.0, "an ordering (which is larger) is categorical"),
}


def tolerance(quantity):
    """(relative tolerance, reason) of a quantity of :data:`TOLERANCES`."""
    if quantity not in TOLERANCES:
        raise InputError(f"verdicts: unknown quantity {quantity!r}", choices=sorted(TOLERANCES))
    return TOLERANCES[quantity]


def half_digit(printed):
    """Reading precision of a number printed as the string ``printed``: half a unit of its last
    digit ('122.5' -> 0.05, '2 080' -> 0.5, '85' -> 0.5)."""
    s = str(printed).replace(" ", "").lstrip("+-")
    if "." in s:
        return 0.5 * 10.0 ** -len(s.split(".")[1])
    return 0.5


def classify_numeric(band, paper, tau, measured):
    """The class of a numeric row (not a calibration, comparable): see the module docstring."""
    lo, hi = float(min(band)), float(max(band))
    if not all(math.isfinite(x) for x in (lo, hi, paper, tau)):
        return "undecided"
    gap = max(lo - paper, paper - hi, 0.0)
    if not measured:
        return "not measured"
    if gap > tau:
        return "contradicted"
    return "reproduced" if hi - lo <= 2.0 * tau else "undecided"


#: kinds of ours that may be the paper's kind but do not confirm it: 'irregular' is the 0-1 test's
#: chaos without a confirmed Lyapunov exponent (pinclear.analysis.classify)
UNCONFIRMED = {"irregular": "chaotic"}


def classify_kind(kinds, paper, measured):
    """The class of a categorical row: ``kinds`` the set of our kinds over the band."""
    kinds = set(kinds)
    if not measured:
        return "not measured"
    if not kinds:
        return "undecided"
    if paper not in kinds:
        maybe = any(UNCONFIRMED.get(k) == paper for k in kinds)
        return "undecided" if maybe else "contradicted"
    return "reproduced" if kinds == {paper} else "undecided"


def row(name, quantity, ours, paper, unit="", *, band=None, band_from="", printed=None, reading=None,
        status=None, group="", why="", cpu_s=None):
    """One row of a report.

    ours: our central value (a number, or for categorical quantities a kind or a set of kinds);
    band: (lo, hi) over the varied inputs (default: ``ours`` alone); band_from: what was varied to
    measure it ('' = not measured); printed: the paper's number as printed (its reading precision
    is half a unit of the last digit) or ``reading``: the precision given directly (same unit);
    status: 'calibration' or 'not comparable' (with ``why`` saying why), else None to classify;
    group: the key of the report's ``groups`` whose paragraph explains this row's differences;
    cpu_s: for a row whose band is not measured, the CPU seconds measuring it would take (the
    report's estimate: runs x one run's CPU), printed in ``why`` and kept as ``cpu_needed_s``.
    Every row gets ``nominal`` (:func:`nominal_text`) and ``nominal_verdict`` (the class a band
    of ours alone would get)."""
    if status not in (None, "calibration", "not comparable"):
        raise InputError(f"verdicts: a row's status is set only for calibration / not comparable, got {status!r}")
    rel, _ = tolerance(quantity)
    measured = bool(band_from)
    out = {"name": name, "quantity": quantity, "unit": unit, "group": group, "why": why, "band_from": band_from}
    if rel == 0.0 and quantity in ("motion kind", "ordering"):
        kinds = sorted(set(band if band is not None else ([ours] if isinstance(ours, str) else ours)))
        out.update(ours=ours if isinstance(ours, str) else ", ".join(sorted(ours)), paper=paper, band=kinds,
                   tau=0.0, deviation=None)
        out["verdict"] = status or classify_kind(kinds, paper, measured)
        nominal = [ours] if isinstance(ours, str) else sorted(set(ours))
        out["nominal_verdict"] = classify_kind(nominal, paper, True)
    else:
        ours, paper = float(ours), float(paper)
        lo, hi = (ours, ours) if band is None else (float(min(band)), float(max(band)))
        rp = half_digit(printed) if printed is not None else float(reading or 0.0)
        tau = max(rp, rel * abs(paper))
        out.update(ours=ours, paper=paper, band=[lo, hi], tau=tau,
                   deviation=(ours - paper) / abs(paper) if paper else None)
        out["verdict"] = status or classify_numeric((lo, hi), paper, tau, measured)
        out["nominal_verdict"] = classify_numeric((ours, ours), paper, tau, True)
    out["nominal"] = nominal_text(out)
    out["cpu_needed_s"] = None if cpu_s is None else float(cpu_s)
    if out["verdict"] == "not measured":
        cost = f"about {_cpu(cpu_s)} CPU, " if cpu_s is not None else ""
        out["why"] = (f"band not measured ({cost}pinclear reproduce --bands); " + why).rstrip("; ")
    return out


def _cpu(seconds):
    """CPU seconds as a reader reads them: '40 s', '12 min', '3.2 h'."""
    s = float(seconds)
    if s < 120:
        return f"{s:.2g} s"
    return f"{s / 60:.0f} min" if s < 7200 else f"{s / 3600:.2g} h"


def nominal_text(r):
    """The nominal verdict of a row (a dict of :func:`row`): ours at the nominal inputs against the
    paper: '+213 %, 21 τ at nominal' (the deviation in per cent of the paper's value, |ours -
    paper| in units of tau; '0 τ' when equal), 'Δ = 3.2 N, 1.5 τ at nominal' when the paper's value
    is 0, the kinds '... at nominal' for a categorical row."""
    if isinstance(r["ours"], str):
        return f"{r['ours']} at nominal"
    diff = r["ours"] - r["paper"]
    if r["tau"] > 0:
        k = abs(diff) / r["tau"]
        taus = f"{k:.0f} τ" if k >= 10 else f"{k:.1f} τ"
    else:
        taus = "τ = 0"
    if r["paper"]:
        pct = 100.0 * diff / abs(r["paper"])
        return f"{pct:+.0f} %, {taus} at nominal" if abs(pct) >= 10 else f"{pct:+.1f} %, {taus} at nominal"
    return f"Δ = {diff:.3g}{(' ' + r['unit']) if r['unit'] else ''}, {taus} at nominal"


def counts(rows):
    """{class: number of rows} in the order of :data:`CLASSES` (every class listed)."""
    c = {k: 0 for k in CLASSES}
    for r in rows:
        c[r["verdict"]] += 1
    return c


def summary(rows):
    """One line: '3 reproduced, 2 contradicted, ...' (classes with no row left out)."""
    c = counts(rows)
    parts = [f"{n} {k}" for k, n in c.items() if n]
    return ", ".join(parts) + f" ({len(rows)} rows; calibration rows do not count)" if parts else "no rows"
