"""The compiled Pinocchio passes (pinclear/model/_cxx/passes.cpp), when the install built them.

``pip install`` compiles the extension ``pinclear.model._passes`` against the ``pin`` wheel's own
headers and libraries. It is optional: without a C++ compiler, or when the installed ``pin`` is
not the one it was built against (a mismatched C++ ABI would corrupt memory), pinclear runs the
same passes through Pinocchio's Python bindings, as a Python stage of the run's evaluation
(``stats['loop']`` says so). ``PINCLEAR_NATIVE=0`` turns it off.
"""
from __future__ import annotations

import ctypes
import importlib
import os
from typing import NamedTuple

import numpy as np
import pinocchio as pin

from pinclear.core.call import call_passes
from pinclear.core.jit import njit

_mod = None
#: why the compiled passes are not in use ("" when they are)
reason = ""

if os.environ.get("PINCLEAR_NATIVE", "1") == "0":
    reason = "turned off by PINCLEAR_NATIVE=0"
else:
    try:
        _mod = importlib.import_module("pinclear.model._passes")
    except ImportError as exc:
        reason = f"the extension pinclear.model._passes was not built ({exc}); reinstall with a C++ compiler"
    else:
        if _mod.PINOCCHIO_VERSION != pin.__version__:
            reason = (f"pinclear.model._passes was built against Pinocchio {_mod.PINOCCHIO_VERSION} but "
                      f"{pin.__version__} is installed; reinstall pinclear")
            _mod = None


def available() -> bool:
    return _mod is not None


#: the flags of pinclear_passes (passes.cpp): frame placements, the mass matrix; the position
#: level instead of an evaluation's passes (placements and Jacobians at q, with FRAMES and MASS
#: as asked: the projections' iterates on trees the compiled joint chain does not cover, the
#: others take J from it, pinclear.dynamics.formulations.projection.at_positions); the mass matrix alone
FRAMES, MASS, POSITIONS, MASS_ONLY = 1, 2, 4, 8


def passes_address() -> int:
    """Address of ``pinclear_passes(model, data, q, v, flags)`` (all int64; flags: FRAMES, MASS,
    POSITIONS, MASS_ONLY); see passes.cpp."""
    return _mod.passes_address()


def python_passes(model, data, q, v, flags):
    """passes.cpp's sequence for ``flags`` through Pinocchio's Python bindings (the library
    functions the extension calls, in the same order)."""
    if flags & MASS_ONLY:
        pin.crba(model, data, q)
        return
    if flags & POSITIONS:
        pin.computeJointJacobians(model, data, q)
    else:
        pin.computeJointJacobiansTimeVariation(model, data, q, v)
    if flags & FRAMES:
        pin.updateFramePlacements(model, data)
    if flags & MASS:
        pin.crba(model, data, q)
    if not flags & POSITIONS:
        pin.nonLinearEffects(model, data, q, v)


class Passes(NamedTuple):
    """What compiled code needs to run Pinocchio's passes on one workspace's data:
    ``call_passes(fn, model, data, q_address, v_address, flags)`` (pinclear.core.call)."""
    fn: int
    model: int
    data: int


#: the C type of pinclear_passes, for its Python twin
_PASSES = ctypes.CFUNCTYPE(None, *[ctypes.c_int64] * 5)


def passes_for(mech, ws):
    """(Passes on ``ws.data``, what must stay alive while they are used). Without the extension
    ``fn`` is a C callback running :func:`python_passes` (at Python's cost: ~10 us a call), so
    kernels that call the passes themselves (the projections onto the constraint manifold) work
    on every install. q and v are read at the addresses passed (nq and nv entries)."""
    if _mod is not None:
        model_addr, data_addr = addresses(mech.model, ws.data)
        return Passes(passes_address(), model_addr, data_addr), None
    model, data, nq, nv = mech.model, ws.data, mech.nq, mech.nv

    def passes(model_addr, data_addr, q_addr, v_addr, flags):
        q = np.ctypeslib.as_array((ctypes.c_double * nq).from_address(q_addr))
        v = np.ctypeslib.as_array((ctypes.c_double * nv).from_address(v_addr))
        python_passes(model, data, q, v, flags)

    c = _PASSES(passes)
    return Passes(ctypes.cast(c, ctypes.c_void_p).value, 0, 0), c


def addresses(model, data) -> tuple:
    """Addresses of the C++ Model and Data behind a pin.Model and a pin.Data (valid while the
    Python objects live)."""
    return _mod.model_address(model), _mod.data_address(data)


@njit(cache=True)
def run_passes(fn, model, data, q, v, flags):
    """Pinocchio's passes of one evaluation at the state buffer's (q, v) (passes.cpp, the same
    sequence as kinematics.update)."""
    call_passes(fn, model, data, q.ctypes.data, v.ctypes.data, flags)


def passes_stage(mech, ws, mass=True, errors=None, frames=True):
    """The stage running Pinocchio's passes of an evaluation on ``ws.data`` at (ws.q, ws.v): the
    compiled passes, or kinematics.update through Python when the extension is not in use.
    ``frames``: the frame placements too (data.oMf, read by force elements evaluated in Python;
    compiled ones take theirs from ws.fk)."""
    from pinclear.core.stage import bind, python_stage

    if _mod is None:
        from pinclear.model import kinematics

        def passes(t):
            kinematics.update(mech, ws, ws.q, ws.v, mass)
            return float("inf")
        return python_stage(passes, errors, name="Pinocchio's passes (Python bindings)")
    flags = (FRAMES if frames else 0) | (MASS if mass else 0)
    model_addr, data_addr = addresses(mech.model, ws.data)
    return bind(run_passes, (passes_address(), model_addr, data_addr, ws.q, ws.v, flags), name="Pinocchio's passes")
