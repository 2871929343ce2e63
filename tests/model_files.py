"""Compare a generated model file (URDF or sidecar YAML) with the committed one by value.

The committed urdf/*.urdf and urdf/*.yaml are what a generator (an importer, a builder script, a
mechanism module) wrote on one machine. Their numbers are ``repr`` of floats computed through
rigid-transform chains and libm/numpy trigonometry, whose last bits depend on the build: NumPy
dispatches sin/cos/arctan2 to SVML kernels on AVX-512 CPUs (up to 4 ulp, against glibc's < 1
ulp), Pinocchio's and Eigen's products vectorise differently (FMA or not). A byte-for-byte
comparison therefore fails on a machine whose rounding differs (AMD EPYC: one rpy angle of
cassie_v2.yaml in its 17th digit, 0.07225343999506346 against 0.07225343999506345).

What is compared exactly: the structure (XML elements and attribute names; YAML mappings, keys,
list lengths), every string, every integer and boolean, and the text of the comments (with their
numbers read as numbers). Floats agree within a bound from the computation that produced them:

    |got - ref| <= ULPS * eps * S

* ULPS = 64. A number of these files ends a chain of at most about 12 roundings-heavy steps: the
  importer's world placement of a body composes the file's relative poses along the tree (depth
  <= 9, cassie's report says "depth 9"), then the frame relative to its parent F[p]^-1 F[c] (two
  more) and the rpy extraction (one). Each composition rounds an entry of R or p by at most about
  3 eps of the magnitudes entering it (a 3-term dot product and the translation's addition), and
  each sin/cos/atan2 adds up to 4 ulp (SVML) : 12 x (3 + 1) + 4 = 52 < 64. The generators of the
  other bundled files (trigonometry of typed dimensions, a few products) have shorter chains.
* S, the magnitude the error scales with (not the number itself: a coordinate near 0 is a
  difference of placements, its error is absolute):
  - a translation (``xyz`` of an origin or a frame): L, the file's largest translation coordinate
    (the placements being composed and subtracted are of that size);
  - an inertia moment: the largest moment of its tensor (R I R^T mixes them);
  - the entries of any other vector (axis, gravity, box size, scale): the vector's largest entry;
  - a scalar: its own magnitude;
  - an ``rpy`` triple: angles from atan2 of rotation entries with absolute errors ULPS eps. The
    pitch asin-like term has unit radius, S = 1; roll = atan2(R21, R22) and yaw = atan2(R10, R00)
    have radius |cos pitch|, S = 1 / |cos pitch| (the Euler angles' condition near gimbal lock).
    Angles are compared modulo 2 pi (a yaw at +-pi may come out on either side).
* Numbers a generator rounds before writing them (the ``parameters`` tables and ``initial``
  positions: round(x, 6), f"{x:.6g}", f"{x:.12g}", round(q, 12)) may also be one unit of their
  last kept digit apart: a computed value within its rounding error of a tie rounds to either
  neighbour.

A real change of a model (a moved frame, a different mass) is orders of magnitude above this
bound: at L = 0.5 m the translation bound is 64 * 2.2e-16 * 0.5 = 7e-15 m.
"""
from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from decimal import Decimal
from pathlib import Path

import numpy as np
import yaml

EPS = float(np.finfo(float).eps)
ULPS = 64
#: a float literal as repr / yaml write it (ints are compared exactly as numbers too)
NUMBER = re.compile(r"(?<![\w.])[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?(?![\w.])")
INERTIA = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
#: sidecar keys whose numbers the generators round (parameter tables, initial positions)
ROUNDED = ("parameters", "initial")


def _text(x) -> str:
    return Path(x).read_text() if isinstance(x, Path) else str(x)


def _close(a: float, b: float, scale: float) -> bool:
    return a == b or abs(a - b) <= ULPS * EPS * scale


def _angles_close(got, ref) -> bool:
    """rpy triples: pitch with S = 1, roll and yaw with S = 1 / |cos pitch|, modulo 2 pi."""
    cond = 1.0 / max(abs(math.cos(ref[1])), 1e-300)
    for k, (a, b) in enumerate(zip(got, ref)):
        d = abs(math.remainder(a - b, 2 * math.pi))
        if d > ULPS * EPS * (1.0 if k == 1 else cond):
            return False
    return True


def _free_text(got: str, ref: str, where: str):
    """Text (comments, a prolog) equal with its numbers read as numbers (relative bound)."""
    gs, rs = NUMBER.split(got), NUMBER.split(ref)
    gn, rn = NUMBER.findall(got), NUMBER.findall(ref)
    assert gs == rs and len(gn) == len(rn), f"{where}: text differs:\n{got!r}\n{ref!r}"
    for a, b in zip(gn, rn):
        if a != b:
            x, y = float(a), float(b)
            assert _close(x, y, max(abs(x), abs(y))), f"{where}: {a} != {b}"


# ----------------------------------------------------------------------------- YAML
def _yaml_lengths(doc) -> float:
    """L: the largest |xyz| coordinate of the document."""
    out = [0.0]

    def walk(x):
        if isinstance(x, dict):
            for k, v in x.items():
                if k == "xyz" and isinstance(v, list):
                    out.extend(abs(float(e)) for e in v)
                walk(v)
        elif isinstance(x, list):
            for e in x:
                walk(e)

    walk(doc)
    return max(out)


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _numbers(x) -> bool:
    """A non-empty list of numbers."""
    return isinstance(x, list) and bool(x) and all(map(_is_number, x))


def _rounded_close(a: float, b: float) -> bool:
    """``b`` as a generator rounded it (round(x, 6), f"{x:.6g}", f"{x:.12g}", round(q, 12) in the
    parameter tables and initial positions): when the computed value sits within its rounding
    error of a tie, a 1-ulp difference moves the kept value to the neighbour, one unit of the
    last kept digit away. Only for a reference printed with 6 or more significant digits (what
    the generators round to); a short typed constant (0.1, 0.35) keeps the ulp bound."""
    digits = Decimal(repr(b)).normalize().as_tuple().digits
    n = len(digits)
    if not 6 <= n < 16:
        return False
    unit = 10.0 ** (Decimal(repr(b)).adjusted() - n + 1)
    return abs(a - b) <= 1.01 * unit


def _float_close(a, b, scale, rounded) -> bool:
    return _close(a, b, scale) or (rounded and _rounded_close(a, b))


def _data_same(got, ref, where, L, rounded=False):
    assert type(got) is type(ref), f"{where}: {type(got).__name__} {got!r} != {type(ref).__name__} {ref!r}"
    if isinstance(ref, dict):
        assert list(got) == list(ref), f"{where}: keys {list(got)} != {list(ref)}"
        for k in ref:
            g, r = got[k], ref[k]
            vector = _numbers(r) and _numbers(g) and len(g) == len(r)
            if k == "rpy" and vector and len(r) == 3:
                assert _angles_close(g, r), f"{where}.rpy: {g} != {r}"
            elif k == "xyz" and vector:
                assert all(_close(a, b, L) for a, b in zip(g, r)), f"{where}.xyz: {g} != {r}"
            else:
                _data_same(g, r, f"{where}.{k}", L, rounded or k in ROUNDED)
    elif isinstance(ref, list):
        assert len(got) == len(ref), f"{where}: {len(got)} items != {len(ref)}"
        if ref and all(isinstance(e, float) for e in ref):
            S = max(abs(e) for e in ref)
            assert all(isinstance(a, float) and _float_close(a, b, S, rounded) for a, b in zip(got, ref)), \
                f"{where}: {got} != {ref}"
        else:
            for i, (g, r) in enumerate(zip(got, ref)):
                _data_same(g, r, f"{where}[{i}]", L, rounded)
    elif isinstance(ref, float):
        assert _float_close(got, ref, abs(ref), rounded), f"{where}: {got!r} != {ref!r}"
    else:
        assert got == ref, f"{where}: {got!r} != {ref!r}"


def assert_same_data(got, ref, name="data", rounded=False):
    """Two parsed documents (dicts, lists, numbers, strings) equal by value; ``rounded``: the
    numbers are a generator's rounded ones throughout (a parameter table)."""
    _data_same(got, ref, name, _yaml_lengths(ref), rounded)


def _comments(text) -> str:
    return "\n".join(line for line in text.splitlines() if line.lstrip().startswith("#"))


def assert_same_yaml(got, ref, name="yaml"):
    """Two sidecar YAMLs (texts or Paths) equal by value (module docstring)."""
    g, r = _text(got), _text(ref)
    _free_text(_comments(g), _comments(r), f"{name} comments")
    rd = yaml.safe_load(r)
    _data_same(yaml.safe_load(g), rd, name, _yaml_lengths(rd))


# ----------------------------------------------------------------------------- URDF
def _floats(value):
    """The attribute's numbers, or None when it is not a list of numbers."""
    toks = value.split()
    try:
        return [float(t) for t in toks] if toks else None
    except ValueError:
        return None


def _urdf_lengths(root) -> float:
    out = [0.0]
    for el in root.iter("origin"):
        out.extend(abs(x) for x in _floats(el.get("xyz", "0 0 0")) or [])
    return max(out)


def _xml_same(g, r, where, L):
    assert g.tag == r.tag, f"{where}: <{g.tag}> != <{r.tag}>"
    here = f"{where}/{r.tag}" + (f"[{r.get('name')}]" if r.get("name") else "")
    if r.tag is ET.Comment:
        _free_text(g.text or "", r.text or "", f"{where} comment")
    else:
        assert sorted(g.attrib) == sorted(r.attrib), f"{here}: attributes {sorted(g.attrib)} != {sorted(r.attrib)}"
        tensor = [abs(float(r.get(k))) for k in INERTIA if r.get(k) is not None] if r.tag == "inertia" else []
        for k, rv in r.attrib.items():
            gv, rn = g.attrib[k], _floats(r.attrib[k])
            gn = _floats(gv)
            if rn is None or gn is None:
                assert gv == rv, f"{here}@{k}: {gv!r} != {rv!r}"
                continue
            assert len(gn) == len(rn), f"{here}@{k}: {gv!r} != {rv!r}"
            if k == "rpy" and len(rn) == 3:
                ok = _angles_close(gn, rn)
            else:
                S = L if (k == "xyz" and r.tag == "origin") else max(tensor) if k in INERTIA else max(map(abs, rn))
                ok = all(_close(a, b, S) for a, b in zip(gn, rn))
            assert ok, f"{here}@{k}: {gv!r} != {rv!r}"
        assert (g.text or "").strip() == (r.text or "").strip(), f"{here}: text {g.text!r} != {r.text!r}"
    assert (g.tail or "").strip() == (r.tail or "").strip(), f"{here}: tail {g.tail!r} != {r.tail!r}"
    assert len(g) == len(r), f"{here}: {len(g)} children != {len(r)}"
    for a, b in zip(g, r):
        _xml_same(a, b, here, L)


def _parse(text):
    return ET.fromstring(text, parser=ET.XMLParser(target=ET.TreeBuilder(insert_comments=True)))


def assert_same_urdf(got, ref, name="urdf"):
    """Two URDFs (texts or Paths) equal by value (module docstring); the prolog (XML declaration
    and the comments before the root element, which the parser drops) as text."""
    g, r = _text(got), _text(ref)
    _free_text(g[: g.index("<robot")], r[: r.index("<robot")], f"{name} prolog")
    rr = _parse(r)
    _xml_same(_parse(g), rr, name, _urdf_lengths(rr))


def assert_same_model_file(got, ref, name=None):
    """By the reference's suffix (a Path) or the content: URDF or YAML."""
    name = name or (Path(ref).name if isinstance(ref, Path) else "file")
    r = _text(ref)
    if (isinstance(ref, Path) and ref.suffix == ".urdf") or r.lstrip().startswith("<?xml"):
        assert_same_urdf(got, ref, name)
    else:
        assert_same_yaml(got, ref, name)
