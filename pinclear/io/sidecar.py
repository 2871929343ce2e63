"""Loading a mechanism: URDF spanning tree + YAML sidecar, every name checked against the model."""
from __future__ import annotations

import copy
import re
from pathlib import Path

import numpy as np
import pinocchio as pin
import yaml

from pinclear.core.errors import ModelFileError, PinclearError
from pinclear.core.registry import CLEARANCE_TYPES as CLEARANCE_REGISTRY
from pinclear.core.registry import FORCE_TYPES as FORCE_REGISTRY
from pinclear.core.registry import Entry, Key, Registry, key_names
from pinclear.core.values import check_keys as _check_keys
from pinclear.core.values import joint as _joint
from pinclear.core.values import number as _number
from pinclear.model.closures import CLOSURES, Closure
from pinclear.model.closures import KEYS as CLOSURE_ENTRY_KEYS
from pinclear.model.drives import Drive
from pinclear.model.mechanism import Mechanism
from pinclear.model.timelaws import build_law, resolve_function, trusted

#: nesting levels of a YAML document (the bundled sidecars use 6); deeper input would otherwise
#: exhaust Python's recursion limit in PyYAML's composer
MAX_YAML_DEPTH = 32


class _YAMLRefused(yaml.YAMLError):
    """A YAML document pinclear refuses although it is valid YAML: ``key`` is what to name."""

    def __init__(self, key, message):
        self.key, self.message = key, message
        super().__init__(message)


class _SidecarLoader(yaml.SafeLoader):
    """PyYAML's safe loader without aliases (a 600-byte file of nested aliases expands to
    gigabytes, "billion laughs", and a mechanism file has no use for them), with duplicate keys
    refused (the last would silently win: a closure's ``type`` given twice changed the closure)
    and nesting bounded by MAX_YAML_DEPTH."""

    def __init__(self, stream):
        super().__init__(stream)
        self._depth = 0

    def compose_node(self, parent, index):
        if self.check_event(yaml.events.AliasEvent):
            event = self.peek_event()
            raise _YAMLRefused("yaml", f"line {event.start_mark.line + 1}: YAML aliases (*{event.anchor}) are not "
                               "accepted in a mechanism file; write the value out")
        self._depth += 1
        try:
            if self._depth > MAX_YAML_DEPTH:
                line = self.peek_event().start_mark.line + 1
                raise _YAMLRefused("yaml", f"line {line}: nested more than {MAX_YAML_DEPTH} levels deep (at most "
                                   f"{MAX_YAML_DEPTH})")
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def construct_yaml_int(self, node):
        # judged on the text, before int(): a 5000-digit literal made int() raise past the
        # 4300-digit limit, or float() overflow later inside a reader (pinclear.core.bounded)
        from pinclear.core.bounded import MAX_INT_DIGITS, bounded_int_text

        text = self.construct_scalar(node)
        if not bounded_int_text(text):
            raise _YAMLRefused("yaml", f"line {node.start_mark.line + 1}: an integer of {len(text)} characters; at "
                               f"most {MAX_INT_DIGITS} digits (write a large value as a float, e.g. 1e30)")
        return super().construct_yaml_int(node)

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            seen = {}
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key = self.construct_object(key_node, deep=True)
                line = key_node.start_mark.line + 1
                try:
                    first = seen.get(key)
                except TypeError:            # an unhashable key: PyYAML's own error follows
                    continue
                if first is not None:
                    raise _YAMLRefused(str(key), f"given twice (lines {first} and {line}); a key appears once "
                                       "in a mapping")
                seen[key] = line
        return super().construct_mapping(node, deep)


_SidecarLoader.add_constructor("tag:yaml.org,2002:int", _SidecarLoader.construct_yaml_int)


def yaml_value(text):
    """A YAML value from a string (a --set value, an override) with the sidecar's rules."""
    return yaml.load(text, Loader=_SidecarLoader)


def read_yaml(path, what="sidecar"):
    """A YAML mapping from a file: a regular file read with a byte bound (pinclear.core.bounded), UTF-8,
    no aliases, no duplicate keys, bounded nesting, errors naming the file (and the key)."""
    from pinclear.core.bounded import read_text_bounded

    file = str(Path(path))
    text = read_text_bounded(path, MAX_SIDECAR_BYTES, "path", what)
    if text not in _PARSED:
        try:
            doc = yaml_value(text)
        except _YAMLRefused as exc:
            raise ModelFileError(file, exc.key, exc.message) from None
        except yaml.YAMLError as exc:
            raise ModelFileError(file, "yaml", f"not valid YAML: {' '.join(str(exc).split())}") from None
        if len(_PARSED) >= _PARSED_MAX:
            _PARSED.pop(next(iter(_PARSED)))
        _PARSED[text] = doc
    return copy.deepcopy(_PARSED[text])


#: parsed YAML by file text: the file is read (and checked) on every call, but the same text is
#: parsed once per process (a study loads one sidecar per run, several times: 0.1 s of PyYAML
#: each); callers get their own deep copy
_PARSED: dict = {}
_PARSED_MAX = 64

#: the top-level keys of a sidecar, each parsed by one section parser below (the key reference's
#: first table; the sections' own keys are declared next to what they build)
TOP = (
    Key("name", "string", "-", "the file's stem", doc="the mechanism's name"),
    Key("urdf", "file name", range="beside the sidecar, bundled, or trusted", doc="the URDF of the spanning tree, "
        "relative to the sidecar"),
    Key("description", "string", "-", "", doc="one line"),
    Key("gravity", "[x, y, z]", "m/s^2", [0.0, 0.0, -9.81], "finite", doc="gravity in world axes"),
    Key("baumgarte", "mapping", "1/s", {}, ">= 0", "", "{alpha, beta}: the source's "
        "stabilisation gains (simulate(alpha=..., beta=...) wins)"),
    Key("initial", "mapping", "-", {}, doc="{q: {JOINT: value}, v: {JOINT: value}}: the assembly guess (below)"),
    Key("closures", "list", "-", [], doc="loop closures: the cut joints of the tree (below)"),
    Key("drives", "list", "-", [], doc="1-DoF joints that follow a time law (below)"),
    Key("forces", "list", "-", [], doc="force elements (below)"),
    Key("clearances", "list", "-", [], doc="clearance joints, each replacing a closure when active (below)"),
    Key("platform", "mapping", "-", None, doc="{frame, motion: {function, args}}: the frame the plots and the "
        "screw method follow"),
    Key("options", "mapping", "-", {}, doc="scene switches {NAME: {default, choices, doc}}; \"$NAME\" in drives, "
        "forces and platform stands for the value"),
    Key("hook", "module:function", "-", None, "pinclear.core.trust.OFFERED unless trusted", doc="f(model, options) "
        "edits the model after loading"),
    Key("parameters", "list", "-", [], doc="documentation table: each {name, value, unit, source, note}"),
    Key("screw", "mapping", "-", None, doc="read by pinclear.dynamics.screw only (docs/screw.md)"),
    Key("nonphysical_inertia", "mapping", "-", {}, doc="{JOINT: reason}: a body whose printed inertia breaks the "
        "triangle inequality, kept for reproduction (the reason is required)"),
)
TOP_KEYS = set(key_names(TOP))
_TOP_DEFAULT = {k.name: k.default for k in TOP}
#: a sidecar is a few kilobytes; anything near this is not one
MAX_SIDECAR_BYTES = 1_000_000
CLOSURE_KEYS = set(key_names(CLOSURE_ENTRY_KEYS))
#: closure types read by their own module (no frames): type -> "module:function(ctx, entry, name)"
CLOSURE_READERS = Registry("closure reader",
                           {"coupling": Entry("coupling", "pinclear.model.closures:coupling_closure")}, record=Entry)
FRAME = (Key("parent", "link or frame name", doc="what the new frame is fixed to"),
         Key("xyz", "[x, y, z]", "m", [0, 0, 0], "finite", doc="origin in the parent's axes"),
         Key("rpy", "[r, p, y]", "rad", [0, 0, 0], "finite; not with axis", doc="orientation (roll, pitch, yaw)"),
         Key("axis", "[x, y, z]", "-", None, "non-zero; not with rpy", doc="orientation: the frame's z axis (a joint "
             "axis), x and y chosen"),
         Key("name", "string", "-", "<entry>.<key>", "a new frame name", doc="the frame's name"))
FRAME_KEYS = set(key_names(FRAME))
DRIVE = (Key("name", "string", "-", "the joint's name", doc="the drive's name (its multiplier is lam[NAME])"),
         Key("joint", "joint name", range="a 1-DoF joint of the URDF", doc="the driven joint"),
         Key("law", "time law", "m or rad", range="a time law (below)", doc="the joint coordinate over time: its value "
             "at t = 0 is where assembly starts the joint"))
DRIVE_KEYS = set(key_names(DRIVE))
INITIAL = (Key("q", "mapping", "rad or m", {}, "finite; quaternions and (cos, sin) pairs normalised",
               doc="{JOINT: value or list}: the assembly guess"),
           Key("v", "mapping", "rad/s or m/s", {}, "finite", doc="{JOINT: value or list}: initial velocities "
               "(projected to consistency)"))
PLATFORM = (Key("frame", "frame", doc="the platform frame: a frame name or {parent, xyz, rpy | axis, name}"),
            Key("motion", "mapping", "-", None, doc="{function: module:function, args: {...}}: the prescribed pose "
                "over time (the screw method, the plots' prescribed path)"))
OPTION = (Key("default", "any", doc="the option's value unless --option / options= / an override sets it"),
          Key("choices", "list", "-", None, doc="the values allowed"),
          Key("doc", "string", "-", "", doc="one line"))
PARAMETER = (Key("name", "string"), Key("value", "any"), Key("unit", "string"),
             Key("source", "string", doc="where the value comes from (paper, section)"),
             Key("note", "string", "-", "", doc="free text"))
BAUMGARTE = (Key("alpha", "number", "1/s", "the formulation's (5)", ">= 0", "formulations/lagrange.py: gamma = "
                 "-(dJ v) - 2 alpha dPhi - beta^2 Phi", "velocity gain"),
             Key("beta", "number", "1/s", "the formulation's (5)", ">= 0", "formulations/lagrange.py: gamma = "
                 "-(dJ v) - 2 alpha dPhi - beta^2 Phi", "position gain"))
FORCE_TYPES = FORCE_REGISTRY
CLEARANCE_TYPES = CLEARANCE_REGISTRY


def allowed_roots(sidecar_path) -> list:
    """Folders an untrusted mechanism file may read from: its own folder, pinclear's bundled
    models and example-robot-data's model folder."""
    from pinclear.core.models import example_robot_data_dir, models_dir

    roots = [Path(sidecar_path).resolve().parent, models_dir().resolve()]
    erd = example_robot_data_dir()
    if erd is not None:
        roots.append(erd)
    return roots


def _vec3(x, file, key, direction=False):
    """Three finite numbers; with ``direction`` (an axis, a plane normal) also of non-zero length."""
    try:
        a = np.asarray(x, float).reshape(3)
    except (TypeError, ValueError):
        raise ModelFileError(file, key, f"expected 3 numbers, got {x!r}") from None
    if not np.all(np.isfinite(a)):
        raise ModelFileError(file, key, f"expected 3 finite numbers, got {x!r}")
    if direction:
        n = np.linalg.norm(a)
        if not (n > 0 and np.all(np.isfinite(a / n))):
            raise ModelFileError(file, key, f"{x!r} has no direction: give a non-zero vector (any length, it is "
                                 "normalised)")
    return a


def _unit_parts(model, jm, arr, file, key, given):
    """A joint configuration whose coordinates hold a unit quaternion or a (cos, sin) pair (free
    flyer, spherical, unbounded revolute, planar joints), normalised; a zero quaternion or pair
    has no rotation to normalise to and is refused (Pinocchio keeps it, and every rotation of
    that joint is then the zero matrix)."""
    q = pin.neutral(model)
    q[jm.idx_q:jm.idx_q + jm.nq] = arr
    q = pin.normalize(model, q)
    if not pin.isNormalized(model, q, 1e-10):
        raise ModelFileError(file, key, f"{given!r}: the {jm.shortname()} coordinates hold a unit quaternion or a "
                             "(cos, sin) pair of zero length; give a non-zero one (it is normalised)")
    return q[jm.idx_q:jm.idx_q + jm.nq]


def _check_finite(obj, file, key):
    """Refuse NaN and inf anywhere in a sidecar value (no key of a mechanism file means 'not a
    number'); the key path is that of load()'s overrides (``closures[0].length``)."""
    if isinstance(obj, float) and not np.isfinite(obj):
        raise ModelFileError(file, key or "value", f"{obj!r} is not finite: every number of a mechanism file "
                             "is a finite number")
    if isinstance(obj, dict):
        for k, v in obj.items():
            _check_finite(v, file, f"{key}.{k}" if key else str(k))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            _check_finite(v, file, f"{key}[{i}]")


def _rotation_z_to(axis):
    """A rotation whose z column is ``axis``."""
    z = axis / np.linalg.norm(axis)
    a = np.eye(3)[np.argmin(np.abs(z))]
    x = np.cross(a, z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def _frame(model, spec, default_name, file, key):
    """Frame id from a name or a {parent, xyz, rpy|axis} mapping (added to the model)."""
    names = [f.name for f in model.frames]
    if isinstance(spec, str):
        if not model.existFrame(spec):
            raise ModelFileError(file, key, f"unknown frame {spec!r}", choices=names)
        return model.getFrameId(spec), spec
    _check_keys(spec, FRAME_KEYS, file, key)
    parent = spec.get("parent")
    if parent is None:
        raise ModelFileError(file, f"{key}.parent", "missing: the link (or frame) the new frame is fixed to")
    if not model.existFrame(parent):
        raise ModelFileError(file, f"{key}.parent", f"unknown link/frame {parent!r}", choices=names)
    pf = model.frames[model.getFrameId(parent)]
    xyz = _vec3(spec.get("xyz", [0, 0, 0]), file, f"{key}.xyz")
    if "rpy" in spec and "axis" in spec:
        raise ModelFileError(file, key, "give either rpy or axis, not both")
    if "axis" in spec:
        R = _rotation_z_to(_vec3(spec["axis"], file, f"{key}.axis", direction=True))
    else:
        R = pin.rpy.rpyToMatrix(_vec3(spec.get("rpy", [0, 0, 0]), file, f"{key}.rpy"))
    name = spec.get("name", default_name)
    if model.existFrame(name):
        raise ModelFileError(file, f"{key}.name", f"frame {name!r} already exists in the model")
    placement = pf.placement * pin.SE3(R, xyz)
    fid = model.addFrame(pin.Frame(name, pf.parentJoint, model.getFrameId(parent), placement,
                                   pin.FrameType.OP_FRAME))
    return fid, name


def _build_model(urdf):
    """pin.Model from a URDF checked first (pinclear.io.urdf_check: bounded size and depth, a tree,
    finite numbers; Pinocchio gets the very text that was checked); urdfdom's own stderr chatter
    is captured into the error message instead of reaching the user's terminal."""
    import os
    import tempfile

    from pinclear.io.urdf_check import checked_urdf_text

    text = checked_urdf_text(urdf)
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        saved = os.dup(2)
        os.dup2(tmp.fileno(), 2)
        try:
            model = pin.buildModelFromXML(text)
            err = None
        except (RuntimeError, ValueError) as exc:
            model, err = None, str(exc).strip()
        finally:
            os.dup2(saved, 2)
            os.close(saved)
        tmp.seek(0)
        chatter = tmp.read().decode(errors="replace").strip()
    if model is None:
        detail = f"{err}; {chatter}" if chatter else err
        raise ModelFileError(str(urdf), "urdf", f"Pinocchio cannot parse it: {' '.join(detail.split())}")
    return model


def check_inertias(model, file, accepted=None, sidecar="<sidecar>"):
    """Every body's inertia must be physically possible: mass >= 0, and where it has mass a
    positive-definite rotational inertia whose principal moments obey the triangle inequality
    (I1 + I2 >= I3 for every ordering). A bad inertia otherwise fails only mid-run.

    ``accepted`` ({joint name: reason}, the sidecar's ``nonphysical_inertia:``) lets a body moved
    by that joint break the triangle inequality only (a paper's printed values kept for
    reproduction); the reason is required and ends up in the mechanism's description."""
    accepted = dict(accepted or {})
    names = list(model.names)
    for jn, why in accepted.items():
        if jn not in names[1:]:
            raise ModelFileError(sidecar, f"nonphysical_inertia.{jn}", "unknown joint", choices=names[1:])
        if not isinstance(why, str) or len(why.split()) < 3:
            raise ModelFileError(sidecar, f"nonphysical_inertia.{jn}", "give the reason (where the values come "
                                 "from and why they are kept)")
    for j in range(1, model.njoints):
        I = model.inertias[j]
        name = model.names[j]
        m = float(I.mass)
        if not np.isfinite(m) or m < 0:
            raise ModelFileError(str(file), f"inertial of the body moved by joint {name!r}", f"mass {m} kg is not >= 0")
        if m == 0:
            continue
        Ic = np.asarray(I.inertia, float)
        if not np.all(np.isfinite(Ic)) or not np.all(np.isfinite(np.asarray(I.lever))):
            raise ModelFileError(str(file), f"inertial of the body moved by joint {name!r}", "non-finite inertia")
        ev = np.linalg.eigvalsh(0.5 * (Ic + Ic.T))
        tol = 1e-9 * max(abs(ev).max(), 1e-300)
        if ev[0] > 0 and ev[0] + ev[1] < ev[2] - tol and name in accepted:
            continue
        if ev[0] <= 0 or ev[0] + ev[1] < ev[2] - tol:
            raise ModelFileError(str(file), f"inertial of the body moved by joint {name!r}",
                                 f"principal moments {ev.tolist()} kg m^2 are not physically possible "
                                 "(each must be positive and at most the sum of the other two)")


def _substitute(obj, opts, file, key):
    if isinstance(obj, dict):
        return {k: _substitute(v, opts, file, f"{key}.{k}") for k, v in obj.items()}
    if isinstance(obj, list):
        return [_substitute(v, opts, file, f"{key}[{i}]") for i, v in enumerate(obj)]
    if isinstance(obj, str) and obj.startswith("$"):
        if obj[1:] not in opts:
            raise ModelFileError(file, key, f"{obj!r} names no scene option", choices=[f"${o}" for o in opts])
        return opts[obj[1:]]
    return obj


def _parse_value(text, key="value"):
    """An override's value: a string is read as a YAML scalar (as on the command line)."""
    if not isinstance(text, str):
        return text
    try:
        return yaml_value(text)
    except _YAMLRefused as exc:
        raise ModelFileError("<override>", key, exc.message) from None
    except yaml.YAMLError as exc:
        raise ModelFileError("<override>", key, f"not a YAML value: {' '.join(str(exc).split())}") from None


_TOKEN = re.compile(r"([^.\[\]]+)|\[([^\]]*)\]")


def parse_key_path(path: str):
    """'drives[crank1_drive].law.coeffs[1]' -> [('key','drives'), ('sel','crank1_drive'), ...]."""
    toks, pos = [], 0
    for m in _TOKEN.finditer(path):
        gap = path[pos:m.start()]
        if gap not in ("", "."):
            raise ModelFileError("<override>", path, f"cannot parse parameter path {path!r} at {gap!r}")
        toks.append(("key", m.group(1)) if m.group(1) is not None else ("sel", m.group(2)))
        pos = m.end()
    if path[pos:] or not toks:
        raise ModelFileError("<override>", path, f"cannot parse parameter path {path!r}")
    return toks


def set_key_path(doc, toks, value, file, path):
    """Set ``value`` at the token path inside the sidecar mapping ``doc``, checking every step:
    a missing key, a list index out of range or an entry name that does not exist is an error
    naming the path and the valid choices."""
    cur = doc
    for i, (kind, tok) in enumerate(toks):
        last = i == len(toks) - 1
        where = path if last else "".join(f".{t}" if k == "key" else f"[{t}]" for k, t in toks[:i + 1]).lstrip(".")
        if kind == "key":
            if not isinstance(cur, dict):
                raise ModelFileError(file, where, f"{tok!r} indexes a {type(cur).__name__}, not a mapping")
            if last:
                cur[tok] = value
                return
            if tok not in cur:
                raise ModelFileError(file, where, "no such key", choices=list(cur))
            cur = cur[tok]
        else:
            if not isinstance(cur, list):
                raise ModelFileError(file, where, f"[{tok}] selects from a list, found a {type(cur).__name__}")
            if re.fullmatch(r"-?\d+", tok):
                j = int(tok)
                if not -len(cur) <= j < len(cur):
                    raise ModelFileError(file, where, f"index {j} out of range (list of {len(cur)})")
            else:
                names = [e.get("name") for e in cur if isinstance(e, dict)]
                if tok not in names:
                    raise ModelFileError(file, where, f"no entry named {tok!r}", choices=[n for n in names if n])
                j = names.index(tok)
            if last:
                cur[j] = value
                return
            cur = cur[j]



def parse_assignments(items, what="--set") -> dict:
    """['KEY=VALUE', ...] -> {KEY: value parsed as a YAML scalar}: the command-line spelling of
    load()'s ``options`` / ``overrides`` (the one parameter language of pinclear)."""
    from pinclear.core.bounded import shown
    from pinclear.core.errors import InputError

    out = {}
    for it in items or []:
        if not isinstance(it, str) or "=" not in it:
            raise InputError(f"{what} expects KEY=VALUE, got {shown(it, 120)}")
        k, v = it.split("=", 1)
        try:
            value = yaml_value(v)
        except _YAMLRefused as exc:
            raise InputError(f"{what} {shown(it, 120)}: {exc.message}") from None
        except yaml.YAMLError as exc:
            raise InputError(f"{what} {shown(it, 120)}: the value is not a YAML scalar ({' '.join(str(exc).split())})") from None
        k = k.strip()
        if k in out and out[k] != value:          # the last one silently won before
            raise InputError(f"{what} {k}={out[k]!r} and {what} {shown(it, 120)} contradict each other: give {k} once")
        out[k] = value
    return out


def check_disjoint(first: dict, second: dict, what1: str, what2: str):
    """Refuse a key given by two options that would each set it (one value was silently kept),
    naming both."""
    from pinclear.core.errors import InputError

    both = sorted(set(first) & set(second), key=str)
    if both:
        k = both[0]
        raise InputError(f"{what1} {k}={first[k]!r} and {what2} {k}={second[k]!r} both set {k}: give it once")


def load(path, options=None, overrides=None, clearances=None, trust=None) -> Mechanism:
    """Load a mechanism: a sidecar (``urdf/<name>.yaml``) and the URDF it names.

    Every key and name is checked; a bad one is one ModelFileError naming the file, the key and
    the valid choices.

    Parameters
    ----------
    path : str or Path
        The sidecar, or a bundled mechanism's name (``"four_bar"``).
    options : dict, optional
        Scene switches declared under the sidecar's ``options:`` (e.g. ``{"limbs": False}``).
    overrides : dict, optional
        ``{"S2.clearance": 5e-4, "limbs": False, ...}``: clearance keys (``NAME.key``), key
        paths (``"forces[spring].k"``) or options.
    clearances : list of str, optional
        Clearance joints to activate, besides those with ``active: true``.
    trust : bool, optional
        A mechanism file may name Python functions (drive laws, platform motions, hooks); unless
        ``trust=True`` (or the environment variable PINCLEAR_TRUST=1) only the functions pinclear
        offers to data files (``pinclear.core.trust.OFFERED``) resolve, since importing a module
        runs its code (docs/security.md).

    Returns
    -------
    Mechanism
        The immutable description (``mech.replace(...)`` derives variants).
    """
    try:
        return _load(path, options, overrides, clearances, trust)
    except (TypeError, AttributeError, KeyError, IndexError, ValueError) as exc:
        if isinstance(exc, PinclearError):
            raise
        # a value of the wrong shape somewhere the checks above did not foresee: still one clear
        # line naming the file, never a traceback
        raise ModelFileError(str(path), "sidecar", f"malformed value ({type(exc).__name__}: "
                             f"{' '.join(str(exc).split())[:200]})") from None


class Context:
    """What a section parser reads besides its entry: the model (frames are added to it), the
    file, the trust gate, and the entry's key path and name (``at``). A force element type's
    parser (pinclear.core.registry.PluginType.parse) gets one."""

    def __init__(self, model, file, trust, key="", name=""):
        self.model, self.file, self.trust, self.key, self.name = model, file, trust, key, name

    def at(self, key, name):
        return Context(self.model, self.file, self.trust, key, name)

    def error(self, sub, message, choices=None):
        return ModelFileError(self.file, f"{self.key}.{sub}" if sub else self.key, message, choices=choices)

    def frame(self, spec, sub):
        """(frame id, name) of a frame name or a {parent, xyz, rpy|axis} mapping (added to the
        model, named NAME.SUB unless it says)."""
        return _frame(self.model, spec, f"{self.name}.{sub}", self.file, f"{self.key}.{sub}")

    def joint(self, name, sub, one_dof=False):
        return _joint(self.model, name, self.file, f"{self.key}.{sub}", one_dof=one_dof)

    def law(self, spec, sub):
        return build_law(spec, self.file, f"{self.key}.{sub}", self.trust)


def _load(path, options, overrides, clearances, trust) -> Mechanism:
    from pinclear.core.models import model_path

    path = model_path(path)
    file = str(path)
    trust = trusted(trust)
    sc, all_overrides = _read_sidecar(path, overrides)
    model = _model(sc, path, trust)
    name = sc.get("name", path.stem)
    opts, clr_overrides, clr_specs, clr_names = _scene_options(sc, file, options, all_overrides)
    if "hook" in sc:
        resolve_function(sc["hook"], file, "hook", trust)(model, opts)
    # "$name" anywhere in drives, forces and platform stands for the scene option's value, so one
    # sidecar serves every variant (e.g. a drive law's args: {law: $law})
    for key in ("drives", "forces", "platform"):
        if key in sc:
            sc[key] = _substitute(sc[key], opts, file, key)
    _baumgarte(sc.get("baumgarte") or {}, file)
    model.gravity.linear = _vec3(sc.get("gravity", _TOP_DEFAULT["gravity"]), file, "gravity")
    ctx = Context(model, file, trust)
    closures = _closures(ctx, sc.get("closures") or [])
    drives = _drives(ctx, sc.get("drives") or [])
    forces = _forces(ctx, sc.get("forces") or [])
    q0, v0 = _initial(ctx, sc.get("initial") or {})
    platform_frame, platform_motion = _platform(ctx, sc["platform"]) if "platform" in sc else (None, None)
    params = _parameters(sc.get("parameters") or [], file)
    chosen = _chosen_clearances(ctx, clr_specs, clr_names, clearances, clr_overrides, closures)
    replaced = _replaced_closures(file, chosen, closures)
    closures = [cl for cl in closures if cl.name not in replaced]

    mech = Mechanism(model, name, closures, drives, forces, q0=q0, v0=v0, path=str(path),
                     platform_frame=platform_frame, platform_motion=platform_motion, options=opts,
                     parameters=params, sidecar=sc, replaced_closures=replaced)
    if chosen:
        from pinclear import contact

        elems = [contact.build(c, mech, file) for _, c in chosen]
        mech = mech.replace(forces=list(mech.forces) + elems)
    # how to load this variant again (saved with every trajectory)
    mech.load_args = {"path": str(path.resolve()), "options": dict(options or {}),
                      "overrides": {k: _parse_value(v) for k, v in all_overrides.items()},
                      "clearances": [c["name"] for _, c in chosen],
                      # read by plug-ins that resolve functions later (screw); never by a reload
                      "trust": trust}
    return mech


def _read_sidecar(path, overrides):
    """The sidecar's mapping (a bare URDF: a minimal one) with the overrides that name a sidecar
    key path ("forces[spring].k", "drives[0].law.terms[0].amp") applied before anything is built
    from it; returns it and every override given."""
    file = str(path)
    if path.suffix.lower() == ".urdf":
        sc = {"name": path.stem, "urdf": path.name}
    else:
        sc = read_yaml(path)
    sc = copy.deepcopy(sc)
    _check_keys(sc, TOP_KEYS, file, "")
    all_overrides = dict(overrides or {})
    for k in [k for k in all_overrides if isinstance(k, str) and re.split(r"[.\[]", k, 1)[0] in TOP_KEYS]:
        set_key_path(sc, parse_key_path(k), _parse_value(all_overrides[k], k), file, k)
    _check_finite(sc, file, "")
    return sc, all_overrides


def _model(sc, path, trust):
    """The Pinocchio model of the sidecar's URDF (read only from the allowed folders unless
    trusted), its inertias checked."""
    file = str(path)
    if "urdf" not in sc:
        raise ModelFileError(file, "urdf", "missing: the URDF file of the spanning tree")
    if not isinstance(sc["urdf"], str):
        raise ModelFileError(file, "urdf", f"expected a file name, got {sc['urdf']!r}")
    urdf = (path.parent / sc["urdf"]).resolve()
    roots = allowed_roots(path)
    if not trust and not any(urdf.is_relative_to(r) for r in roots):
        raise ModelFileError(file, "urdf", f"{sc['urdf']!r} lies outside the folders a mechanism file may read "
                             f"({', '.join(map(str, roots))}); keep the URDF beside its sidecar, or trust the file "
                             "(trust=True, --trust, PINCLEAR_TRUST=1)")
    if not urdf.is_file():
        raise ModelFileError(file, "urdf", f"URDF file {str(urdf)!r} does not exist")
    model = _build_model(urdf)
    accepted = sc.get("nonphysical_inertia") or {}
    _check_keys(accepted, set(accepted), file, "nonphysical_inertia")
    check_inertias(model, urdf, accepted, file)
    return model


def _scene_options(sc, file, options, overrides):
    """(scene option values, {clearance: {key: value}}, the ``clearances:`` entries, their
    names) from the declared ``options:``, the caller's options and the overrides that are not
    key paths."""
    declared = sc.get("options") or {}
    _check_keys(declared, set(declared), file, "options")
    opts = {}
    for k, spec in declared.items():
        if not isinstance(spec, dict) or "default" not in spec:
            raise ModelFileError(file, f"options.{k}", "each option is a mapping with a 'default'")
        _check_keys(spec, key_names(OPTION), file, f"options.{k}")
        opts[k] = spec["default"]
    clr_specs = sc.get("clearances") or []
    if not isinstance(clr_specs, list):
        raise ModelFileError(file, "clearances", "expected a list")
    clr_names = [c.get("name") for c in clr_specs if isinstance(c, dict)]
    for k, val in dict(options or {}).items():
        if k not in opts:
            raise ModelFileError(file, f"options.{k}", "unknown scene option", choices=list(opts))
        opts[k] = val
    clr_overrides: dict[str, dict] = {}
    for k, val in overrides.items():
        if isinstance(k, str) and re.split(r"[.\[]", k, 1)[0] in TOP_KEYS:
            continue                  # a key path, applied by _read_sidecar
        val = _parse_value(val, k)
        if "." in k:
            cname, key = k.split(".", 1)
            if cname not in clr_names:
                raise ModelFileError(file, f"clearances.{cname}", "unknown clearance joint in override",
                                     choices=clr_names)
            clr_overrides.setdefault(cname, {})[key] = val
        elif k in opts:
            opts[k] = val
        else:
            raise ModelFileError(file, k, "unknown override (a sidecar key path such as forces[NAME].k, NAME.key for "
                                 "a clearance joint, or a scene option)",
                                 choices=list(opts) + [f"{c}.<key>" for c in clr_names] + sorted(TOP_KEYS))
    _check_finite(opts, file, "options")
    _check_finite(clr_overrides, file, "clearances")
    for k, val in opts.items():
        choices = declared[k].get("choices")
        if choices is not None and val not in choices:
            raise ModelFileError(file, f"options.{k}", f"invalid value {val!r}", choices=choices)
    return opts, clr_overrides, clr_specs, clr_names


def _baumgarte(bg, file):
    """The Baumgarte gains of the model's source (read by the formulations that stabilise with them)."""
    _check_keys(bg, key_names(BAUMGARTE), file, "baumgarte")
    for k, val in bg.items():
        if isinstance(val, bool) or not isinstance(val, (int, float)) or not val >= 0.0:
            raise ModelFileError(file, f"baumgarte.{k}", f"expected a number >= 0 [1/s], got {val!r}")


def _closures(ctx, entries):
    """``closures:`` -> [Closure]; each type's geometry is its pinclear.model.closures.CLOSURES record."""
    file, model = ctx.file, ctx.model
    closures, seen = [], set()
    for i, c in enumerate(entries):
        key = f"closures[{i}]"
        ctype = c.get("type") if isinstance(c, dict) else None
        if ctype in CLOSURE_READERS:
            cname = c.get("name", f"loop{i}")
            if cname in seen:
                raise ModelFileError(file, f"{key}.name", f"duplicate closure name {cname!r}")
            seen.add(cname)
            closures.append(CLOSURE_READERS[ctype](model, c, file, key, cname))
            continue
        _check_keys(c, CLOSURE_KEYS, file, key)
        cname = c.get("name", f"loop{i}")
        if cname in seen:
            raise ModelFileError(file, f"{key}.name", f"duplicate closure name {cname!r}")
        seen.add(cname)
        if ctype not in CLOSURES:
            raise ModelFileError(file, f"{key}.type", f"unknown closure type {ctype!r}", choices=CLOSURES)
        for fk in ("frame1", "frame2"):
            if fk not in c:
                raise ModelFileError(file, f"{key}.{fk}", "missing")
        here = ctx.at(key, cname)
        f1, n1 = here.frame(c["frame1"], "frame1")
        f2, n2 = here.frame(c["frame2"], "frame2")
        if model.frames[f1].parentJoint == model.frames[f2].parentJoint:
            raise ModelFileError(file, key, "frame1 and frame2 are on the same body: nothing to close")
        for req in CLOSURES[ctype].required:
            if req not in c:
                raise ModelFileError(file, f"{key}.{req}", f"missing for a {ctype} closure")
        # |p1 - p2| = 0 has no gradient at its solution: a distance is > 0 (a spherical closure is L = 0)
        length = _number(c.get("length", 0.0), file, f"{key}.length", positive=ctype == "distance")
        closures.append(Closure(cname, ctype, n1, n2, f1, f2,
                                normal=_vec3(c.get("normal", [0, 0, 1]), file, f"{key}.normal", direction=True),
                                length=length))
    return closures


def _drives(ctx, entries):
    """``drives:`` -> [Drive], at most one per joint."""
    file = ctx.file
    drives = []
    for i, d in enumerate(entries):
        key = f"drives[{i}]"
        _check_keys(d, DRIVE_KEYS, file, key)
        here = ctx.at(key, d.get("name"))
        jm = here.joint(d.get("joint"), "joint", one_dof=True)
        if "law" not in d:
            raise ModelFileError(file, f"{key}.law", "missing")
        drives.append(Drive(d.get("name", d["joint"]), d["joint"], jm.idx_q, jm.idx_v, here.law(d["law"], "law")))
    if len({d.idx_v for d in drives}) != len(drives):
        raise ModelFileError(file, "drives", "two drives act on the same joint")
    return drives


def _forces(ctx, entries):
    """``forces:`` -> [ForceElement], each built by its type's parser (pinclear.core.registry.FORCE_TYPES)."""
    file = ctx.file
    forces = []
    for i, f in enumerate(entries):
        key = f"forces[{i}]"
        ftype = f.get("type") if isinstance(f, dict) else None
        if ftype not in FORCE_TYPES:
            raise ModelFileError(file, f"{key}.type", f"unknown force element type {ftype!r}",
                                 choices=FORCE_TYPES.names())
        _check_keys(f, FORCE_TYPES.allowed(ftype), file, key)
        try:
            forces.append(FORCE_TYPES.get(ftype).parse(f, ctx.at(key, f.get("name", f"{ftype}{i}"))))
        except KeyError as exc:
            raise ModelFileError(file, f"{key}.{exc.args[0]}", "missing") from None
        except (TypeError, ValueError) as exc:
            if isinstance(exc, ModelFileError):
                raise
            raise ModelFileError(file, key, f"bad value: {exc}") from None
    return forces


def _initial(ctx, init):
    """(q0, v0): the neutral configuration and zero velocity with ``initial:``'s joints set."""
    model, file = ctx.model, ctx.file
    q0, v0 = pin.neutral(model), np.zeros(model.nv)
    _check_keys(init, key_names(INITIAL), file, "initial")
    for which, vec in (("q", q0), ("v", v0)):
        for jn, val in (init.get(which) or {}).items():
            jm = _joint(model, jn, file, f"initial.{which}.{jn}")
            idx, n = (jm.idx_q, jm.nq) if which == "q" else (jm.idx_v, jm.nv)
            try:
                arr = np.atleast_1d(np.asarray(val, float))
            except (TypeError, ValueError):
                raise ModelFileError(file, f"initial.{which}.{jn}", f"expected {n} number(s), got {val!r}") from None
            if arr.size != n or not np.all(np.isfinite(arr)):
                raise ModelFileError(file, f"initial.{which}.{jn}", f"expected {n} finite number(s), got {val!r}")
            if which == "q" and jm.nq != jm.nv:
                arr = _unit_parts(model, jm, arr, file, f"initial.q.{jn}", val)
            vec[idx:idx + n] = arr
    return q0, v0


def _platform(ctx, p):
    """(frame id, motion function or None) of ``platform:``."""
    file = ctx.file
    _check_keys(p, key_names(PLATFORM), file, "platform")
    platform_frame, _ = _frame(ctx.model, p.get("frame"), "platform", file, "platform.frame")
    platform_motion = None
    if "motion" in p:
        m = p["motion"]
        _check_keys(m, {"function", "args"}, file, "platform.motion")
        func = resolve_function(m.get("function"), file, "platform.motion.function", ctx.trust)
        args = dict(m.get("args") or {})
        platform_motion = lambda t, _f=func, _a=args: _f(t, **_a)  # noqa: E731
    return platform_frame, platform_motion


def _parameters(params, file):
    """``parameters:``, a documentation table: each entry has name, value, unit and source."""
    for i, prm in enumerate(params):
        _check_keys(prm, key_names(PARAMETER), file, f"parameters[{i}]")
        for k in [k.name for k in PARAMETER if k.required]:
            if k not in prm:
                raise ModelFileError(file, f"parameters[{i}].{k}", "missing (each parameter has name, value, "
                                     "unit and source)")
    return params


def _unknown_clearance(ctx, name, clr_names, closures):
    """The error for ``--clearance NAME`` that names no clearance joint: what NAME is instead
    (a tree joint, a closure without a clearances: entry) and what to do."""
    file, model = ctx.file, ctx.model
    if isinstance(name, str) and model.existJointName(name):
        cut = sorted({c for t in CLEARANCE_TYPES.types() for c in t.replaces})
        return ModelFileError(file, "clearances", f"{name!r} is a joint of the URDF tree: a clearance replaces a cut "
                              "joint (a closure of the sidecar's closures:). Make it a cut joint: leave the joint out "
                              "of the URDF (choose the spanning tree so that its child link hangs from its other "
                              "joints), add a closures: entry joining a frame on each of its two links (type "
                              f"{', '.join(cut)}) and a clearances: entry naming that closure", choices=clr_names)
    if name in {cl.name for cl in closures}:
        return ModelFileError(file, "clearances", f"closure {name!r} has no clearances: entry; add one such as "
                              f"{{name: {name}, type: planar_revolute, closure: {name}, clearance: 1.0e-4}}",
                              choices=clr_names)
    return ModelFileError(file, "clearances", f"unknown clearance joint {name!r}", choices=clr_names)


def _chosen_clearances(ctx, clr_specs, clr_names, clearances, clr_overrides, closures):
    """[(index, entry with its overrides)] of the clearance joints to activate: those named by
    the caller and those with ``active: true``."""
    file = ctx.file
    active = set(clearances or [])
    unknown = active - set(clr_names)
    if unknown:
        raise _unknown_clearance(ctx, sorted(unknown)[0], clr_names, closures)
    on = active | {c["name"] for c in clr_specs if isinstance(c, dict) and c.get("active", False)}
    idle = sorted(set(clr_overrides) - on)
    if idle:
        raise ModelFileError(file, f"clearances.{idle[0]}", "an override names an inactive clearance joint: it "
                             f"would change nothing (activate it with --clearance {idle[0]} / clearances=[...])",
                             choices=sorted(on))
    chosen = []
    for i, c in enumerate(clr_specs):
        if not isinstance(c, dict) or "name" not in c:
            raise ModelFileError(file, f"clearances[{i}]", "each clearance is a mapping with a 'name'")
        c = {**c, **clr_overrides.get(c["name"], {})}
        if c["name"] in active or c.get("active", False):
            ctype = c.get("type")
            if ctype not in CLEARANCE_TYPES:
                raise ModelFileError(file, f"clearances[{i}].type", f"unknown clearance type {ctype!r}",
                                     choices=CLEARANCE_TYPES.names())
            chosen.append((i, c))
    return chosen


def _replaced_closures(file, chosen, closures):
    """{closure name: Closure} of the closures the chosen clearance joints replace."""
    replaced = {}
    for i, c in chosen:
        target = c.get("closure")
        match = [cl for cl in closures if cl.name == target]
        if not match:
            raise ModelFileError(file, f"clearances[{i}].closure", f"no closure named {target!r} to replace",
                                 choices=[cl.name for cl in closures])
        replaced[target] = match[0]
    return replaced
