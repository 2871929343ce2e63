"""Which force elements are clearance joints: of a live mechanism (``el.is_clearance``) or of a
saved run whose mechanism is not loaded (the element types recorded in its metadata).  The
only place the viewer and the plots tell clearance joints apart."""
from __future__ import annotations

from pinclear.core.registry import CLEARANCE_TYPES


def active_clearances(mech) -> list:
    """The force elements of ``mech`` that are clearance joints."""
    return [el for el in (getattr(mech, "forces", None) or ()) if el.is_clearance]


def clearance_plot(kind):
    """How clearance type ``kind`` is drawn (pinclear.core.registry.ClearancePlot), or None for a type
    not registered (a run saved by a newer pinclear)."""
    return CLEARANCE_TYPES.get(kind).plot if kind in CLEARANCE_TYPES else None


def clearance_size(el):
    """Radial clearance c of a ball or journal, or the gaps (c1, c2) across a slider's guide
    (the type's ClearancePlot.boundary says which)."""
    plot = clearance_plot(el.kind)
    return (float(el.c1), float(el.c2)) if plot is not None and plot.boundary == "rectangle" else float(el.c)


def recorded_clearances(meta) -> dict[str, dict]:
    """name -> recorded description (``type`` = spherical / revolute / planar_revolute /
    prismatic, and ``clearance`` when recorded) of the clearance joints active in a saved run,
    from ``traj.meta["mechanism"]["forces"]``."""
    mech = (meta or {}).get("mechanism") if isinstance(meta, dict) else None
    forces = (mech or {}).get("forces") if isinstance(mech, dict) else None
    return {f["name"]: f for f in (forces or [])
            if isinstance(f, dict) and isinstance(f.get("name"), str) and f.get("type") in CLEARANCE_TYPES}


def run_clearances(traj) -> dict[str, str]:
    """name -> kind of the clearance joints of a run: from its mechanism when one is attached
    (``traj.mech``), else from the recorded metadata."""
    mech = getattr(traj, "mech", None)
    if mech is not None:
        return {el.name: el.kind for el in active_clearances(mech)}
    return {n: f["type"] for n, f in recorded_clearances(getattr(traj, "meta", None)).items()}
