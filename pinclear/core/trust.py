"""The trust gate: which Python functions a data file may name (docs/security.md).

A mechanism file may name functions as ``module:function`` (drive laws, platform motions, the
load hook, the screw method's inverse kinematics, motions and virtual-joint rules). Without the
user's consent (``trust=True``, ``--trust``, PINCLEAR_TRUST=1) a name must be one of
:data:`OFFERED`, the functions pinclear itself offers to data files; the name is checked as a
string before anything is imported, and the object found must be a plain function defined in
that very module under that very name. So no attribute chain (``pinclear.model.timelaws:os.spawnv``,
``pinclear.io.sidecar:re.enum.bltns.exec``) and no other pinclear function (``pinclear.cli:main``)
is reachable from an untrusted file. With trust, any importable ``module:attr.path`` resolves:
the user has chosen to run the file's code.
"""
from __future__ import annotations

import importlib
import os
import re
import types
from types import MappingProxyType

from pinclear.core import aliases
from pinclear.core.errors import ModelFileError

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
    "pinclear.dynamics.screw.virtual:line_normal": "screw.virtual rule",
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
    # a file written before the layered layout names the module by its old path: the same function
    mod = aliases.current(mod)
    spec = f"{mod}:{attr}"
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


# --------------------------------------------------------------- what a results file may name
#: sidecar keys that name code or files: a results file may never set them, under --trust too
CODE_AND_FILE_KEYS = frozenset({"function", "hook", "ik", "motions", "virtual", "urdf", "mesh", "meshes",
                                "package_dirs", "filename", "path", "file"})
_FUNCTION_NAME = re.compile(r"^\s*[A-Za-z_][\w.]*\s*:\s*[A-Za-z_][\w.]*\s*$")


def check_recorded_args(load_args, run_file) -> dict:
    """The options, overrides and active clearances recorded in a saved run, refused (one line
    naming the run file and the key) when any could add code or a file to the mechanism: a key
    path through :data:`CODE_AND_FILE_KEYS`, or a value holding such a key or a string spelled
    like a function name (``module:function``, unless offered to data files). ``--trust`` is the
    user's word about the mechanism file named on the command line; nothing recorded in a
    results file may add code, laws or files to it. Returns the keyword arguments for load()."""
    la = load_args if isinstance(load_args, dict) else {}
    out = {}
    for part in ("options", "overrides"):
        rec = la.get(part)
        if rec in (None, {}):
            out[part] = None
            continue
        if not isinstance(rec, dict):
            raise ModelFileError(str(run_file), f"load_args.{part}", f"expected a mapping, got {type(rec).__name__}")
        for k, v in rec.items():
            _refuse_code(k, v, run_file, f"load_args.{part}.{k}")
        out[part] = rec
    cl = la.get("clearances")
    if cl not in (None, []) and not (isinstance(cl, list) and all(isinstance(c, str) for c in cl)):
        raise ModelFileError(str(run_file), "load_args.clearances", "expected a list of clearance names")
    out["clearances"] = cl or None
    return out


def _refuse_code(key, value, run_file, where, depth=0):
    segments = re.split(r"[.\[\]]+", str(key)) if depth == 0 else [str(key)]
    bad = next((s for s in segments if s in CODE_AND_FILE_KEYS), None)
    if bad is None and isinstance(value, str) and _FUNCTION_NAME.match(value) and value.strip() not in OFFERED:
        bad = "a function name"
    if bad is not None:
        raise ModelFileError(str(run_file), where, f"a saved run may not set {bad!r} (code or a file): a results "
                             "file never adds code, laws or files to a mechanism, with --trust neither; repeat it on "
                             "the command line as your own (plot, view, analyse poincare: --mech FILE --set "
                             "KEY=VALUE, with --trust for code outside pinclear)")
    if depth > 32:
        raise ModelFileError(str(run_file), where, "nested too deeply")
    if isinstance(value, dict):
        for k, v in value.items():
            _refuse_code(k, v, run_file, f"{where}.{k}", depth + 1)
    elif isinstance(value, list):
        for i, v in enumerate(value):
            _refuse_code(i, v, run_file, f"{where}[{i}]", depth + 1)


def recorded_mechanism(meta, run_file, prog=None) -> str:
    """The bundled mechanism a saved run was made with, by name. A path recorded in a results
    file is never opened: a run of any other mechanism file needs the file named by the user
    (``--mech FILE``, ``load_mechanism(path)``); the error quotes only the run file's own text.
    ``prog``: the subcommand asking (``"pinclear plot"``), whose --help the error points to."""
    from pinclear.core.models import available

    how = (f"--mech FILE.yaml, the sidecar the run was made with (see {prog} --help)" if prog else
           "--mech FILE.yaml on the command line, or Trajectory.load_mechanism(path)")
    la = meta.get("load_args") if isinstance(meta.get("load_args"), dict) else {}
    rec = la.get("path") or meta.get("mech_path")
    if not isinstance(rec, str) or not rec:
        raise ModelFileError(str(run_file), "mech_path", f"the run does not name its mechanism file; pass {how}")
    name = rec.replace("\\", "/").rsplit("/", 1)[-1]
    stem = name[:-5] if name.endswith(".yaml") else None
    if stem is None or stem not in available():
        raise ModelFileError(str(run_file), "mech_path", f"the run was made with {rec[:300]!r}, not a bundled "
                             "mechanism: pinclear opens no file a results file names; pass the mechanism file "
                             f"yourself: {how}")
    return stem
