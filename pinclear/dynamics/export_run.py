"""A run's samples for other programs: CSV (one column per scalar channel,
MATLAB's readtable, spreadsheets, ADAMS's spline import) and MATLAB's .mat (scipy.io.savemat).

Both hold the same channels (:func:`columns`), SI units and radians throughout:

* ``t`` (s); ``q.NAME`` / ``v.NAME`` / ``a.NAME`` per configuration coordinate and dof (m or
  rad, m/s or rad/s, m/s^2 or rad/s^2; a joint with several coordinates as ``NAME[k]``);
* ``lam.NAME`` per constraint row (the multipliers: N or N m; a drive row's is its force);
* ``out.ELEMENT.OUTPUT`` (``[k]`` per component) as the force elements record them
  (pinclear.analysis.signals.OUTPUT_UNITS); ``energy.NAME`` (J, or W for powers);
  ``residual`` (the closure rows' |Phi|_inf) and ``drive_error``.

The CSV writes each number as its shortest round-trip decimal (Python's repr: reading it back
gives the same double), NaN as ``nan``. The .mat file holds matrices ``t``, ``q``, ``v``, ``a``,
``z``, ``lam``, ``outputs``, ``energies`` with the column names beside them (``q_names``,
``lam_names``, ...: MATLAB cell arrays of strings), ``columns`` (every CSV column, in order)
and ``meta_json``: the run's metadata (versions, summary) as a JSON text.
"""
from __future__ import annotations

import io
import json

import numpy as np

from pinclear.core import safeio
from pinclear.core.jsonsafe import jsonable


def _coordinate_names(traj, kind: str, n: int) -> list[str]:
    """Names of the q (kind 'q') or v/a columns: the joint's name, ``NAME[k]`` for a joint with
    several; from the mechanism when loaded, else the recorded joint names when each has one
    column, else ``q[i]``."""
    mech = traj.mech
    if mech is not None:
        model = mech.model
        names = []
        for j in range(1, model.njoints):
            size = model.joints[j].nq if kind == "q" else model.joints[j].nv
            names += [model.names[j]] if size == 1 else [f"{model.names[j]}[{k}]" for k in range(size)]
        if len(names) == n:
            return names
    if kind != "q":
        acc = list((traj.stats.get("peaks") or {}).get("accelerations") or {})
        if len(acc) == n:
            return acc
    joints = (traj.meta.get("mechanism") or {}).get("joints")
    if isinstance(joints, list) and len(joints) == n and all(isinstance(x, str) for x in joints):
        return list(joints)
    return [f"{kind}[{i}]" for i in range(n)]


def _split(prefix, name, arr):
    """(column name, 1-D array) of one channel: a vector channel per component."""
    a = np.asarray(arr, float)
    if a.ndim == 1:
        return [(f"{prefix}{name}", a)]
    a = a.reshape(len(a), -1)
    if a.shape[1] == 1:
        return [(f"{prefix}{name}", a[:, 0])]
    return [(f"{prefix}{name}[{k}]", a[:, k]) for k in range(a.shape[1])]


def groups(traj) -> dict:
    """{group: [(column name, 1-D array)]}, the groups in the order the CSV writes them."""
    n = len(traj.t)
    g = {"t": [("t", np.asarray(traj.t, float))]}
    for kind in ("q", "v", "a"):
        X = np.asarray(getattr(traj, kind), float).reshape(n, -1)
        g[kind] = [(f"{kind}.{nm}", X[:, i]) for i, nm in enumerate(_coordinate_names(traj, kind, X.shape[1]))]
    Z = np.asarray(traj.z, float).reshape(n, -1)
    g["z"] = [(f"z[{i}]", Z[:, i]) for i in range(Z.shape[1])]
    g["lam"] = [(f"lam.{k}", np.asarray(v, float)) for k, v in traj.lam.items()]
    g["outputs"] = [c for k, v in traj.outputs.items() for c in _split("out.", k, v)]
    g["energies"] = [c for k, v in traj.energies.items() for c in _split("energy.", k, v)]
    g["residual"] = [("residual", np.asarray(traj.residual, float))]
    if len(traj.drive_error) == n:
        g["drive_error"] = [("drive_error", np.asarray(traj.drive_error, float))]
    return g


def columns(traj) -> list[tuple[str, np.ndarray]]:
    """Every exported channel as (name, 1-D array over the samples), in the CSV's order."""
    return [c for cols in groups(traj).values() for c in cols]


def csv_text(traj) -> str:
    """The CSV: a header of column names, one row per sample, shortest round-trip decimals."""
    cols = columns(traj)
    for name, _ in cols:
        if any(ch in name for ch in ',"\n\r'):
            from pinclear.core.errors import InputError

            raise InputError(f"export: channel name {name!r} holds a comma, a quote or a line break")
    buf = io.StringIO()
    buf.write(",".join(name for name, _ in cols) + "\n")
    M = np.column_stack([a for _, a in cols]) if cols else np.zeros((0, 0))
    for row in M.tolist():
        buf.write(",".join(map(repr, row)) + "\n")
    return buf.getvalue()


def write_csv(traj, path, root=None):
    """``path`` (link-safe, atomic: pinclear.core.safeio) holding :func:`csv_text`."""
    return safeio.write_text(path, csv_text(traj), root)


def mat_dict(traj) -> dict:
    """The .mat file's variables (see the module doc)."""
    g = groups(traj)
    n = len(traj.t)
    out = {}
    for key in ("t", "q", "v", "a", "z", "lam", "outputs", "energies", "residual", "drive_error"):
        cols = g.get(key, [])
        out[key] = np.column_stack([a for _, a in cols]) if cols else np.zeros((n, 0))
        if key not in ("t", "residual", "drive_error"):
            out[f"{key}_names"] = np.array([nm for nm, _ in cols], dtype=object).reshape(-1, 1)
    out["columns"] = np.array([nm for nm, _ in columns(traj)], dtype=object).reshape(-1, 1)
    meta = dict(traj.meta, status=traj.status, message=traj.message)
    out["meta_json"] = json.dumps(jsonable(meta), default=str)
    return out


def write_mat(traj, path, root=None):
    """``path`` as MATLAB 5 .mat (scipy.io.savemat; MATLAB's load, Octave, scipy.io.loadmat),
    written link-safely and atomically."""
    from scipy.io import savemat

    data = mat_dict(traj)
    return safeio.write_atomic(path, lambda fh: savemat(fh, data, do_compression=True), root=root)
