"""Trajectory: the one result object of a simulation (after SciPy's OdeResult)."""
from __future__ import annotations

import json
import platform
from pathlib import Path

import numpy as np
import pinocchio as pin

from . import kinematics


def _versions():
    import scipy

    from . import __version__

    return {"pinclear": __version__, "pinocchio": pin.__version__, "numpy": np.__version__,
            "scipy": scipy.__version__, "python": platform.python_version()}


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, (np.floating, np.integer, np.bool_)):
        return x.item()
    if isinstance(x, (str, int, float, bool)) or x is None:
        return x
    return repr(x)


class Trajectory:
    """Samples of a run: t, q, v, a, lam (by name), residual, outputs, energy, stats, status."""

    def __init__(self):
        self.t = np.zeros(0)
        self.q = self.v = self.a = np.zeros((0, 0))
        self.z = np.zeros((0, 0))
        self.lam: dict[str, np.ndarray] = {}
        self.residual = np.zeros(0)
        self.outputs: dict[str, np.ndarray] = {}
        self.energies: dict[str, np.ndarray] = {}
        self.stats: dict = {}
        self.status, self.message = "empty", ""
        self.meta: dict = {}
        self.mech = None
        self.mech_path = None

    # ------------------------------------------------------------------ building
    @classmethod
    def empty(cls, mech, form, integrator, rtol, atol, t_eval):
        tr = cls()
        tr.mech, tr.mech_path = mech, mech.path
        tr.stats = {"rhs_evals": 0, "steps": 0, "restarts": 0, "events": [], "cpu_s": 0.0}
        tr.meta = {"mechanism": mech.describe(), "method": form.describe(), "integrator": integrator,
                   "rtol": rtol, "atol": atol if np.isscalar(atol) else list(np.ravel(atol)),
                   "t_requested": [float(t_eval[0]), float(t_eval[-1]), len(t_eval)],
                   "options": mech.options, "versions": _versions()}
        return tr

    def fill(self, samples, sysf):
        """Evaluate accelerations, multipliers, residuals, outputs and energies at the samples."""
        mech, form = sysf.mech, sysf.form
        ws = form.ws
        n = len(samples)
        self.t = np.array([s[0] for s in samples], float)
        self.q = np.zeros((n, mech.nq))
        self.v = np.zeros((n, mech.nv))
        self.a = np.zeros((n, mech.nv))
        self.z = np.zeros((n, mech.nz))
        lam = np.zeros((n, mech.m))
        self.residual = np.zeros(n)
        self.drive_error = np.zeros(n)
        E = {k: np.zeros(n) for k in ("kinetic", "potential", "spring", "dissipated_power")}
        outs: dict[str, list] = {}
        model = mech.model
        for i, (t, x, anchor) in enumerate(samples):
            if anchor is not None:
                sysf.anchor = anchor
            q, v, z = sysf.split(x)
            self.q[i], self.v[i], self.z[i] = q, v, z
            try:
                self.a[i] = form.accelerations(t, q, v, z)
                lam[i] = ws.lam
            except Exception:               # a failed sample keeps NaN, the run's message says why
                self.a[i] = np.nan
                lam[i] = np.nan
            kinematics.update(mech, ws, q, v)
            ws.q_cur = q
            kinematics.constraint_rows(mech, ws, t, v)
            mc = mech.compiled.m
            self.residual[i] = np.linalg.norm(ws.phi[:mc], np.inf) if mc else 0.0
            if mech.drives:
                self.drive_error[i] = np.abs(ws.phi[mc:]).max()
            E["kinetic"][i] = pin.computeKineticEnergy(model, ws.data, q, v)
            E["potential"][i] = pin.computePotentialEnergy(model, ws.data, q)
            for f, sl in zip(mech.forces, mech.z_slices):
                E["spring"][i] += f.potential(mech, ws, q)
                E["dissipated_power"][i] += f.power_loss(mech, ws, t, q, v, z[sl])
                for k, val in f.outputs(mech, ws, t, q, v, z[sl]).items():
                    outs.setdefault(f"{f.name}.{k}", []).append(np.asarray(val, float))
        names = mech.row_names()
        self.lam = {nm: lam[:, k] for k, nm in enumerate(names)}
        self.outputs = {k: np.array(v) for k, v in outs.items()}
        self.energies = E
        if self.status != "success" and n:
            self.message += f" (samples kept up to t = {self.t[-1]:.6g} s)"

    # ------------------------------------------------------------------ results
    def closure_residual(self):
        return self.residual

    def energy(self) -> dict:
        E = dict(self.energies)
        E["total"] = E["kinetic"] + E["potential"] + E["spring"]
        return E

    def drive_forces(self) -> dict:
        if self.mech is None:
            names = self.meta["mechanism"]["drives"]
            return {d["name"]: self.lam[d["name"]] for d in names}
        return {d.name: self.lam[d.name] for d in self.mech.drives}

    def tracking_error(self) -> dict:
        """Drive coordinates vs their laws; platform pose vs its prescribed motion (if any)."""
        res = {}
        if len(self.drive_error) and self.mech is not None and self.mech.drives:
            res["drives"] = float(np.max(self.drive_error))
        mech = self.mech
        if mech is not None and mech.platform_frame is not None and mech.platform_motion is not None:
            ws = mech.workspace()
            ep, er = 0.0, 0.0
            for t, q in zip(self.t, self.q):
                pin.framesForwardKinematics(mech.model, ws.data, q)
                M = ws.data.oMf[mech.platform_frame]
                Mref = mech.platform_motion(t)
                if isinstance(Mref, tuple):
                    Mref = Mref[0]
                ep = max(ep, float(np.linalg.norm(M.translation - Mref.translation)))
                er = max(er, float(np.linalg.norm(pin.log3(Mref.rotation.T @ M.rotation))))
            res["platform_position"] = ep
            res["platform_rotation"] = er
        return res

    def summary(self) -> dict:
        s = {"status": self.status, "message": self.message, "t_end": float(self.t[-1]) if len(self.t) else None,
             "samples": len(self.t),
             "max_closure_residual": float(np.max(self.residual)) if len(self.residual) else None,
             "rhs_evals": self.stats.get("rhs_evals"), "steps": self.stats.get("steps"),
             "cpu_s": self.stats.get("cpu_s"), "events": len(self.stats.get("events", [])),
             "method": self.meta.get("method", {}).get("method"), "integrator": self.meta.get("integrator"),
             "rtol": self.meta.get("rtol")}
        for k in ("mobility", "redundant_constraints", "redundant_rows", "rank_loss", "cpu_per_sim_s"):
            if k in self.stats:
                s[k] = self.stats[k]
        if self.mech is not None and len(self.t):
            conservative = self.mech.conservative
            s["conservative"] = conservative
            if conservative:
                E = self.energy()["total"]
                scale = max(abs(E[0]), float(np.max(self.energies["kinetic"])), 1e-300)
                s["energy_drift_rel"] = float(np.max(np.abs(E - E[0])) / scale)
            te = self.tracking_error()
            if te:
                s["tracking_error"] = te
        return _jsonable(s)

    # ------------------------------------------------------------------ I/O
    def save(self, path):
        """NPZ with every array + JSON metadata (versions, parameters, method options, stats)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        arrays = {"t": self.t, "q": self.q, "v": self.v, "a": self.a, "z": self.z, "residual": self.residual}
        for k, v in self.lam.items():
            arrays[f"lam/{k}"] = v
        for k, v in self.outputs.items():
            arrays[f"out/{k}"] = v
        for k, v in self.energies.items():
            arrays[f"energy/{k}"] = v
        meta = dict(self.meta, status=self.status, message=self.message, stats=self.stats,
                    mech_path=str(Path(self.mech_path).resolve()) if self.mech_path else None,
                    load_args=getattr(self.mech, "load_args", None),
                    lam_names=list(self.lam), summary=self.summary())
        if self.mech is not None:
            meta["parameters"] = self.mech.parameters
        arrays["meta"] = np.array(json.dumps(_jsonable(meta)))
        np.savez_compressed(path, **arrays)
        return path

    @classmethod
    def load(cls, path, mech=None):
        d = np.load(path, allow_pickle=False)
        tr = cls()
        meta = json.loads(str(d["meta"]))
        tr.meta, tr.status, tr.message, tr.stats = meta, meta["status"], meta["message"], meta["stats"]
        tr.mech_path = meta.get("mech_path")
        for k in ("t", "q", "v", "a", "z", "residual"):
            setattr(tr, k, d[k])
        tr.lam = {k: d[f"lam/{k}"] for k in meta["lam_names"]}
        tr.outputs = {k[4:]: d[k] for k in d.files if k.startswith("out/")}
        tr.energies = {k[7:]: d[k] for k in d.files if k.startswith("energy/")}
        tr.mech = mech
        return tr

    def load_mechanism(self):
        """The mechanism this run used, loaded again with the same options, overrides and
        active clearances (from the saved metadata)."""
        from .sidecar import load

        la = self.meta.get("load_args") or {}
        path = la.get("path") or self.mech_path
        if path is None:
            from .errors import ModelFileError

            raise ModelFileError("<trajectory>", "mech_path", "the run does not name its mechanism file")
        self.mech = load(path, options=la.get("options") or None, overrides=la.get("overrides") or None,
                         clearances=la.get("clearances") or None)
        return self.mech

    def __repr__(self):
        return (f"Trajectory({self.status}, {len(self.t)} samples, t = [{self.t[:1]}, {self.t[-1:]}], "
                f"rhs_evals={self.stats.get('rhs_evals')})")
