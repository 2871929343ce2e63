"""Calls of a run's compiled callbacks through their addresses.

Why addresses: the step logic (``pinclear.stepping``) is the same for every mechanism, while the
right-hand side is composed per mechanism. Passing the callback's address as an int64 argument
keeps the step functions ordinary, cacheable module code (compiled once per machine for all
mechanisms) instead of a template generated per mechanism; the indirect call costs nanoseconds
against microseconds of dynamics. It is the pattern the Pinocchio passes already use
(``pinclear.native``).

The callbacks' C signatures (``numba.cfunc``):

* ``RHS``:     ``double rhs(int64 ctx, double t, double* x, double* dx)``: dx = f(t, x); returns
  the evaluation code: >= 0 the pivot ratio of the constraint solve (1.0 when not watched),
  -1 the evaluation is Python's to take (rank loss, rows to choose again), -2 non-finite.
* ``EVENTS``:  ``void events(int64 ctx, double t, double* y, double* g)``: every event channel's
  value at state y.
* ``PROJECT``: ``double project(int64 ctx, double t, double* y)``: y moved onto the constraint
  manifold in place; returns 0 on success, -1 when Python must take it.

``ctx`` is the address of the run's int64 context table (the callbacks rebuild their buffers'
views from it, see pinclear._bind).
"""
from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

RHS = types.float64(types.int64, types.float64, types.CPointer(types.float64), types.CPointer(types.float64))
EVENTS = types.void(types.int64, types.float64, types.CPointer(types.float64), types.CPointer(types.float64))
PROJECT = types.float64(types.int64, types.float64, types.CPointer(types.float64))


def _data_pointer(context, builder, arrty, arr):
    """double* of a contiguous 1-d float64 array value."""
    ary = context.make_array(arrty)(context, builder, arr)
    return ary.data


@intrinsic
def call_rhs(typingctx, fn, ctx, t, x, dx):
    """rhs(ctx, t, x, dx) at address fn (x, dx: contiguous float64 arrays); returns the code."""
    sig = types.float64(types.int64, types.int64, types.float64, x, dx)

    def codegen(context, builder, signature, args):
        f64, i64 = ir.DoubleType(), ir.IntType(64)
        pf = f64.as_pointer()
        fnty = ir.FunctionType(f64, [i64, f64, pf, pf])
        ptr = builder.inttoptr(args[0], fnty.as_pointer())
        px = _data_pointer(context, builder, signature.args[3], args[3])
        pdx = _data_pointer(context, builder, signature.args[4], args[4])
        return builder.call(ptr, [args[1], args[2], px, pdx])
    return sig, codegen


@intrinsic
def call_events(typingctx, fn, ctx, t, y, g):
    """events(ctx, t, y, g) at address fn."""
    sig = types.void(types.int64, types.int64, types.float64, y, g)

    def codegen(context, builder, signature, args):
        f64, i64 = ir.DoubleType(), ir.IntType(64)
        pf = f64.as_pointer()
        fnty = ir.FunctionType(ir.VoidType(), [i64, f64, pf, pf])
        ptr = builder.inttoptr(args[0], fnty.as_pointer())
        py = _data_pointer(context, builder, signature.args[3], args[3])
        pg = _data_pointer(context, builder, signature.args[4], args[4])
        builder.call(ptr, [args[1], args[2], py, pg])
        return context.get_dummy_value()
    return sig, codegen


@intrinsic
def call_project(typingctx, fn, ctx, t, y):
    """project(ctx, t, y) at address fn; returns its code."""
    sig = types.float64(types.int64, types.int64, types.float64, y)

    def codegen(context, builder, signature, args):
        f64, i64 = ir.DoubleType(), ir.IntType(64)
        fnty = ir.FunctionType(f64, [i64, f64, f64.as_pointer()])
        ptr = builder.inttoptr(args[0], fnty.as_pointer())
        py = _data_pointer(context, builder, signature.args[3], args[3])
        return builder.call(ptr, [args[1], args[2], py])
    return sig, codegen


@intrinsic
def call_passes(typingctx, fn, model, data, q_addr, v_addr, flags):
    """Call ``void pinclear_passes(int64 model, int64 data, int64 q, int64 v, int64 flags)`` at
    address ``fn``: an int argument rather than a ctypes global keeps the caller cacheable."""
    sig = types.void(types.int64, types.int64, types.int64, types.int64, types.int64, types.int64)

    def codegen(context, builder, signature, args):
        i64 = ir.IntType(64)
        fnty = ir.FunctionType(ir.VoidType(), [i64] * 5)
        ptr = builder.inttoptr(args[0], fnty.as_pointer())
        builder.call(ptr, list(args[1:]))
        return context.get_dummy_value()
    return sig, codegen



__all__ = ["RHS", "EVENTS", "PROJECT", "call_rhs", "call_events", "call_project", "call_passes"]
