"""The compiled Pinocchio passes (pinclear/_cxx/passes.cpp), when the install built them.

``pip install`` compiles the extension ``pinclear._passes`` against the ``pin`` wheel's own
headers and libraries. It is optional: without a C++ compiler, or when the installed ``pin`` is
not the one it was built against (a mismatched C++ ABI would corrupt memory), pinclear runs the
same passes through Pinocchio's Python bindings and the integration loop stays in Python
(pinclear.fastloop says which path a run took). ``PINCLEAR_NATIVE=0`` turns it off.
"""
from __future__ import annotations

import importlib
import os

import pinocchio as pin

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
