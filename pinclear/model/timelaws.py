"""Time laws for drives and applied forces: value, first and second derivative, all exact."""
from __future__ import annotations

import abc
import functools
import math
from typing import NamedTuple

import numpy as np

from pinclear.core.errors import ModelFileError
from pinclear.core.jit import njit
from pinclear.core.registry import Key

# the trust gate lives in pinclear.core.trust; re-exported here, where sidecar and screw import it
from pinclear.core.trust import TRUST_ENV, resolve_function, trusted  # noqa: F401


class TimeLaw(abc.ABC):
    """A scalar function of time with exact first and second derivatives.

    The contract:

    1. ``eval(t)`` returns ``(y, dy/dt, d2y/dt2)`` as three floats, in SI units (m or rad for a
       drive, N or N m for an applied force, per second and per second squared).
    2. The derivatives are exact derivatives of ``y`` (no finite differences): drives enforce
       them at velocity and acceleration level.
    3. A law is immutable and ``eval`` is a pure function of ``t``: no caches on the object, so
       one law serves any number of workspaces and threads.
    4. ``kind`` names the sidecar ``type`` and ``describe()`` returns the mapping that rebuilds
       the law with :func:`build_law`.
    """

    kind = "law"
    #: a law that is one component of a vector function shared by several drives names it here
    #: (the drives then evaluate the function once for all of them: pinclear.model.drives); None: alone
    share_key = None

    @abc.abstractmethod
    def eval(self, t: float) -> tuple[float, float, float]:
        """(y, y', y'') at time t."""

    def __call__(self, t):
        return self.eval(t)

    def describe(self) -> dict:
        return {"type": self.kind}

    def kernel_params(self):
        """(code, parameters) when :func:`eval_laws` evaluates this law in compiled code (the
        drive rows then fill all such laws in one call); None: Python ``eval`` only."""
        return None


#: codes of the compiled time laws (TimeLaw.kernel_params)
L_CONSTANT, L_SINES, L_POLYNOMIAL = 0, 1, 2


@njit(cache=True)
def eval_laws(codes, starts, P, t, cols, f):
    """f[:, cols[k]] = (y, y', y'') of law k at t, for the laws of this module with a compiled
    form; law k's parameters are P[starts[k]:starts[k + 1]] (see each law's kernel_params)."""
    for k in range(codes.shape[0]):
        a, b = starts[k], starts[k + 1]
        code = codes[k]
        y = yd = ydd = 0.0
        if code == L_CONSTANT:
            y = P[a]
        elif code == L_SINES:
            y = P[a]
            for i in range(a + 1, b, 3):
                amp, w, ph = P[i], P[i + 1], P[i + 2]
                s, c = math.sin(w * t + ph), math.cos(w * t + ph)
                y += amp * s
                yd += amp * w * c
                ydd -= amp * w * w * s
        else:
            # P = (len c, len d, len dd, c..., d..., dd...): Horner on each, as Polynomial.eval
            c0 = a + 3
            d0 = c0 + int(P[a])
            e0 = d0 + int(P[a + 1])
            for i in range(d0 - 1, c0 - 1, -1):
                y = y * t + P[i]
            for i in range(e0 - 1, d0 - 1, -1):
                yd = yd * t + P[i]
            for i in range(b - 1, e0 - 1, -1):
                ydd = ydd * t + P[i]
        j = cols[k]
        f[0, j], f[1, j], f[2, j] = y, yd, ydd


class LawTable(NamedTuple):
    """Compiled time laws as :func:`eval_laws` reads them: law k has code ``codes[k]``, its
    parameters ``P[starts[k]:starts[k + 1]]``, and writes column ``cols[k]`` of the values."""
    codes: np.ndarray
    starts: np.ndarray
    P: np.ndarray
    cols: np.ndarray


def law_table(laws, cols) -> LawTable | None:
    """The table of ``laws`` (each with ``kernel_params()``) writing columns ``cols``; None when
    there are none. Arrays read-only: a table is shared by every workspace."""
    laws = list(laws)
    if not laws:
        return None
    P, starts, codes = [], [0], []
    for law in laws:
        code, par = law.kernel_params()
        codes.append(code)
        P.extend(float(x) for x in par)
        starts.append(len(P))
    # one trailing zero: a table of parameterless laws still has an element type numba can see
    out = (np.array(codes, dtype=np.int64), np.array(starts, dtype=np.int64), np.array(P + [0.0], float),
           np.array(list(cols), dtype=np.int64))
    for a in out:
        a.flags.writeable = False
    return LawTable(*out)


class Constant(TimeLaw):
    kind = "constant"

    def __init__(self, value: float):
        self.value = float(value)

    def eval(self, t):
        return self.value, 0.0, 0.0

    def kernel_params(self):
        return L_CONSTANT, [self.value]

    def describe(self):
        return {"type": self.kind, "value": self.value}


class Sines(TimeLaw):
    """offset + sum amp * sin|cos(omega t + phase)."""

    kind = "sines"

    def __init__(self, offset=0.0, terms=()):
        self.offset = float(offset)
        self.terms = [dict(t) for t in terms]
        # (amp, omega, phase) with a cosine written as a sine advanced by pi/2; plain floats and
        # math.sin: a law has a few terms and is evaluated at every right-hand side
        # the defaults are SINE_TERM_KEYS' (the key reference's)
        self._t = [(float(t.get("amp", _TERM["amp"])), float(t.get("omega", _TERM["omega"])),
                    float(t.get("phase", _TERM["phase"]))
                    + (math.pi / 2 if t.get("kind", _TERM["kind"]) == "cos" else 0.0))
                   for t in self.terms]

    def eval(self, t):
        y, yd, ydd = self.offset, 0.0, 0.0
        for a, w, p in self._t:
            s, c = math.sin(w * t + p), math.cos(w * t + p)
            y += a * s
            yd += a * w * c
            ydd -= a * w * w * s
        return y, yd, ydd

    def kernel_params(self):
        return L_SINES, [self.offset] + [x for term in self._t for x in term]

    def describe(self):
        return {"type": self.kind, "offset": self.offset, "terms": self.terms}


class Polynomial(TimeLaw):
    """c0 + c1 t + c2 t^2 + ..."""

    kind = "polynomial"

    def __init__(self, coeffs):
        self.coeffs = [float(c) for c in coeffs]
        c = self.coeffs
        self._d = [k * c[k] for k in range(1, len(c))]
        self._dd = [k * d for k, d in enumerate(self._d) if k > 0]

    @staticmethod
    def _horner(c, t):
        y = 0.0
        for ck in reversed(c):
            y = y * t + ck
        return y

    def eval(self, t):
        h = self._horner
        return h(self.coeffs, t), h(self._d, t), h(self._dd, t)

    def kernel_params(self):
        c, d, dd = self.coeffs, self._d, self._dd
        return L_POLYNOMIAL, [len(c), len(d), len(dd)] + c + d + dd

    def describe(self):
        return {"type": self.kind, "coeffs": self.coeffs}


class Spline(TimeLaw):
    """Cubic spline through tabulated points; derivatives are those of the spline itself."""

    kind = "spline"

    def __init__(self, t, y, bc_type="not-a-knot"):
        from scipy.interpolate import CubicSpline

        self.t, self.y = np.asarray(t, float), np.asarray(y, float)
        self._s = CubicSpline(self.t, self.y, bc_type=bc_type)
        self._d, self._dd = self._s.derivative(1), self._s.derivative(2)

    def eval(self, t):
        return float(self._s(t)), float(self._d(t)), float(self._dd(t))

    def describe(self):
        return {"type": self.kind, "t": self.t.tolist(), "y": self.y.tolist()}


class Callable(TimeLaw):
    """Wraps f(t, **args) -> (y, yd, ydd); with ``index``, f returns arrays and this law is
    component ``index``. Drives whose laws share (f, args) are evaluated with one call of f per
    time (``share_key``), the result cached in the workspace (pinclear.model.drives)."""

    kind = "python"

    def __init__(self, func, args=None, name=None, index=None):
        self.func, self.args = func, dict(args or {})
        self.name = name or getattr(func, "__qualname__", repr(func))
        self.index = index
        # laws with equal keys are components of one vector function
        self.share_key = (func, repr(sorted(self.args.items()))) if index is not None else None
        # the compiled twin, looked up once (drives fill their values with it at every new time)
        into = getattr(func, "into", None)
        self._into = into if callable(into) else None

    def vector(self, t):
        """All components of the shared function at t (three float arrays)."""
        return [np.asarray(x, float) for x in self.func(t, **self.args)]

    def filler(self):
        """``fill(t, out)``: the function's compiled twin ``func.into(t, out, **args)``, which writes
        its components' values and first and second derivatives into out (3, n) without
        allocating; None when the function declares none."""
        if self._into is None:
            return None
        return functools.partial(self._into, **self.args) if self.args else self._into

    def compiled_filler(self):
        """(kernel, args) with kernel(t, *args, out) a compiled function that fills what
        :meth:`filler` fills (``func.kernel(**args)``, declared next to ``func.into``); None when
        the function declares none. A run calls it as a compiled stage (pinclear.model.drives)."""
        make = getattr(self.func, "kernel", None)
        return make(**self.args) if callable(make) else None

    def eval(self, t):
        if self.index is not None:
            y, yd, ydd = self.vector(t)
            i = self.index
            return float(y[i]), float(yd[i]), float(ydd[i])
        y, yd, ydd = self.func(t, **self.args)
        return float(y), float(yd), float(ydd)

    def describe(self):
        d = {"type": self.kind, "function": self.name, "args": self.args}
        if self.index is not None:
            d["index"] = self.index
        return d


#: the keys of a ``sines`` law's ``terms`` entries (y = offset + sum amp sin|cos(omega t + phase))
SINE_TERM_KEYS = (
    Key("amp", "number", "m, rad, N or N m", 1.0, "finite", "Sines", "amplitude"),
    Key("omega", "number", "rad/s", 1.0, "finite", "Sines", "angular frequency"),
    Key("phase", "number", "rad", 0.0, "finite", "Sines", "phase at t = 0 (the law's value at t = 0 is "
        "offset + amp sin(phase))"),
    Key("kind", "string", "-", "sin", "sin | cos", "Sines", "sine or cosine (a cosine is a sine advanced by pi/2)"))
_TERM = {k.name: k.default for k in SINE_TERM_KEYS}

#: law type -> (its keys besides ``type``, one line); a law's value is in the unit of what it drives
LAW_KEYS = {
    "constant": ((Key("value", "number", "m, rad, N or N m", range="finite", doc="the constant value"),),
                 "y = value"),
    "sines": ((Key("offset", "number", "m, rad, N or N m", 0.0, "finite", doc="constant part"),
               Key("terms", "list of terms", "-", [], doc="each {amp, omega, phase, kind} (sine terms below)")),
              "y = offset + sum amp sin|cos(omega t + phase)"),
    "polynomial": ((Key("coeffs", "list of numbers", "SI per s^k", range="non-empty, finite", doc="[c0, c1, ...]"),),
                   "y = c0 + c1 t + c2 t^2 + ..."),
    "spline": ((Key("t", "list of numbers", "s", range="increasing", doc="knot times"),
                Key("y", "list of numbers", "m, rad, N or N m", range="finite, one per knot", doc="knot values"),
                Key("bc_type", "string", "-", "not-a-knot", "scipy.interpolate.CubicSpline's bc_type",
                    doc="end conditions")),
               "cubic spline through (t, y); its derivatives are the spline's"),
    "python": ((Key("function", "module:function", range="pinclear.core.trust.OFFERED unless trusted (--trust)",
                    doc="f(t, **args) -> (y, y', y'')"),
                Key("args", "mapping", "-", {}, doc="keyword arguments of the function"),
                Key("index", "integer", "-", None, ">= 0", doc="the component of a vector function")),
               "a Python function returning (y, y', y'')"),
}
LAW_TYPES = {kind: tuple(k.name for k in keys) for kind, (keys, _) in LAW_KEYS.items()}


def _finite(law, file, key):
    """A tabulated law must give finite values (NaN or inf in a sidecar is a typo, not a law)."""
    vals = law.eval(0.0)
    params = [getattr(law, a, 0.0) for a in ("value", "offset")] + list(getattr(law, "coeffs", []))
    params += [x for term in getattr(law, "_t", []) for x in term]
    params += list(np.ravel(getattr(law, "y", []))) + list(np.ravel(getattr(law, "t", [])))
    if not (np.all(np.isfinite(vals)) and np.all(np.isfinite(np.asarray(params, float)))):
        raise ModelFileError(file, key, "the law has a non-finite parameter (nan or inf)")
    return law


def _checked_output(law, file, key):
    """A python law evaluated once, at t = 0, to check the shape of what its function returns
    against the law's ``index``: an index past the function's output (or a vector function
    without an index) is a load error naming the law's key, not an IndexError in the run. A
    function that raises here is left to the run, which reports the time and the reason."""
    try:
        out = law.func(0.0, **law.args)
    except Exception:
        return law
    name = law.name
    try:
        parts = [np.asarray(x, float) for x in out]
    except (TypeError, ValueError):
        parts = None
    if parts is None or len(parts) != 3 or any(p.ndim > 1 for p in parts):
        raise ModelFileError(file, f"{key}.function", f"{name} returned {type(out).__name__}: a law returns three "
                             "numbers (y, y', y''), or three 1-D arrays of equal length chosen from with 'index'")
    n = parts[0].size
    if law.index is None:
        if any(p.size != 1 for p in parts):
            raise ModelFileError(file, f"{key}.index", f"missing: {name} returns {n} values per derivative; "
                                 f"choose one with index (0..{n - 1})")
    elif any(p.size != n for p in parts) or law.index >= n:
        sizes = "/".join(str(p.size) for p in parts)
        raise ModelFileError(file, f"{key}.index", f"{law.index} is past the values {name} returns ({sizes} for "
                             f"y, y', y''; valid: 0..{min(p.size for p in parts) - 1})")
    return law


def build_law(spec, file="<python>", key="law", trust=None) -> TimeLaw:
    """A TimeLaw from a sidecar mapping, a number, a callable or a TimeLaw."""
    if isinstance(spec, TimeLaw):
        return spec
    if callable(spec):
        return Callable(spec)
    if isinstance(spec, (int, float)):
        return Constant(spec)
    if not isinstance(spec, dict) or "type" not in spec:
        raise ModelFileError(file, key, "a law is a mapping with a 'type'", choices=LAW_TYPES)
    kind = spec["type"]
    if kind not in LAW_TYPES:
        raise ModelFileError(file, f"{key}.type", f"unknown law type {kind!r}", choices=LAW_TYPES)
    extra = set(spec) - {"type"} - set(LAW_TYPES[kind])
    if extra:
        raise ModelFileError(file, f"{key}.{sorted(extra)[0]}", f"unknown key for a {kind} law",
                             choices=LAW_TYPES[kind])
    try:
        if kind == "constant":
            return _finite(Constant(spec["value"]), file, key)
        if kind == "sines":
            for i, term in enumerate(spec.get("terms", [])):
                bad = set(term) - set(_TERM)
                if bad:
                    raise ModelFileError(file, f"{key}.terms[{i}].{sorted(bad)[0]}", "unknown key",
                                         choices=list(_TERM))
                if term.get("kind", "sin") not in ("sin", "cos"):
                    raise ModelFileError(file, f"{key}.terms[{i}].kind", f"{term['kind']!r}", choices=["sin", "cos"])
            return _finite(Sines(spec.get("offset", 0.0), spec.get("terms", [])), file, key)
        if kind == "polynomial":
            c = spec["coeffs"]
            if not isinstance(c, list) or not c:
                raise ModelFileError(file, f"{key}.coeffs", f"expected a non-empty list of numbers [c0, c1, ...], "
                                     f"got {c!r}")
            return _finite(Polynomial(c), file, key)
        if kind == "spline":
            return _finite(Spline(spec["t"], spec["y"], spec.get("bc_type", "not-a-knot")), file, key)
        func = resolve_function(spec.get("function"), file, f"{key}.function", trust)
        index = spec.get("index")
        if index is not None and (not isinstance(index, int) or index < 0):
            raise ModelFileError(file, f"{key}.index", f"expected a non-negative integer, got {index!r}")
        args = spec.get("args")
        if args is not None and not isinstance(args, dict):
            raise ModelFileError(file, f"{key}.args", f"expected a mapping of keyword arguments, got {args!r}")
        return _checked_output(Callable(func, args, name=spec.get("function"), index=index), file, key)
    except KeyError as exc:
        raise ModelFileError(file, f"{key}.{exc.args[0]}", f"missing for a {kind} law") from None
    except (TypeError, ValueError) as exc:
        if isinstance(exc, ModelFileError):
            raise
        raise ModelFileError(file, key, f"bad {kind} law: {exc}") from None
