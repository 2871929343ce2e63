"""The trust gate: which Python functions a data file may name (docs/security.md).

A mechanism file may name functions as ``module:function`` (drive laws, platform motions, the
load hook, the screw method's inverse kinematics, motions and virtual-joint rules). Without the
user's consent (``trust=True``, ``--trust``, PINCLEAR_TRUST=1) a name must be one of
:data:`OFFERED`, the functions pinclear itself offers to data files; the name is checked as a
string before anything is imported, and the object found must be a plain function defined in
that very module under that very name. So no attribute chain (``pinclear.timelaws:os.spawnv``,
``pinclear.sidecar:re.enum.bltns.exec``) and no other pinclear function (``pinclear.cli:main``)
is reachable from an untrusted file. With trust, any importable ``module:attr.path`` resolves:
the user has chosen to run the file's code.
"""
from __future__ import annotations

import importlib
import os
import types
from types import MappingProxyType

from .errors import ModelFileError

#: environment variable that trusts every mechanism file (as ``trust=True`` / ``--trust``)
TRUST_ENV = "PINCLEAR_TRUST"

#: the functions pinclear offers to untrusted data files, with the role each plays. Adding one is
#: a security decision: it must be a function of its module (not an import) whose effects are
#: confined to computing its result for the arguments a sidecar can give.
OFFERED = MappingProxyType({
    "pinclear.mechanisms.four_ups_upu:limb_lengths": "drive law (python, vector of limb lengths)",
    "pinclear.mechanisms.four_ups_upu:platform_pose": "platform.motion",
    "pinclear.mechanisms.three_upru_up:limb_lengths": "drive law (python, vector of limb lengths)",
    "pinclear.mechanisms.three_upru_up:platform_pose": "platform.motion",
    "pinclear.mechanisms.four_ups_upr:limb_lengths": "drive law (python, vector of limb lengths)",
    "pinclear.mechanisms.four_ups_upr:platform_pose": "platform.motion",
    "pinclear.mechanisms.four_ups_upr:platform_motion": "screw.motions (pose, twist, acceleration)",
    "pinclear.mechanisms.four_ups_upr:tree_configuration_ik": "screw.ik",
    "pinclear.mechanisms.four_ups_upr:sidecar_hook": "hook (layout and limb inertia options)",
    "pinclear.screw.virtual:line_normal": "screw.virtual rule",
})


def trusted(trust=None) -> bool:
    """The effective trust setting: an explicit argument wins, else the environment variable."""
    if trust is not None:
        return bool(trust)
    return os.environ.get(TRUST_ENV, "").strip().lower() in ("1", "true", "yes", "on")


def _refuse(spec, file, key, why):
    raise ModelFileError(
        file, key, f"refusing {spec!r}: {why}; an untrusted mechanism file may only name the functions "
        f"pinclear offers to data files; trust the file to run its own code (pinclear.load(..., trust=True), "
        f"--trust on the command line, or {TRUST_ENV}=1)", choices=list(OFFERED))


def resolve_function(spec, file, key, trust=None):
    """'package.module:function' -> the function, through the trust gate (module docstring)."""
    if not isinstance(spec, str) or spec.count(":") != 1:
        raise ModelFileError(file, key, f"expected 'module:function', got {spec!r}")
    mod, attr = spec.split(":", 1)
    if any(not part.isidentifier() for part in mod.split(".") + attr.split(".")):
        raise ModelFileError(file, key, f"{spec!r} is not a 'package.module:function' name")
    if not trusted(trust):
        if spec not in OFFERED:
            _refuse(spec, file, key, "not a function pinclear offers to data files")
        obj = _import(spec, mod, [attr], file, key)
        # defence in depth: the registry names a function of that module, never an import of it
        if not (isinstance(obj, types.FunctionType) and obj.__module__ == mod and obj.__qualname__ == attr):
            _refuse(spec, file, key, "it does not name a function defined in that module")
        return obj
    return _import(spec, mod, attr.split("."), file, key)


def _import(spec, mod, parts, file, key):
    try:
        obj = importlib.import_module(mod)
        for part in parts:
            obj = getattr(obj, part)
    except (ImportError, AttributeError) as exc:
        raise ModelFileError(file, key, f"cannot import {spec!r}: {exc}") from None
    return obj
