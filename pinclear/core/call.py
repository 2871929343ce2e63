"""The calling convention of a run's compiled pieces: every stage of an evaluation is a C
callback ``double stage(int64 ctx, double t)`` called through its address.

Why addresses: the step logic (``pinclear.dynamics.stepping``) is the same for every mechanism, while the
stages of an evaluation (Pinocchio's passes, each force element, the drive laws, the
formulation's solve) differ from run to run. Calling them through an int64 address keeps the step
functions ordinary, cacheable module code compiled once per machine for every mechanism, instead
of a loop generated per mechanism; an indirect call costs nanoseconds against microseconds of
dynamics (measured: 5 ns per stage, view rebuilding included). Pinocchio's passes are called the
same way (``pinclear.model.native``). A stage reads the state from its run's state buffer and writes its
results into the run's buffers; the only argument that changes per call is the time.

``ctx`` is the address of the stage's int64 table (pinclear.core.stage rebuilds the buffers'
views from it). A stage returns a code (``OK`` and the constants below; a formulation's solve
returns the pivot ratio of its constraint solve, >= 0).
"""
from __future__ import annotations

import math

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from pinclear.core.jit import njit

#: the C signature of every stage
CALLBACK = types.float64(types.int64, types.float64)

#: stage codes: a stage that watches nothing returns OK; negative codes are failures of the
#: evaluation (the step logic rejects the trial step, pinclear.dynamics.stepping.chunk)
OK = math.inf
#: rank loss of the constraint solve (or a mass matrix that is not positive definite)
RANK = -1.0
#: non-finite result
NONFINITE = -2.0
#: a Python stage raised: the run stops and the exception is raised again in Python
ERROR = -3.0


def _pointer_intrinsic(nbtype):
    @intrinsic
    def as_pointer(typingctx, addr):
        ptr = types.CPointer(nbtype)

        def codegen(context, builder, signature, args):
            return builder.inttoptr(args[0], context.get_value_type(ptr))
        return ptr(types.int64), codegen
    return as_pointer


#: int64 address -> typed data pointer (to rebuild a bound buffer's view)
ptr_f8 = _pointer_intrinsic(types.float64)
ptr_i8 = _pointer_intrinsic(types.int64)


@intrinsic
def call_stage(typingctx, fn, ctx, t):
    """stage(ctx, t) at address fn; returns its code."""
    sig = types.float64(types.int64, types.int64, types.float64)

    def codegen(context, builder, signature, args):
        f64, i64 = ir.DoubleType(), ir.IntType(64)
        ptr = builder.inttoptr(args[0], ir.FunctionType(f64, [i64, f64]).as_pointer())
        return builder.call(ptr, [args[1], args[2]])
    return sig, codegen


@intrinsic
def call_passes(typingctx, fn, model, data, q_addr, v_addr, flags):
    """``void pinclear_passes(int64 model, int64 data, int64 q, int64 v, int64 flags)`` at
    address ``fn`` (pinclear/model/_cxx/passes.cpp, or the Python fallback of pinclear.model.native)."""
    sig = types.void(types.int64, types.int64, types.int64, types.int64, types.int64, types.int64)

    def codegen(context, builder, signature, args):
        i64 = ir.IntType(64)
        ptr = builder.inttoptr(args[0], ir.FunctionType(ir.VoidType(), [i64] * 5).as_pointer())
        builder.call(ptr, list(args[1:]))
        return context.get_dummy_value()
    return sig, codegen


@njit(cache=True)
def run_stage(fn, ctx, t):
    """One stage called from Python (a stage's ``__call__``)."""
    return call_stage(fn, ctx, t)


@njit(cache=True)
def run_stages(stages, t):
    """Stages (rows of (fn, ctx)) in order; the smallest code, or ERROR at once."""
    code = OK
    for i in range(stages.shape[0]):
        r = call_stage(stages[i, 0], stages[i, 1], t)
        if r == ERROR:
            return r
        if r < code or r != r:
            code = r
    return code


__all__ = ["CALLBACK", "OK", "RANK", "NONFINITE", "ERROR", "ptr_f8", "ptr_i8", "call_stage", "call_passes",
           "run_stage", "run_stages"]
