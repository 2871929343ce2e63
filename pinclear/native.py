"""The compiled Pinocchio passes (pinclear/_cxx/passes.cpp), when the install built them.

``pip install`` compiles the extension ``pinclear._passes`` against the ``pin`` wheel's own
headers and libraries. It is optional: without a C++ compiler, or when the installed ``pin`` is
not the one it was built against (a mismatched C++ ABI would corrupt memory), pinclear runs the
same passes through Pinocchio's Python bindings, as a Python stage of the run's evaluation
(``stats['loop']`` says so). ``PINCLEAR_NATIVE=0`` turns it off.
"""
from __future__ import annotations

import importlib
import os

import pinocchio as pin

from ._jit import njit
from .stepping.call import call_passes

_mod = None
#: why the compiled passes are not in use ("" when they are)
reason = ""

if os.environ.get("PINCLEAR_NATIVE", "1") == "0":
    reason = "turned off by PINCLEAR_NATIVE=0"
else:
    try:
        _mod = importlib.import_module("pinclear._passes")
    except ImportError as exc:
        reason = f"the extension pinclear._passes was not built ({exc}); reinstall with a C++ compiler"
    else:
        if _mod.PINOCCHIO_VERSION != pin.__version__:
            reason = (f"pinclear._passes was built against Pinocchio {_mod.PINOCCHIO_VERSION} but "
                      f"{pin.__version__} is installed; reinstall pinclear")
            _mod = None


def available() -> bool:
    return _mod is not None


#: the flags of pinclear_passes (passes.cpp): frame placements, the mass matrix
FRAMES, MASS = 1, 2


def passes_address() -> int:
    """Address of ``pinclear_passes(model, data, q, v, flags)`` (all int64; flags: FRAMES | MASS);
    see passes.cpp."""
    return _mod.passes_address()


def addresses(model, data) -> tuple:
    """Addresses of the C++ Model and Data behind a pin.Model and a pin.Data (valid while the
    Python objects live)."""
    return _mod.model_address(model), _mod.data_address(data)


@njit(cache=True)
def run_passes(fn, model, data, q, v, flags):
    """Pinocchio's passes of one evaluation at the state buffer's (q, v) (passes.cpp, the same
    sequence as kinematics.update)."""
    call_passes(fn, model, data, q.ctypes.data, v.ctypes.data, flags)


def passes_stage(mech, ws, mass=True, errors=None):
    """The stage running Pinocchio's passes of an evaluation on ``ws.data`` at (ws.q, ws.v): the
    compiled passes, or kinematics.update through Python when the extension is not in use."""
    from .stepping.stage import bind, python_stage

    if _mod is None:
        from . import kinematics

        def passes(t):
            kinematics.update(mech, ws, ws.q, ws.v, mass)
            return float("inf")
        return python_stage(passes, errors, name="Pinocchio's passes (Python bindings)")
    flags = (FRAMES if mech.forces else 0) | (MASS if mass else 0)   # frames as kinematics.update
    model_addr, data_addr = addresses(mech.model, ws.data)
    return bind(run_passes, (passes_address(), model_addr, data_addr, ws.q, ws.v, flags), name="Pinocchio's passes")
