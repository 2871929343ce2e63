"""Stages: compiled kernels bound once to their buffers, callable through one address.

A kernel of pinclear is an ordinary ``@njit`` function of buffers (workspace arrays, views of
Pinocchio's data, frozen parameter tables, NamedTuples grouping them) and, at most, the time.
:func:`bind` stores the buffers' addresses and shapes once in an int64 table and gives back a
:class:`Stage`: a C callback ``double stage(int64 ctx, double t)`` (pinclear.core.call)
that rebuilds the views from the table inside compiled code and calls the kernel. The step logic
calls stages through their addresses, so it is module code compiled once for every mechanism;
Python calls the same stage (``stage(t)``), so both see the very same arithmetic.

This wrapper is the only code pinclear generates: numba cannot otherwise call a kernel on buffers
known only at run time from compiled code without passing every buffer along, and a C callback
has a fixed signature. It is generated per (kernel, argument kinds) — not per mechanism — as a
plain Python file in the user cache folder (never inside the package), named by a hash of its
source and of the kernels it inlines, so numba caches its compiled code like any kernel's.

Buffers must keep their address for the stage's life (the Stage keeps them alive): persistent
workspace arrays and views, never temporaries. The state a kernel reads is a view of its run's
state buffer (``Workspace.q``, ``.v``, ``.z``), filled before the stages run.
"""
from __future__ import annotations

import ctypes
import functools
import hashlib
import importlib.util
import os
import sys

import numpy as np

from pinclear.core.call import ERROR, run_stage
from pinclear.core.jit import KERNELS_DIGEST, cache_dir


class _Time:
    """The marker of the argument that receives the evaluation time."""

    def __repr__(self):
        return "T"


#: marks the argument of a kernel that receives the evaluation time (``bind(k, (..., T, ...))``)
T = _Time()

_DTYPES = {np.dtype(np.float64): ("f8", "ptr_f8"), np.dtype(np.int64): ("i8", "ptr_i8")}


def _kind(x, where):
    """How one argument is passed: ('a', dtype, ndim, order) an array, ('f',) a float, ('i',) an
    int, ('t',) the time, ('s', module, name, kinds) a NamedTuple of such."""
    if x is T:
        return ("t",)
    if isinstance(x, np.ndarray):
        if x.dtype not in _DTYPES or x.ndim == 0:
            raise TypeError(f"{where}: a bound array must be float64 or int64 with ndim >= 1, got {x.dtype} {x.shape}")
        if x.flags.c_contiguous:
            order = "C"
        elif x.flags.f_contiguous:
            order = "F"
        else:
            raise TypeError(f"{where}: a bound array must be contiguous (its address and shape describe it)")
        return ("a", _DTYPES[x.dtype][0], x.ndim, order)
    if isinstance(x, (bool, np.bool_)):
        raise TypeError(f"{where}: pass flags as int, not bool")
    if isinstance(x, (int, np.integer)):
        return ("i",)
    if isinstance(x, (float, np.floating)):
        return ("f",)
    if isinstance(x, tuple) and hasattr(type(x), "_fields"):
        cls = type(x)
        return ("s", cls.__module__, cls.__qualname__,
                tuple(_kind(v, f"{where}.{f}") for f, v in zip(cls._fields, x)))
    raise TypeError(f"{where}: cannot bind {type(x).__name__} (arrays, numbers, NamedTuples of them and T)")


def _flatten(x, kind, P, F):
    """Append argument x of ``kind`` to the address table P and the float table F."""
    tag = kind[0]
    if tag == "a":
        P.append(x.ctypes.data)
        P.extend(int(n) for n in x.shape)
    elif tag == "i":
        P.append(int(x))
    elif tag == "f":
        F.append(float(x))
    elif tag == "s":
        for v, k in zip(x, kind[3]):
            _flatten(v, k, P, F)


class _Source:
    """Writes the wrapper's body: one line per rebuilt argument."""

    def __init__(self):
        self.lines, self.imports, self.p, self.f = [], {}, 1, 0

    def expr(self, kind):
        tag = kind[0]
        if tag == "t":
            return "t"
        if tag == "i":
            self.p += 1
            return f"P[{self.p - 1}]"
        if tag == "f":
            self.f += 1
            return f"F[{self.f - 1}]"
        if tag == "a":
            _, dt, ndim, order = kind
            pointer = dict(_DTYPES.values())[dt]
            shape = ", ".join(f"P[{self.p + 1 + j}]" for j in range(ndim)) + ("," if ndim == 1 else "")
            make = "carray" if order == "C" else "farray"
            text = f"{make}({pointer}(P[{self.p}]), ({shape}))"
            self.p += 1 + ndim
            return text
        _, mod, name, kinds = kind
        alias = self.imports.setdefault((mod, name), f"S{len(self.imports)}")
        return f"{alias}({', '.join(self.expr(k) for k in kinds)})"


@functools.lru_cache(maxsize=None)
def _source(kernel, kinds, code):
    """The wrapper module of ``kernel`` called with arguments of these kinds."""
    body = _Source()
    args = []
    for i, kind in enumerate(kinds):
        if kind[0] in ("a", "s"):
            body.lines.append(f"    a{i} = {body.expr(kind)}")
            args.append(f"a{i}")
        else:
            args.append(body.expr(kind))
    call = f"kernel({', '.join(args)})"
    mod, name = kernel.py_func.__module__, kernel.py_func.__name__
    head = ["# generated by pinclear.core.stage: a kernel bound to its buffers (do not edit)",
            "import math", "from numba import carray, cfunc, farray",
            "from pinclear.core.call import CALLBACK, ptr_f8, ptr_i8",
            f"from {mod} import {name} as kernel"]
    head += [f"from {m} import {n} as {alias}" for (m, n), alias in body.imports.items()]
    lines = head + ["", "", "@cfunc(CALLBACK, cache=True)", "def stage(ctx, t):",
                    f"    P = carray(ptr_i8(ctx), ({body.p},))"]
    if body.f:
        lines.append(f"    F = carray(ptr_f8(P[0]), ({body.f},))")
    lines += body.lines
    lines += [f"    return float({call})"] if code else [f"    {call}", "    return math.inf"]
    return "\n".join(lines) + "\n", body.p


_LOADED: dict = {}


def load_generated(src, prefix="stage"):
    """Import generated source from the user cache folder, named by a hash of the source and of
    the kernels it inlines (one module per distinct source per process)."""
    key = hashlib.sha1(src.encode() + KERNELS_DIGEST).hexdigest()[:20]
    if key in _LOADED:
        return _LOADED[key]
    folder = cache_dir() / "stages"
    path = folder / f"{prefix}_{key}.py"
    folder.mkdir(parents=True, exist_ok=True)
    if not path.exists() or path.read_text() != src:
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(src)
        tmp.replace(path)            # atomic: parallel workers may write the same file
    spec = importlib.util.spec_from_file_location(f"pinclear_{prefix}_{key}", path)
    module = importlib.util.module_from_spec(spec)
    # registered before it runs: numba's on-disk cache records the module by name and imports
    # it again when it loads the compiled code
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    _LOADED[key] = module
    return module


class Stage:
    """A bound kernel: ``fn`` (the callback's address) and ``ctx`` (its table's address), the
    row a run's stage list holds. ``stage(t)`` runs it from Python; ``name`` says what it is."""

    __slots__ = ("fn", "ctx", "name", "_keep")

    def __init__(self, fn, ctx, name, keep):
        self.fn, self.ctx, self.name, self._keep = int(fn), int(ctx), name, keep

    def __call__(self, t=0.0):
        return run_stage(self.fn, self.ctx, float(t))

    def __repr__(self):
        return f"Stage({self.name})"


def bind(kernel, args, code=False, name=None) -> Stage:
    """The stage calling ``kernel(*args)`` with ``T`` replaced by the evaluation time.

    ``code``: the kernel returns the stage's code (a formulation's solve: the pivot ratio or a
    failure code of pinclear.core.call); otherwise its result is ignored and the stage
    returns OK. Raises TypeError naming the argument that cannot be bound."""
    label = name or kernel.py_func.__name__
    args = tuple(args)
    kinds = tuple(_kind(x, f"{label} argument {i}") for i, x in enumerate(args))
    src, n = _source(kernel, kinds, bool(code))
    P, F = [0], []
    for x, kind in zip(args, kinds):
        _flatten(x, kind, P, F)
    F = np.array(F + [0.0], dtype=np.float64)
    P[0] = F.ctypes.data
    table = np.array(P, dtype=np.int64)
    assert len(table) == n, (len(table), n)
    module = load_generated(src)
    return Stage(module.stage.address, table.ctypes.data, label, (table, F, args, module))


#: the C type of a stage, for stages written in Python
_CALLBACK = ctypes.CFUNCTYPE(ctypes.c_double, ctypes.c_int64, ctypes.c_double)


def python_stage(func, errors, name=None) -> Stage:
    """A stage that runs ``func(t) -> code`` in Python (a plug-in without a compiled form, a
    Python drive law, the whole Python right-hand side). An exception is appended to ``errors``
    and the stage returns ERROR: the step logic then stops and the run raises it again."""
    def callback(ctx, t):
        try:
            return float(func(t))
        except BaseException as exc:      # KeyboardInterrupt too: re-raised by the run
            errors.append(exc)
            return ERROR

    c = _CALLBACK(callback)
    return Stage(ctypes.cast(c, ctypes.c_void_p).value, 0, name or getattr(func, "__name__", "python"), (c, func))


__all__ = ["T", "Stage", "bind", "python_stage", "load_generated"]
