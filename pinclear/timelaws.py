"""Time laws for drives and applied forces: value, first and second derivative, all exact."""
from __future__ import annotations

import importlib
import math

import numpy as np

from .errors import ModelFileError


class TimeLaw:
    """A scalar function of time with exact first and second derivatives."""

    kind = "law"

    def eval(self, t: float) -> tuple[float, float, float]:
        raise NotImplementedError

    def __call__(self, t):
        return self.eval(t)

    def describe(self) -> dict:
        return {"type": self.kind}


class Constant(TimeLaw):
    kind = "constant"

    def __init__(self, value: float):
        self.value = float(value)

    def eval(self, t):
        return self.value, 0.0, 0.0

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
        self._t = [(float(t.get("amp", 1.0)), float(t.get("omega", 1.0)),
                    float(t.get("phase", 0.0)) + (math.pi / 2 if t.get("kind", "sin") == "cos" else 0.0))
                   for t in self.terms]

    def eval(self, t):
        y, yd, ydd = self.offset, 0.0, 0.0
        for a, w, p in self._t:
            s, c = math.sin(w * t + p), math.cos(w * t + p)
            y += a * s
            yd += a * w * c
            ydd -= a * w * w * s
        return y, yd, ydd

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


class _Shared:
    """One evaluation per time of a vector-valued f(t, **args) -> (y, yd, ydd) arrays, shared by
    the laws that take one component each (e.g. all limb lengths from one inverse kinematics)."""

    _registry: dict = {}

    def __init__(self, func, args):
        self.func, self.args, self.t, self.val = func, args, None, None

    @classmethod
    def get(cls, func, args):
        key = (func, repr(sorted(args.items())))
        if key not in cls._registry:
            cls._registry[key] = cls(func, args)
        return cls._registry[key]

    def __call__(self, t):
        if t != self.t:
            self.val = [np.asarray(x, float) for x in self.func(t, **self.args)]
            self.t = t
        return self.val


class Callable(TimeLaw):
    """Wraps f(t, **args) -> (y, yd, ydd); with ``index``, f returns arrays and this law is
    component ``index`` (f is then evaluated once per time for all components)."""

    kind = "python"

    def __init__(self, func, args=None, name=None, index=None):
        self.func, self.args = func, dict(args or {})
        self.name = name or getattr(func, "__qualname__", repr(func))
        self.index = index
        self._shared = _Shared.get(func, self.args) if index is not None else None

    def eval(self, t):
        if self._shared is not None:
            y, yd, ydd = self._shared(t)
            i = self.index
            return float(y[i]), float(yd[i]), float(ydd[i])
        y, yd, ydd = self.func(t, **self.args)
        return float(y), float(yd), float(ydd)

    def describe(self):
        d = {"type": self.kind, "function": self.name, "args": self.args}
        if self.index is not None:
            d["index"] = self.index
        return d


LAW_TYPES = {"constant": ("value",), "sines": ("offset", "terms"), "polynomial": ("coeffs",),
             "spline": ("t", "y", "bc_type"), "python": ("function", "args", "index")}


def resolve_function(spec: str, file, key):
    """'package.module:attr' -> the object."""
    if not isinstance(spec, str) or ":" not in spec:
        raise ModelFileError(file, key, f"expected 'module:function', got {spec!r}")
    mod, attr = spec.split(":", 1)
    try:
        obj = importlib.import_module(mod)
        for part in attr.split("."):
            obj = getattr(obj, part)
    except (ImportError, AttributeError) as exc:
        raise ModelFileError(file, key, f"cannot import {spec!r}: {exc}") from None
    return obj


def build_law(spec, file="<python>", key="law") -> TimeLaw:
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
            return Constant(spec["value"])
        if kind == "sines":
            for i, term in enumerate(spec.get("terms", [])):
                bad = set(term) - {"amp", "omega", "phase", "kind"}
                if bad:
                    raise ModelFileError(file, f"{key}.terms[{i}].{sorted(bad)[0]}", "unknown key",
                                         choices=["amp", "omega", "phase", "kind"])
                if term.get("kind", "sin") not in ("sin", "cos"):
                    raise ModelFileError(file, f"{key}.terms[{i}].kind", f"{term['kind']!r}", choices=["sin", "cos"])
            return Sines(spec.get("offset", 0.0), spec.get("terms", []))
        if kind == "polynomial":
            return Polynomial(spec["coeffs"])
        if kind == "spline":
            return Spline(spec["t"], spec["y"], spec.get("bc_type", "not-a-knot"))
        func = resolve_function(spec.get("function"), file, f"{key}.function")
        index = spec.get("index")
        if index is not None and (not isinstance(index, int) or index < 0):
            raise ModelFileError(file, f"{key}.index", f"expected a non-negative integer, got {index!r}")
        return Callable(func, spec.get("args"), name=spec.get("function"), index=index)
    except KeyError as exc:
        raise ModelFileError(file, f"{key}.{exc.args[0]}", f"missing for a {kind} law") from None
    except (TypeError, ValueError) as exc:
        if isinstance(exc, ModelFileError):
            raise
        raise ModelFileError(file, key, f"bad {kind} law: {exc}") from None
