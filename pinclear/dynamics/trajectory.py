"""Trajectory: the one result object of a simulation (after SciPy's OdeResult)."""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

from pinclear.core.failures import Failure, FailureKind
from pinclear.core.jsonsafe import jsonable
from pinclear.model import kinematics


def _versions():
    """The run's provenance (pinclear.core.version.provenance): pinclear's version and commit, the
    versions of Pinocchio, NumPy, SciPy, Numba and Python."""
    from pinclear.core.version import provenance

    return provenance()


def _digest(mech):
    """The mechanism's identity (pinclear.dynamics.validate.mechanism_digest: its description with
    parameters, inertias and joint placements), None if it cannot be formed."""
    from pinclear.dynamics.validate import mechanism_digest

    try:
        return mechanism_digest(mech)
    except (AttributeError, TypeError, ValueError):
        return None


#: one implementation (pinclear.core.jsonsafe), under its old names here too
_jsonable = jsonable


@dataclass
class Checkpoint:
    """Where a run stood after an accepted step: enough to continue it exactly (same steps,
    same samples) with ``simulate(..., resume=checkpoint)``."""

    t0: float
    q: np.ndarray                # initial state of the run
    v: np.ndarray
    z: np.ndarray
    t: float                     # time of the last accepted step
    q_now: np.ndarray
    v_now: np.ndarray
    z_now: np.ndarray
    h_next: float | None         # the step the integrator would try next
    samples: list = field(default_factory=list)      # (t, q, v, z) output samples so far
    stats: dict = field(default_factory=dict)
    identity: dict | None = None  # the run it belongs to (pinclear.dynamics.validate.run_identity)
    path: str | None = None       # the file it was loaded from (named in errors)
    #: what the integrator carries from step to step beyond the state (ROS34PW2: its Jacobian;
    #: pinclear.dynamics.stepping.run.method_state), saved as arrays ``method/NAME``
    method_state: dict = field(default_factory=dict)

    def save(self, path):
        """NPZ, written atomically (a temporary file renamed into place)."""
        n = len(self.samples)
        arrays = {k: np.asarray(getattr(self, k), float) for k in ("q", "v", "z", "q_now", "v_now", "z_now")}
        arrays["ts"] = np.array([s[0] for s in self.samples], float)
        for i, k in enumerate(("qs", "vs", "zs")):
            arrays[k] = (np.array([s[i + 1] for s in self.samples], float) if n
                         else np.zeros((0, arrays[k[0]].size)))
        meta = {"t0": self.t0, "t": self.t, "h_next": self.h_next, "stats": self.stats, "identity": self.identity}
        arrays["meta"] = np.array(json.dumps(_jsonable(meta)))
        for k, a in (self.method_state or {}).items():
            arrays[f"method/{k}"] = np.asarray(a, float)
        return atomic_savez(path, arrays)

    @classmethod
    def load(cls, path):
        """A checkpoint written by :meth:`save`, checked as data (headers and sizes before
        loading, consistent shapes, finite values, JSON types); :func:`pinclear.dynamics.validate.
        check_checkpoint` then checks it against the mechanism and the run it is to continue."""
        from pinclear.dynamics import validate as V

        arrays = V.read_npz(path, "checkpoint")
        meta = V.read_meta(arrays, path, "checkpoint")
        for k in ("t0", "t", "h_next", "stats"):
            if k not in meta:
                raise V.file_error(path, f"metadata has no {k!r}: not a pinclear checkpoint")
        if not isinstance(meta["stats"], dict):
            raise V.file_error(path, "stats must be a mapping")
        vec = {k: V.real_array(arrays, k, path, 1) for k in ("q", "v", "z", "q_now", "v_now", "z_now")}
        ts = V.real_array(arrays, "ts", path, 1)
        n = len(ts)
        qs, vs, zs = (V.real_array(arrays, k, path, 2, rows=n, cols=vec[k[0]].size) for k in ("qs", "vs", "zs"))
        V.increasing(ts, path, "ts")
        samples = [(float(t), q, v, z) for t, q, v, z in zip(ts, qs, vs, zs)]
        identity = meta.get("identity")
        if not isinstance(identity, dict):
            raise V.file_error(path, "the checkpoint records no identity of its run (written by another program or an "
                               "older pinclear): it cannot be matched to a run, start the run again")
        return cls(t0=V.number(meta["t0"], path, "t0"), q=vec["q"], v=vec["v"], z=vec["z"],
                   t=V.number(meta["t"], path, "t"), q_now=vec["q_now"], v_now=vec["v_now"], z_now=vec["z_now"],
                   h_next=V.number(meta["h_next"], path, "h_next", positive=True, allow_none=True),
                   samples=samples, stats=dict(meta["stats"]), identity=identity, path=str(path),
                   method_state={k[7:]: V.real_array(arrays, k, path, arrays[k].ndim) for k in arrays
                                 if k.startswith("method/") and arrays[k].ndim in (1, 2)})


def atomic_savez(path, arrays: dict, root=None):
    """np.savez_compressed to a new temporary file in the target folder, then an atomic rename,
    never through a link (pinclear.core.safeio): a reader never sees half a file, and two runs
    writing one path never mix their contents."""
    from pinclear.core.safeio import savez

    return savez(path, arrays, root)


def atomic_write_text(path, text: str, root=None):
    """Text written link-safely to a temporary file beside ``path`` and renamed into place."""
    from pinclear.core.safeio import write_text

    return write_text(path, text, root)


#: the version of the layout of summary.json and of a saved run's metadata (``schema_version``),
#: raised when a key is renamed or changes meaning so a reader can tell which layout it holds: 2 named the energy audit's units
#: (error_rel, error_J, terms_absolute_J / terms_change_J; the older keys kept, ``aliases``) and
#: added ``versions``, ``units`` and ``peaks_after``
SUMMARY_SCHEMA = 2
#: the units of the summary's numbers whose key does not say them (summary["units"])
SUMMARY_UNITS = {"t_end": "s", "cpu_s": "s", "max_closure_residual": "m or rad (closure rows' |Phi|_inf)",
                 "drive_force_peaks": "N (prismatic drive) or N m (revolute drive)", "drive_force_peak_times": "s",
                 "contact_force_peaks": "N", "contact_force_peak_times": "s",
                 "acceleration_peaks": "m/s^2 or rad/s^2 per dof; t in s", "energy_drift_rel": "1 (of the run's energy)",
                 "energy_balance.t": "s", "energy_balance.terms_t": "s", "peaks_after.t_from": "s",
                 "tracking_error": "m (positions), rad (rotations)", "rtol": "1"}

#: the energy channels every saved run holds
ENERGY_KEYS = ("kinetic", "potential", "spring", "dissipated_power")
#: the statuses a run can end with
STATUSES = ("success", "failed", "interrupted", "empty")
#: the kinds of a run's failure (Trajectory.failure = Failure(kind, t, detail)), pinclear.core.failures
FAILURE_KINDS = tuple(k.value for k in FailureKind)


def _rows(V, arrays, key, path, n):
    a = arrays[key]
    if a.dtype.kind not in "fiub" or a.ndim < 1 or len(a) != n:
        raise V.file_error(path, f"array {key!r} has shape {a.shape} and dtype {a.dtype}, expected {n} rows of numbers")
    return np.asarray(a, float)


def _read_failure(V, rec, path):
    """Trajectory.failure from its saved record, checked as data."""
    if rec is None:
        return None
    if not isinstance(rec, dict) or set(rec) != {"kind", "t", "detail"}:
        raise V.file_error(path, "metadata 'failure': expected a mapping of kind, t, detail")
    if rec["kind"] not in FAILURE_KINDS:
        raise V.file_error(path, f"metadata 'failure.kind': {rec['kind']!r} is not a failure kind (valid: "
                           f"{', '.join(FAILURE_KINDS)})")
    if not isinstance(rec["detail"], str):
        raise V.file_error(path, "metadata 'failure.detail': expected a string")
    return Failure(FailureKind(rec["kind"]), V.number(rec["t"], path, "failure.t", allow_none=True), rec["detail"])


class Trajectory:
    """Samples of a run: t, q, v, a, lam (by name), residual, outputs, energy, stats, status."""

    def __init__(self):
        """An empty run (status "empty", no samples, no mechanism); :meth:`empty` and
        :meth:`load` make the ones a simulation or a file gives."""
        self.t = np.zeros(0)
        self.q = self.v = self.a = np.zeros((0, 0))
        self.z = np.zeros((0, 0))
        self.lam: dict[str, np.ndarray] = {}
        self.residual = np.zeros(0)
        self.drive_error = np.zeros(0)
        self.outputs: dict[str, np.ndarray] = {}
        self.energies: dict[str, np.ndarray] = {}
        self.stats: dict = {}
        self.status, self.message = "empty", ""
        #: why the run did not succeed, as data: a pinclear.core.failures.Failure (kind, time s, detail), or None
        self.failure = None
        self.meta: dict = {}
        self.mech = None
        self.mech_path = None

    # ------------------------------------------------------------------ building
    @classmethod
    def empty(cls, mech, form, integrator, rtol, atol, t_eval):
        """A run with no samples yet: its mechanism, zeroed statistics and the metadata every
        saved run carries (the mechanism's description and digest, the method, the tolerances,
        the requested times, the load options and the versions).

        Parameters
        ----------
        mech : Mechanism
            The mechanism being simulated (its ``path`` becomes ``mech_path``).
        form : Formulation
            The formulation object; its ``describe()`` is recorded as ``meta["method"]``.
        integrator : str
            The integrator's name (e.g. "RK45", "ROS34PW2", "RK4").
        rtol : float
            Relative tolerance [1].
        atol : float or array
            Absolute tolerance, one number or one per state component (recorded as a list).
        t_eval : array
            The requested output times [s]; first, last and count are recorded.

        Returns
        -------
        Trajectory
            Status "empty", no samples.
        """
        tr = cls()
        tr.mech, tr.mech_path = mech, mech.path
        tr.stats = {"rhs_evals": 0, "steps": 0, "restarts": 0, "events": [], "cpu_s": 0.0}
        tr.meta = {"mechanism": mech.describe(), "method": form.describe(), "integrator": integrator,
                   "rtol": rtol, "atol": atol if np.isscalar(atol) else list(np.ravel(atol)),
                   "t_requested": [float(t_eval[0]), float(t_eval[-1]), len(t_eval)],
                   "options": mech.options, "versions": _versions(),
                   "mechanism_digest": _digest(mech)}
        return tr

    def fill_states(self, samples):
        """Set the times and states of the samples, nothing evaluated: ``a``, ``residual`` and
        ``drive_error`` are NaN until :meth:`write_outputs` fills them.

        Parameters
        ----------
        samples : Samples
            pinclear.dynamics.stepping.outputs.Samples: arrays t [s], q (nq per row), v (nv per
            row) and z (the element and energy states, nz per row).
        """
        mech = self.mech
        n = len(samples.t)
        self.t = np.array(samples.t, float)
        self.q = np.array(samples.q, float).reshape(n, mech.nq)
        self.v = np.array(samples.v, float).reshape(n, mech.nv)
        self.z = np.array(samples.z, float).reshape(n, mech.nz)
        self.a = np.full((n, mech.nv), np.nan)
        self.residual = np.full(n, np.nan)
        self.drive_error = np.full(n, np.nan)

    def write_outputs(self, samples, outs):
        """Set the samples (t, q, v, z) and everything recorded at them: accelerations,
        multipliers by row name, residuals, the elements' outputs and the energies of the audit;
        samples whose evaluation failed are counted in ``stats["failed_samples"]``.

        Parameters
        ----------
        samples : Samples
            pinclear.dynamics.stepping.outputs.Samples (arrays t, q, v, z), as for
            :meth:`fill_states`.
        outs : Outputs
            pinclear.dynamics.stepping.outputs.Outputs, whole arrays: ``core`` (a, multipliers,
            constraint values, closure power, kinetic and potential energy per sample),
            ``elements`` (each force element's potential, loss and named outputs) and
            ``failures``.
        """
        mech = self.mech
        self.fill_states(samples)
        n, nv, m, mc = len(samples.t), mech.nv, mech.m, mech.compiled.m
        core = outs.core
        self.a = np.array(core[:, :nv])
        lam, absphi = core[:, nv:nv + m], np.abs(core[:, nv + m:nv + 2 * m])
        if n:
            self.residual[:] = absphi[:, :mc].max(axis=1) if mc else 0.0
            self.drive_error[:] = absphi[:, mc:].max(axis=1) if mech.drives else 0.0
        self.lam = {nm: np.array(lam[:, k]) for k, nm in enumerate(mech.row_names())}
        # power of the closure rows' forces (pinclear.dynamics.energy: Baumgarte drift), sampled
        E = {"closure_power": np.array(core[:, nv + 2 * m]), "kinetic": np.array(core[:, nv + 2 * m + 1]),
             "potential": np.array(core[:, nv + 2 * m + 2])}
        E["spring"], E["dissipated_power"], E["applied_power"] = np.zeros(n), np.zeros(n), np.zeros(n)
        self.outputs = {}
        for f, (pot, loss, named) in zip(mech.forces, outs.elements):
            E["spring"] += pot
            E["dissipated_power"] += loss
            if f.dissipation_state is None:      # integrated over the samples by the audit
                E["applied_power"] += loss
            self.outputs.update({f"{f.name}.{k}": np.array(val) for k, val in named.items()})
        # the integrated energy states of the audit (pinclear.dynamics.energy): dissipated energy of the
        # elements that integrate it, the work of the drive rows
        E["dissipated"] = np.zeros(n)
        for f, sl in zip(mech.forces, mech.z_slices):
            if f.dissipation_state is not None:
                E["dissipated"] += self.z[:, sl.start + f.dissipation_state]
        E["work_drives"] = self.z[:, mech.z_work.start].copy() if mech.n_work else np.zeros(n)
        self.energies = E
        if outs.failures:             # samples whose evaluation failed (NaN a, lam): named, not lost
            first = outs.failures[0]
            self.stats["failed_samples"] = {"count": len(outs.failures),
                                            "kinds": sorted({str(f.kind) for f in outs.failures}),
                                            "first": {"t": first.t, "kind": str(first.kind), "detail": first.detail}}
        if self.status != "success" and n:
            self.message += f" (samples kept up to t = {self.t[-1]:.6g} s)"

    # ------------------------------------------------------------------ results
    def closure_residual(self):
        """The closure residual per sample.

        Returns
        -------
        ndarray
            max |Phi| over the closure rows at each sample [m or rad, by row], 0 without
            closures; NaN where a sample could not be evaluated.
        """
        return self.residual

    def energy(self) -> dict:
        """The sampled energy channels with their total.

        Returns
        -------
        dict
            ``{name: array}``, a copy of :attr:`energies` (kinetic, potential, spring [J],
            dissipated_power, applied_power, closure_power [W], dissipated, work_drives [J])
            plus ``"total"`` = kinetic + potential + spring [J].
        """
        E = dict(self.energies)
        E["total"] = E["kinetic"] + E["potential"] + E["spring"]
        return E

    def energy_balance(self) -> dict:
        """The run's energy audit (pinclear.dynamics.energy.energy_balance).

        Returns
        -------
        dict
            What pinclear.dynamics.energy.energy_balance returns: ``error_rel`` and
            ``error_J`` (the largest drift of the balance, relative to ``scale_J`` and in J),
            ``t`` [s] where it lies, ``bound_rel``/``bound_J`` (what the tolerances allow),
            ``ok`` (error <= bound), ``scale_J`` and the balance's terms [J].
        """
        from pinclear.dynamics.energy import energy_balance

        return energy_balance(self)

    def drive_forces(self) -> dict:
        """The drive rows' multipliers by drive name (from the recorded mechanism description when
        the run has no mechanism attached).

        Returns
        -------
        dict
            ``{drive: array}``, one value per sample [N for a prismatic drive, N m for a
            revolute one].
        """
        if self.mech is None:
            names = self.meta["mechanism"]["drives"]
            return {d["name"]: self.lam[d["name"]] for d in names}
        return {d.name: self.lam[d.name] for d in self.mech.drives}

    def tracking_error(self) -> dict:
        """Drive coordinates against their laws; platform pose against its prescribed motion.

        Returns
        -------
        dict
            ``"drives"``: the largest drive error over the samples [m or rad] (with a mechanism
            attached and drives); ``"platform_position"`` [m] and ``"platform_rotation"`` [rad,
            the angle of the relative rotation]: the largest deviation of the platform frame
            from ``mech.platform_motion`` (when the mechanism prescribes one). Empty otherwise.
        """
        res = {}
        if len(self.drive_error) and self.mech is not None and self.mech.drives:
            res["drives"] = float(np.max(self.drive_error))
        mech = self.mech
        if mech is not None and mech.platform_frame is not None and mech.platform_motion is not None:
            fm = kinematics.frame_motion(mech.model, [mech.platform_frame], self.q)
            ep, er = 0.0, 0.0
            for k, t in enumerate(self.t):
                M = pin.SE3(fm.R[k, 0], fm.p[k, 0])
                Mref = mech.platform_motion(t)
                if isinstance(Mref, tuple):
                    Mref = Mref[0]
                ep = max(ep, float(np.linalg.norm(M.translation - Mref.translation)))
                er = max(er, float(np.linalg.norm(pin.log3(Mref.rotation.T @ M.rotation))))
            res["platform_position"] = ep
            res["platform_rotation"] = er
        return res

    def summary(self, peaks_after=None) -> dict:
        """The run's summary (summary.json).

        Parameters
        ----------
        peaks_after : float, optional
            A time [s]: the summary also gives the peaks from that time on, under
            ``peaks_after`` (:meth:`window_peaks`); the whole run's peaks stay where they were.
            Default: the run's recorded ``meta["peaks_after"]`` (set by ``simulate
            --peaks-after``), none if it records none. A time after the run's end gives
            ``{"t_from", "message"}`` there instead.

        Returns
        -------
        dict
            JSON-safe: ``schema_version`` (SUMMARY_SCHEMA), status, message, failure, t_end,
            samples, max_closure_residual, step statistics, the energy drift of a conservative
            run, the tracking error, the energy audit, the peaks (:meth:`peak_summary`),
            versions, aliases and ``units`` (SUMMARY_UNITS).
        """
        from pinclear.dynamics.energy import ALIASES

        s = {"schema_version": SUMMARY_SCHEMA, "status": self.status, "message": self.message,
             "failure": self._failure_record(),
             "t_end": float(self.t[-1]) if len(self.t) else None,
             "samples": len(self.t),
             "max_closure_residual": float(np.max(self.residual)) if len(self.residual) else None,
             "rhs_evals": self.stats.get("rhs_evals"), "steps": self.stats.get("steps"),
             "cpu_s": self.stats.get("cpu_s"), "events": len(self.stats.get("events", [])),
             "method": self.meta.get("method", {}).get("method"), "integrator": self.meta.get("integrator"),
             "rtol": self.meta.get("rtol")}
        for k in ("mobility", "redundant_constraints", "redundant_rows", "rank_loss", "cpu_per_sim_s", "compile_s"):
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
        s["energy_balance"] = self.energy_balance()
        s.update(self.peak_summary())
        s["versions"] = self.meta.get("versions")
        s["aliases"] = {f"energy_balance.{k}": f"energy_balance.{v}" for k, v in ALIASES.items()}
        s["units"] = SUMMARY_UNITS
        if peaks_after is None:
            peaks_after = self.meta.get("peaks_after")
        if peaks_after is not None:
            from pinclear.core.errors import InputError

            try:
                s["peaks_after"] = self.window_peaks(peaks_after)
            except InputError as exc:     # e.g. a failed run that ended before T: said, the rest kept
                s["peaks_after"] = {"t_from": peaks_after, "message": str(exc)}
        return _jsonable(s)

    def window_peaks(self, t_from) -> dict:
        """The peaks from ``t_from`` to the end, the steady regime after a start-up transient.

        Parameters
        ----------
        t_from : float
            Start of the window [s], a finite number not after the run's last sample; anything
            else raises InputError.

        Returns
        -------
        dict
            ``{"t_from", "drive_force_peaks", "drive_force_peak_times", "contact_force_peaks",
            "contact_force_peak_times", "acceleration_peaks", "peaks_from"}`` in the units of
            :meth:`peak_summary`.

        Notes
        -----
        Where the whole run's peak from the integration lies at or after
        ``t_from`` it is the window's peak too (the largest of the run, inside the window) and is
        taken ("integration"); else the window's peak over the output samples
        (pinclear.dynamics.stepping.peaks.window_peak: a lower bound, resolved by the output step;
        "samples"). ``peaks_from`` names the source per channel, ``{"drive_force_peaks.A1": ...}``."""
        from pinclear.core.errors import InputError
        from pinclear.dynamics.stepping.peaks import window_peak

        if isinstance(t_from, bool) or not isinstance(t_from, (int, float)) or not np.isfinite(t_from):
            raise InputError(f"peaks_after: expected a time in seconds, got {t_from!r}")
        t_from = float(t_from)
        if len(self.t) and t_from > self.t[-1]:
            raise InputError(f"peaks_after = {t_from:g} s lies after the run's end (t = {self.t[-1]:.6g} s): no "
                             "sample to take a peak from")
        pk = self.stats.get("peaks") if isinstance(self.stats.get("peaks"), dict) else {}
        res = {"t_from": t_from, "drive_force_peaks": {}, "drive_force_peak_times": {}, "contact_force_peaks": {},
               "contact_force_peak_times": {}, "acceleration_peaks": {}, "peaks_from": {}}

        def pick(family, name, samples):
            rec = (pk.get(family) or {}).get(name)
            value, t = window_peak(self.t, samples, t_from=t_from) if samples is not None else (None, None)
            if isinstance(rec, dict) and rec.get("t") is not None and rec["t"] >= t_from:
                # the accepted steps' peak, unless an output sample between two steps (dense output)
                # came closer to the peak between them: the peak is over every evaluated point
                if value is None or not np.isfinite(value) or value <= rec["value"]:
                    return rec["value"], rec["t"], "integration"
            return (None, None, None) if value is None or not np.isfinite(value) else (value, t, "samples")

        drives = list(pk.get("drive_forces") or {}) or [
            d["name"] for d in (self.meta.get("mechanism") or {}).get("drives", []) if isinstance(d, dict)]
        for name in drives:
            value, t, src = pick("drive_forces", name, self.lam.get(name))
            res["drive_force_peaks"][name], res["drive_force_peak_times"][name] = value, t
            res["peaks_from"][f"drive_force_peaks.{name}"] = src
        contacts = list(pk.get("contact_forces") or {}) or [c.get("name") for c in self.stats.get("clearances", [])
                                                             if isinstance(c, dict)]
        for name in contacts:
            fn = self.outputs.get(f"{name}.fn")     # the total normal force, the contact peaks' quantity
            value, t, src = pick("contact_forces", name, None if fn is None else np.ravel(fn))
            res["contact_force_peaks"][name], res["contact_force_peak_times"][name] = value, t
            res["peaks_from"][f"contact_force_peaks.{name}"] = src
        for j, name in enumerate(pk.get("accelerations") or {}):
            col = self.a[:, j] if self.a.ndim == 2 and j < self.a.shape[1] else None
            value, t, src = pick("accelerations", name, col)
            res["acceleration_peaks"][name] = None if value is None else {"value": value, "t": t}
            res["peaks_from"][f"acceleration_peaks.{name}"] = src
        return res

    def peak_summary(self) -> dict:
        """The run's peaks as summary.json and :meth:`summary` give them (one function for both):
        ``drive_force_peaks`` {drive: N or N m}, ``drive_force_peak_times`` {drive: s},
        ``acceleration_peaks`` {dof: {value, t}}, ``clearances`` (each active clearance's
        description with ``peak_normal_force`` N and ``t_peak`` s), the same as
        ``contact_force_peaks`` {clearance: N} and ``contact_force_peak_times``, and ``peaks_from``:
        "integration" (over the accepted steps, pinclear.dynamics.stepping.peaks: independent of the
        output grid; a drive force sampled above its steps' peak gives the sample's) or "samples"
        (a run saved before the peaks were recorded).

        Returns
        -------
        dict
            The peaks as above; from the samples, only ``peaks_from``, ``drive_force_peaks``
            (max |multiplier|) and ``clearances``.
        """
        pk = self.stats.get("peaks")
        if isinstance(pk, dict):
            drives, acc, contact = (dict(pk.get(k) or {}) for k in ("drive_forces", "accelerations", "contact_forces"))
            from pinclear.dynamics.stepping.peaks import window_peak

            # the steps' drive-force peaks see the accepted states only: an output sample between
            # two long steps (dense output) can come closer to the peak between them
            for k, r in drives.items():
                if r is not None and len(self.t) and k in self.lam:
                    v, t = window_peak(self.t, self.lam[k])
                    if np.isfinite(v) and v > r["value"]:
                        drives[k] = {"value": v, "t": t}
            clr = [dict(c, peak_normal_force=(contact.get(c.get("name")) or {}).get("value"),
                        t_peak=(contact.get(c.get("name")) or {}).get("t")) for c in self.stats.get("clearances", [])]
            return {"peaks_from": "integration",
                    "drive_force_peaks": {k: None if r is None else r["value"] for k, r in drives.items()},
                    "drive_force_peak_times": {k: None if r is None else r["t"] for k, r in drives.items()},
                    "acceleration_peaks": acc, "clearances": clr,
                    # the same peaks by name (a sweep's per-point table keeps mappings, not lists)
                    "contact_force_peaks": {k: None if r is None else r["value"] for k, r in contact.items()},
                    "contact_force_peak_times": {k: None if r is None else r["t"] for k, r in contact.items()}}
        names = [d["name"] for d in (self.meta.get("mechanism") or {}).get("drives", [])]
        return {"peaks_from": "samples",
                "drive_force_peaks": {k: float(np.nanmax(np.abs(self.lam[k]))) if len(self.t) and k in self.lam
                                      else None for k in names},
                "clearances": list(self.stats.get("clearances", []))}

    def _failure_record(self):
        if self.failure is None:
            return None
        kind, t, detail = self.failure
        return {"kind": str(kind), "t": None if t is None else float(t), "detail": detail}

    def _summary_for_saving(self) -> dict:
        """The summary, or why it could not be computed: the summary calls user code (the
        platform motion of the tracking error), and nothing it raises may cost the run's file."""
        try:
            return self.summary()
        except Exception as exc:
            return {"status": self.status, "message": self.message,
                    "summary_error": f"{type(exc).__name__}: {' '.join(str(exc).split())[:300]}"}

    # ------------------------------------------------------------------ I/O
    def save(self, path):
        """Write the run as NPZ: every array (t, q, v, a, z, residual, drive_error, ``lam/NAME``,
        ``out/NAME``, ``energy/NAME``) and the JSON metadata (versions, parameters, method
        options, status, failure, stats, the summary), atomically (a temporary file renamed
        into place); :meth:`load` reads it back.

        Parameters
        ----------
        path : str or Path
            The file to write (conventionally ``.npz``); missing parent folders are created.

        Returns
        -------
        Path
            The file written.
        """
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        arrays = {"t": self.t, "q": self.q, "v": self.v, "a": self.a, "z": self.z, "residual": self.residual,
                  "drive_error": self.drive_error}
        for k, v in self.lam.items():
            arrays[f"lam/{k}"] = v
        for k, v in self.outputs.items():
            arrays[f"out/{k}"] = v
        for k, v in self.energies.items():
            arrays[f"energy/{k}"] = v
        meta = dict(self.meta, status=self.status, message=self.message, failure=self._failure_record(), stats=self.stats,
                    mech_path=str(Path(self.mech_path).resolve()) if self.mech_path else None,
                    load_args=getattr(self.mech, "load_args", None),
                    lam_names=list(self.lam), summary=self._summary_for_saving())
        if self.mech is not None:
            meta["parameters"] = self.mech.parameters
        arrays["meta"] = np.array(json.dumps(_jsonable(meta)))
        return atomic_savez(path, arrays)

    def to_csv(self, path):
        """Write the samples as CSV for other programs (pinclear.dynamics.export_run: one column
        per scalar channel, t, q.NAME, v.NAME, a.NAME, lam.NAME, out.*, energy.*, SI units,
        shortest round-trip decimals).

        Parameters
        ----------
        path : str or Path
            The CSV file to write.

        Returns
        -------
        Path
            The file written.
        """
        from pinclear.dynamics.export_run import write_csv

        return write_csv(self, path)

    def to_mat(self, path):
        """Write the samples as a MATLAB .mat file (scipy.io.savemat; matrices t, q, v, a, z, lam,
        outputs, energies with their column names, and the metadata as JSON text).

        Parameters
        ----------
        path : str or Path
            The .mat file to write.

        Returns
        -------
        Path
            The file written.
        """
        from pinclear.dynamics.export_run import write_mat

        return write_mat(self, path)

    @classmethod
    def load(cls, path, mech=None):
        """A saved run (NPZ + JSON metadata, as :meth:`save` writes it). Loading never imports
        code. The file is checked as data first (pinclear.dynamics.validate: declared sizes
        before loading, JSON types, shapes, finite states, increasing times); a failure is an
        InputError naming the file.

        Parameters
        ----------
        path : str or Path
            The saved run (``.npz``).
        mech : Mechanism, optional
            The mechanism it belongs to, checked against the recorded description and digest
            (:meth:`check_mechanism`) and attached; without it the run has no mechanism
            (:meth:`load_mechanism` attaches one later).

        Returns
        -------
        Trajectory
        """
        from pinclear.dynamics import validate as V

        tr = cls()
        arrays = V.read_npz(path, "trajectory")
        meta = V.read_meta(arrays, path, "trajectory")
        for k, types in (("status", str), ("message", str), ("stats", dict), ("lam_names", list)):
            if not isinstance(meta.get(k), types):
                raise V.file_error(path, f"metadata {k!r}: expected a {types.__name__}, got {type(meta.get(k)).__name__}")
        if meta["status"] not in STATUSES:
            raise V.file_error(path, f"metadata 'status': {meta['status']!r} is not a run status (valid: {', '.join(STATUSES)})")
        if not all(isinstance(k, str) for k in meta["lam_names"]):
            raise V.file_error(path, "metadata 'lam_names': expected a list of names")
        if not isinstance(meta.get("mech_path"), (str, type(None))):
            raise V.file_error(path, "metadata 'mech_path': expected a path")
        for k, types in (("mechanism", dict), ("load_args", dict), ("method", dict), ("options", dict),
                         ("versions", dict), ("summary", dict), ("integrator", str), ("rtol", (int, float)),
                         ("atol", (int, float, list)), ("t_requested", list), ("parameters", list),
                         ("peaks_after", (int, float)), ("mechanism_digest", str)):
            if not isinstance(meta.get(k), (types, type(None))) or isinstance(meta.get(k), bool):
                raise V.file_error(path, f"metadata {k!r}: expected {getattr(types, '__name__', 'a number')}, "
                                   f"got {type(meta.get(k)).__name__}")
        # the tolerances and step count the energy audit and the residual bound read back
        V.number(meta.get("rtol"), path, "rtol", positive=True, allow_none=True)
        atol = meta.get("atol")
        for a in (atol if isinstance(atol, list) and atol else [atol]):
            if (a is not None or isinstance(atol, list)) and V.number(a, path, "atol") < 0:
                raise V.file_error(path, f"atol: expected a number >= 0, got {a!r}")
        for k in ("steps", "rhs_evals"):
            V.number(meta["stats"].get(k), path, f"stats.{k}", integer=True, allow_none=True)
        tr.meta, tr.status, tr.message, tr.stats = meta, meta["status"], meta["message"], dict(meta["stats"])
        tr.failure = _read_failure(V, meta.get("failure"), path)
        tr.mech_path = meta.get("mech_path")
        rec = meta.get("mechanism") or {}
        dims = {}
        for k in ("nq", "nv"):
            if k in rec:
                dims[k] = V.number(rec[k], path, f"mechanism.{k}", integer=True)
        tr.t = V.real_array(arrays, "t", path, 1)
        n = len(tr.t)
        V.increasing(tr.t, path, "t")
        tr.q = V.real_array(arrays, "q", path, 2, rows=n, cols=dims.get("nq"))
        tr.v = V.real_array(arrays, "v", path, 2, rows=n, cols=dims.get("nv"))
        tr.z = V.real_array(arrays, "z", path, 2, rows=n)
        # accelerations, residuals and multipliers are NaN where a sample could not be evaluated
        tr.a = V.real_array(arrays, "a", path, 2, finite=False, rows=n, cols=tr.v.shape[1])
        tr.residual = V.real_array(arrays, "residual", path, 1, finite=False, rows=n)
        tr.drive_error = (V.real_array(arrays, "drive_error", path, 1, finite=False, rows=n)
                          if "drive_error" in arrays else np.zeros(0))
        tr.lam = {k: V.real_array(arrays, f"lam/{k}", path, 1, finite=False, rows=n) for k in meta["lam_names"]}
        tr.outputs = {k[4:]: _rows(V, arrays, k, path, n) for k in arrays if k.startswith("out/")}
        tr.energies = {k[7:]: V.real_array(arrays, k, path, 1, finite=False, rows=n)
                       for k in arrays if k.startswith("energy/")}
        missing = [k for k in ENERGY_KEYS if k not in tr.energies]
        if missing:
            raise V.file_error(path, f"array 'energy/{missing[0]}' is missing")
        if mech is not None:
            tr.check_mechanism(mech, path)
        tr.mech = mech
        return tr

    def check_mechanism(self, mech, path="<trajectory>"):
        """Refuse a mechanism other than the one the run recorded (same sizes are not enough): its
        name, sizes, joints, closures, drives, force elements and gravity, its digest (parameters,
        inertias, joint placements) and the columns of q, v, a and z must agree.

        Parameters
        ----------
        mech : Mechanism
            The mechanism to check.
        path : str
            What the run is called in the error (its file).

        Returns
        -------
        None
            Returns only if the mechanism matches; else raises InputError naming ``path`` and
            the first difference.
        """
        from pinclear.core.errors import InputError

        rec = self.meta.get("mechanism") or {}
        have = mech.describe()
        def kinds(forces):           # force elements and active clearances by name and type
            # (a tampered record's entries that are not mappings compare as what they are)
            return sorted((str(f.get("name")), str(f.get("type"))) if isinstance(f, dict) else ("", repr(f)[:40])
                          for f in (forces if isinstance(forces, list) else [forces] if forces else []))
        for key in ("name", "nq", "nv", "joints", "closures", "drives", "forces", "gravity"):
            if key not in rec:
                continue
            a, b = (kinds(rec[key]), kinds(have[key])) if key == "forces" else (_jsonable(rec[key]),
                                                                                  _jsonable(have[key]))
            if a != b:
                raise InputError(f"{path}: the run was made with mechanism {rec.get('name')!r} "
                                 f"({rec.get('path')}); {mech.path or mech.name} differs in {key!r}")
        rec_digest = self.meta.get("mechanism_digest")
        if isinstance(rec_digest, str) and rec_digest != _digest(mech):
            # the same joints and elements, other parameters (a clearance, a mass, a law's coefficient)
            raise InputError(f"{path}: the run was made with another version of mechanism {rec.get('name')!r}: "
                             f"{mech.path or mech.name} (loaded with the run's recorded options) has other "
                             "parameters, inertias or joint placements (mechanism digest differs); give the file "
                             "and options the run was made with")
        if self.q.ndim == 2 and self.q.shape[1] != mech.nq:
            raise InputError(f"{path}: q has {self.q.shape[1]} columns, mechanism {mech.name!r} has nq = {mech.nq}")
        for k, n in (("v", mech.nv), ("a", mech.nv), ("z", mech.nz)):
            arr = getattr(self, k)
            if arr.ndim == 2 and len(arr) and arr.shape[1] != n:
                raise InputError(f"{path}: {k} has {arr.shape[1]} columns, mechanism {mech.name!r} needs {n}")

    def load_mechanism(self, path=None, trust=None):
        """The mechanism this run used, loaded again with the recorded options, overrides and
        active clearances. ``path``: the mechanism file, named by the caller; without it only a
        bundled mechanism is loaded, by the name the run records (a path recorded in a results
        file is never opened). ``trust`` covers the file at ``path`` only: recorded arguments
        never add code or files (pinclear.core.trust.check_recorded_args), and a bundled mechanism
        needs no trust (docs/security.md).

        Parameters
        ----------
        path : str or Path, optional
            The mechanism file (sidecar) to load; default: the bundled mechanism the run names.
        trust : bool, optional
            As :func:`pinclear.load`'s ``trust``, for the file at ``path`` only (ignored without
            ``path``).

        Returns
        -------
        Mechanism
            The mechanism, checked against the run (:meth:`check_mechanism`) and attached as
            ``self.mech``.
        """
        from pinclear.core.trust import check_recorded_args, recorded_mechanism
        from pinclear.io.sidecar import load

        kw = check_recorded_args(self.meta.get("load_args"), "<saved run>")
        if path is None:
            path, trust = recorded_mechanism(self.meta, "<saved run>"), False
        mech = load(path, **kw, trust=trust)
        self.check_mechanism(mech)
        self.mech = mech
        return self.mech

    def __repr__(self):
        return (f"Trajectory({self.status}, {len(self.t)} samples, t = [{self.t[:1]}, {self.t[-1:]}], "
                f"rhs_evals={self.stats.get('rhs_evals')})")
