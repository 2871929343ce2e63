"""The number, key and joint checks every reader of a mechanism file shares: each error names
the file, the key and what is allowed.
"""
from __future__ import annotations

import numpy as np

from pinclear.core.errors import ModelFileError


def check_keys(d, allowed, file, key):
    if not isinstance(d, dict):
        raise ModelFileError(file, key, f"expected a mapping, got {type(d).__name__}")
    for k in d:
        if k not in allowed:
            raise ModelFileError(file, f"{key}.{k}" if key else k, "unknown key", choices=allowed)


def number(x, file, key, positive=False):
    """A finite number (> 0 with ``positive``) or an error naming the file, the key and what is
    allowed: a NaN or zero reaching the solver fails only later, as a LAPACK error without a key."""
    from pinclear.core.bounded import shown

    if isinstance(x, bool):
        raise ModelFileError(file, key, f"expected a number, got {x!r}")
    try:
        v = float(x)
    except (TypeError, ValueError):
        raise ModelFileError(file, key, f"expected a number, got {shown(x)}") from None
    except OverflowError:           # an integer beyond the float range
        raise ModelFileError(file, key, f"{shown(x)} is not finite as a float: give a finite number") from None
    if not np.isfinite(v):
        raise ModelFileError(file, key, f"{shown(x)} is not finite: give a finite number{' > 0' if positive else ''}")
    if positive and not v > 0:
        raise ModelFileError(file, key, f"{v!r}: must be > 0")
    return v


def joint(model, name, file, key, one_dof=False):
    names = [n for n in model.names][1:]
    if not isinstance(name, str) or not model.existJointName(name):
        raise ModelFileError(file, key, f"unknown joint {name!r}", choices=names)
    jid = model.getJointId(name)
    jm = model.joints[jid]
    if one_dof and not any(jm.shortname() == "JointModel" + s for s in ONE_DOF_JOINTS):
        ok = [n for n in names if any(model.joints[model.getJointId(n)].shortname() == "JointModel" + s
                                      for s in ONE_DOF_JOINTS)]
        raise ModelFileError(file, key, f"joint {name!r} ({jm.shortname()}) is not a 1-DoF joint", choices=ok)
    return jm


ONE_DOF_JOINTS = ("RX", "RY", "RZ", "PX", "PY", "PZ", "RevoluteUnaligned", "PrismaticUnaligned")
