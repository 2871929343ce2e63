"""Drives: a 1-DoF tree joint's coordinate follows a time law, enforced as a constraint row
q_j - f(t) = 0 whose multiplier is the actuator's generalized force."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pinclear.model.timelaws import TimeLaw, eval_laws


def _readonly(a):
    a.flags.writeable = False
    return a


@dataclass(frozen=True)
class Drive:
    name: str
    joint: str
    idx_q: int
    idx_v: int
    law: TimeLaw


class DriveData:
    """Per-workspace drive buffers: law values (3, nd). No cache by time: a run's compiled
    stages write these values too, so a value remembered by time would go stale."""

    def __init__(self, nd, ngroups):
        self.f = np.zeros((3, nd))


class DriveRows:
    """Vectorised drive rows: phi = q[iq] - f(t), dphi = v[iv] - f'(t), f''(t). Immutable; the
    values live in a :class:`DriveData` of the workspace."""

    def __init__(self, drives: list[Drive], nv: int):
        self.drives = tuple(drives)
        self.iq = np.array([d.idx_q for d in drives], dtype=np.int64)
        self.iv = np.array([d.idx_v for d in drives], dtype=np.int64)
        self.J = np.zeros((len(drives), nv))
        self.J[np.arange(len(drives)), self.iv] = 1.0
        self.J.flags.writeable = False
        # drives whose laws are components of one shared vector function (e.g. every limb length
        # from one inverse kinematics) are filled together: one call per time, one fancy-index copy
        groups: dict = {}
        single = []
        for k, d in enumerate(drives):
            key = d.law.share_key
            if key is not None:
                g = groups.setdefault(key, (d.law, [], []))
                g[1].append(k)
                g[2].append(d.law.index)
            else:
                single.append((k, d.law))
        # laws with a compiled form (constant, sines, polynomial) are evaluated in one call
        compiled = [(k, law, law.kernel_params()) for k, law in single if law.kernel_params() is not None]
        self.single = tuple((k, law) for k, law in single if law.kernel_params() is None)
        P, starts = [], [0]
        for _, _, (code, par) in compiled:
            P.extend(float(x) for x in par)
            starts.append(len(P))
        self.law_table = None
        if compiled:
            self.law_table = tuple(_readonly(x) for x in (
                np.array([c[2][0] for c in compiled], dtype=np.int64), np.array(starts, dtype=np.int64),
                np.array(P + [0.0], float), np.array([c[0] for c in compiled], dtype=np.int64)))
        nd = len(drives)
        # a group holding every drive, in the function's component order, whose function has a
        # compiled twin writes straight into the values array: one compiled call per time
        # (its fill(t, f) bound once: this runs at every new time of a run)
        self.groups = tuple((law, np.array(ks), np.array(ix),
                             law.filler() if ks == list(range(nd)) and ix == list(range(nd)) else None)
                            for law, ks, ix in groups.values())

    def create_data(self) -> DriveData:
        return DriveData(len(self.drives), len(self.groups))

    def values(self, t, d: DriveData):
        """(3, nd) law values, first and second derivatives at t (written into ``d.f``)."""
        f = d.f
        for law, ks, ix, direct in self.groups:
            if direct is not None:
                direct(t, f)
            else:
                y, yd, ydd = law.vector(t)
                f[0, ks], f[1, ks], f[2, ks] = y[ix], yd[ix], ydd[ix]
        lt = self.law_table
        if lt is not None:
            eval_laws(lt[0], lt[1], lt[2], float(t), lt[3], f)
        for k, law in self.single:
            f[:, k] = law.eval(t)
        return f

    def stages(self, d: DriveData, errors) -> tuple:
        """The stages filling ``d.f`` at the evaluation time in a run (pinclear.dynamics.stepping): one
        compiled call for the compiled laws (constant, sines, polynomial), one per shared vector
        function with a compiled filler (``func.kernel``) covering every drive, and a Python
        stage for the rest (at Python's cost: the laws' functions run through a C callback)."""
        from pinclear.core.stage import T, bind, python_stage

        out = []
        python_groups = []
        for g, (law, ks, ix, direct) in enumerate(self.groups):
            made = law.compiled_filler() if direct is not None else None
            if made is None:
                python_groups.append(g)
                continue
            kernel, args = made
            out.append(bind(kernel, (T,) + tuple(args) + (d.f,), name=f"drive law {law.name}"))
        if self.law_table is not None:
            lt = self.law_table
            out.append(bind(eval_laws, (lt[0], lt[1], lt[2], T, lt[3], d.f), name="drive laws"))
        if python_groups or self.single:
            def python_laws(t):
                f = d.f
                for g in python_groups:
                    law, ks, ix, _ = self.groups[g]
                    y, yd, ydd = law.vector(t)
                    f[0, ks], f[1, ks], f[2, ks] = y[ix], yd[ix], ydd[ix]
                for k, law in self.single:
                    f[:, k] = law.eval(t)
                return np.inf
            names = [self.groups[g][0].name for g in python_groups] + [self.drives[k].name for k, _ in self.single]
            out.append(python_stage(python_laws, errors, name=f"python drive laws ({', '.join(names)})"))
        return tuple(out)

    def rows(self, t, q, v, d: DriveData):
        f = self.values(t, d)
        return q[self.iq] - f[0], v[self.iv] - f[1], f[2]
