"""Registries of plug-in kinds (pinclear.core.registry) and the key reference generated from them.

A new force element, a new clearance type and a new integrator are each one module plus one
registry line: the toy types below are defined here (the module), registered with one ``add``
call (the line), loaded from a sidecar and simulated, and their physics (the integrator's order
of convergence) checked against closed forms. The key
reference docs/keys.md is regenerated and compared with the committed file; the declared
defaults are checked against what the builders do when a key is left out."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from pinclear.contact.base import ClearanceJoint
from pinclear.contact.laws import (
    FRICTION_LAWS,
    NORMAL_LAWS,
    make_friction_law,
    make_normal_law,
)
from pinclear.contact.spec import COMMON, FRICTION_LAW_KEYS, NORMAL_LAW_KEYS
from pinclear.core.errors import ContactSetupError, ModelFileError
from pinclear.core.registry import (
    CLEARANCE_TYPES,
    FORCE_TYPES,
    INTEGRATORS,
    ClearancePlot,
    Key,
    PluginType,
)
from pinclear.dynamics.simulate import simulate
from pinclear.io.sidecar import load
from pinclear.model.forces import ForceElement

ROOT = Path(__file__).resolve().parents[2]


# ------------------------------------------------------------------ a toy force element (its "module")
class JointSpring(ForceElement):
    """tau_j = -k (q_j - rest) on a 1-DoF joint: a conservative linear spring in joint space."""

    def __init__(self, name, idx_q, idx_v, k, rest):
        self.name, self.iq, self.iv, self.k, self.rest = name, int(idx_q), int(idx_v), float(k), float(rest)
        self._freeze()

    def add_force(self, mech, ws, d, t, q, v, z, tau, zdot):
        tau[self.iv] -= self.k * (q[self.iq] - self.rest)

    def potential(self, mech, ws, d, q):
        return 0.5 * self.k * (q[self.iq] - self.rest) ** 2


def parse_joint_spring(f, ctx):
    jm = ctx.joint(f["joint"], "joint", one_dof=True)
    return JointSpring(ctx.name, jm.idx_q, jm.idx_v, f["k"], JOINT_SPRING.value(f, "rest"))


JOINT_SPRING = PluginType("toy_joint_spring", parse=parse_joint_spring, doc="tau = -k (q - rest)",
                          keys=(Key("joint", "joint name"), Key("k", "number", "N/m"),
                                Key("rest", "number", "m", 0.0)))


# ------------------------------------------------------------------ a toy clearance type (its "module")
class DistanceGap(ClearanceJoint):
    """A distance closure with play: |p2 - p1| may range over [L - c, L + c]; beyond, the normal
    law pushes back along the line (two channels: the stretch stop and the compression stop).
    Geometry in Python (no compiled twin): the run calls it through a Python stage."""

    kind = "toy_gap"

    def __init__(self, name, model, f1, f2, L, clearance, law, friction, **kw):
        super().__init__(name, model, f1, f2, 2, friction, **kw)
        self.L, self.c, self.law = float(L), float(clearance), law
        self._freeze()

    def _channel_laws(self):
        return (self.law, self.law)

    def _geometry(self, data, d):
        p1, p2 = data.oMf[self.f1].translation, data.oMf[self.f2].translation
        e = p2 - p1
        r = float(np.linalg.norm(e))
        n = e / r
        # d|e|/dt = n . (v2(p2) - v1(p1)): each channel's normal rate is its penetration rate
        d.delta[:] = (r - (self.L + self.c), (self.L - self.c) - r)
        d.n[0], d.n[1] = n, -n
        d.p1[:] = p1
        d.p2[:] = p2


def parse_distance_gap(sp, mech, closure):
    law = sp.normal_law(K=sp.number("stiffness"))
    return DistanceGap(sp.name, mech.model, closure.f1, closure.f2, closure.length, sp.clearance(), law,
                       sp.friction_law(), **sp.common(sp.clearance()))


DISTANCE_GAP = PluginType("toy_gap", parse=parse_distance_gap, replaces=("distance",), keys=(),
                          doc="a distance with play", plot=ClearancePlot(False, False, "circle", "end"))


# ------------------------------------------------------------------ the model
URDF = """<?xml version="1.0"?>
<robot name="toy_slide">
  <link name="world"/>
  <joint name="slide" type="prismatic"><parent link="world"/><child link="slider"/><origin xyz="0 0 0" rpy="0 0 0"/>
    <axis xyz="1 0 0"/><limit lower="-10" upper="10" effort="1e6" velocity="1e6"/></joint>
  <link name="slider"><inertial><origin xyz="0 0 0" rpy="0 0 0"/><mass value="{m}"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
</robot>
"""
M = 2.0
#: the slider's distance closure D from the origin (the toy clearance type replaces it)
DISTANCE = ("closures:\n  - {{name: D, type: distance, frame1: {{parent: world, name: anchor}}, "
            "frame2: {{parent: slider, name: tip}}, length: {L}}}\n")
GAP = "clearances:\n  - {{name: D, type: toy_gap, closure: D, clearance: {c}, stiffness: {K}{extra}}}\n"


def _files(tmp_path, body):
    (tmp_path / "toy_slide.urdf").write_text(URDF.format(m=M))
    path = tmp_path / "toy.yaml"
    path.write_text("name: toy\nurdf: toy_slide.urdf\ngravity: [0, 0, 0]\n" + body)
    return path


@pytest.fixture
def toys():
    FORCE_TYPES.add(JOINT_SPRING)
    CLEARANCE_TYPES.add(DISTANCE_GAP)
    try:
        yield
    finally:
        FORCE_TYPES.remove("toy_joint_spring")
        CLEARANCE_TYPES.remove("toy_gap")


def test_a_toy_force_element_loads_from_a_sidecar_and_conserves_energy(toys, tmp_path):
    """m x'' = -k (x - rest): x = rest + A cos(w t), w = sqrt(k/m), and 1/2 m v^2 + 1/2 k (x - rest)^2
    stays 1/2 k A^2. RK45 at rtol 1e-10 keeps the global error near 1e-10 of the amplitude over
    2 periods; 1e-7 (relative) leaves a thousandfold margin and still catches a wrong sign or
    factor (errors of order A)."""
    k, rest, A = 50.0, 0.1, 0.02
    path = _files(tmp_path, f"initial: {{q: {{slide: {rest + A}}}}}\n"
                  f"forces:\n  - {{name: spring, type: toy_joint_spring, joint: slide, k: {k}, rest: {rest}}}\n")
    mech = load(path)
    assert [type(f).__name__ for f in mech.forces] == ["JointSpring"]
    w = math.sqrt(k / M)
    tr = simulate(mech, 2 * 2 * math.pi / w, rtol=1e-10, q0=[rest + A], v0=[0.0], dt_out=0.01)
    assert tr.status == "success", tr.message
    x, v = tr.q[:, 0], tr.v[:, 0]
    assert np.max(np.abs(x - (rest + A * np.cos(w * tr.t)))) < 1e-7 * A
    E = 0.5 * M * v ** 2 + 0.5 * k * (x - rest) ** 2
    assert np.max(np.abs(E / (0.5 * k * A * A) - 1.0)) < 1e-7
    assert tr.summary()["energy_balance"]["ok"]


def _gap_exact(t, L, c, v0, w):
    """x(t) of the slider started at the centre L with speed v0 > 0 between stops at L +- c made
    of linear springs of stiffness K = m w^2 (undamped): flights of 2c/v0 at speed +-v0 and half
    oscillations of pi/w with penetration (v0/w) sin(w s)."""
    T = 4 * c / v0 + 2 * math.pi / w
    s = np.mod(t, T)
    t1, t2 = c / v0, c / v0 + math.pi / w
    t3, t4 = t2 + 2 * c / v0, t2 + 2 * c / v0 + math.pi / w
    return np.select([s <= t1, s <= t2, s <= t3, s <= t4],
                     [L + v0 * s, L + c + v0 / w * np.sin(w * (s - t1)), L + c - v0 * (s - t2),
                      L - c - v0 / w * np.sin(w * (s - t3))], L - c + v0 * (s - t4))


def test_a_toy_clearance_type_loads_from_a_sidecar_and_matches_its_closed_form(toys, tmp_path):
    """A distance closure with play c and linear (hertz, n = 1) stops: the slider bounces between
    L - c and L + c, each contact a half oscillation of pi/w (w = sqrt(K/m)) that returns the
    impact speed. Impacts are located as events (exact onsets), so at rtol 1e-10 the error stays
    near 1e-10 of the 0.1 m scale; 1e-8 m catches a wrong normal, stiffness or exit speed
    (errors of order c = 1 mm)."""
    L, c, K, v0 = 0.1, 1e-3, 1e4, 0.05
    path = _files(tmp_path, DISTANCE.format(L=L) + GAP.format(c=c, K=K, extra=", normal_law: {type: hertz, n: 1}"))
    mech = load(path, clearances=["D"])
    assert not mech.closures and [f.kind for f in mech.forces] == ["toy_gap"]
    w = math.sqrt(K / M)
    T = 4 * c / v0 + 2 * math.pi / w
    tr = simulate(mech, 2.5 * T, rtol=1e-10, q0=[L], v0=[v0], assemble=False, dt_out=T / 200)
    assert tr.status == "success", tr.message
    assert np.max(np.abs(tr.q[:, 0] - _gap_exact(tr.t, L, c, v0, w))) < 1e-8
    # undamped stops: the energy audit closes and the element's potential is K d^2/2 at the stops
    assert tr.summary()["energy_balance"]["ok"]


def test_a_clearance_on_a_tree_joint_says_clearances_go_on_cut_joints(toys, tmp_path):
    path = _files(tmp_path, DISTANCE.format(L=0.1) + GAP.format(c=1e-3, K=1e4, extra=""))
    with pytest.raises(ModelFileError) as exc:
        load(path, clearances=["slide"])
    msg = str(exc.value)
    assert "'slide' is a joint of the URDF tree" in msg and "cut joint" in msg and "closures:" in msg
    assert "(valid: D)" in msg


def test_the_command_line_says_so_in_one_line(tmp_path, capsys):
    """`pinclear simulate ... --clearance rod_joint` (a tree joint of the bundled slider-crank)."""
    from pinclear.cli import commands as cli

    argv = ["simulate", "slider_crank_clearance", "--clearance", "rod_joint", "--t-end", "0.01",
            "--out", str(tmp_path)]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "'rod_joint' is a joint of the URDF tree" in err
    assert "Make it a cut joint" in err and err.endswith("(valid: P)")


def test_a_closure_without_a_clearance_entry_says_how_to_add_one(tmp_path):
    path = _files(tmp_path, DISTANCE.format(L=0.1))
    with pytest.raises(ModelFileError, match=r"closure 'D' has no clearances: entry; add one such as"):
        load(path, clearances=["D"])


def test_a_revolute_clearance_on_a_planar_point_closure_names_planar_revolute(tmp_path):
    path = _files(tmp_path, "closures:\n  - {name: P, type: planar_point, frame1: {parent: world, name: bearing}, "
                  "frame2: {parent: slider, name: journal}}\n"
                  "clearances:\n  - {name: P, type: revolute, closure: P, clearance: 1.0e-4}\n")
    with pytest.raises(ContactSetupError) as exc:
        load(path, clearances=["P"])
    msg = str(exc.value)
    assert "a revolute clearance cannot replace the planar_point closure 'P'" in msg
    assert "takes type planar_revolute or lubricated_revolute" in msg
    assert msg.endswith("(valid: lubricated_revolute, planar_revolute)")


# ------------------------------------------------------------------ the key reference
def test_the_key_reference_is_the_code_s():
    """docs/keys.md is what `python -m pinclear.io.keyref --out docs/keys.md` writes today."""
    from pinclear.io.keyref import render

    assert (ROOT / "docs" / "keys.md").read_text(encoding="utf-8") == render(), \
        "docs/keys.md is stale: run python -m pinclear.io.keyref --out docs/keys.md"


def test_every_type_and_key_a_builder_accepts_is_declared():
    """The declared law keys are exactly those the law builders accept: each declared key is taken,
    any other refused; every law type has its table."""
    assert set(FRICTION_LAW_KEYS) == set(FRICTION_LAWS)
    assert NORMAL_LAW_KEYS[0].range == ", ".join(NORMAL_LAWS)
    for typ, keys in FRICTION_LAW_KEYS.items():
        spec = {"type": typ, **{k.name: 0.5 for k in keys if k.required}}
        make_friction_law(spec, mu=0.1)
        for k in keys:
            val = 2e-3 if k.name in ("v0", "Vs") else 0.5
            make_friction_law({**spec, k.name: val}, mu=0.1)
        with pytest.raises(ContactSetupError, match="unknown key"):
            make_friction_law({**spec, "not_a_key": 1.0}, mu=0.1)
    for k in NORMAL_LAW_KEYS[1:]:
        make_normal_law({"type": "lankarani_nikravesh", k.name: {"damping": "flores"}.get(k.name, 0.8)}, K=1e9)
    with pytest.raises(ContactSetupError, match="unknown key"):
        make_normal_law({"type": "lankarani_nikravesh", "not_a_key": 1.0}, K=1e9)


def _numeric(keys):
    return [k for k in keys if isinstance(k.default, (int, float)) and not isinstance(k.default, bool)]


def test_the_declared_law_defaults_are_the_builders():
    """A law built without a key equals the law built with the key at its declared default, and
    differs from one built with another value (so the key is read)."""
    for typ, keys in FRICTION_LAW_KEYS.items():
        base = {"type": typ, **{k.name: 0.3 for k in keys if k.required}}
        for k in _numeric(keys):
            left_out = make_friction_law(base, mu=0.1).kernel_params()
            given = make_friction_law({**base, k.name: k.default}, mu=0.1).kernel_params()
            other = make_friction_law({**base, k.name: 3.0 * k.default + 1e-3}, mu=0.1).kernel_params()
            assert np.array_equal(left_out[1], given[1]) and not np.array_equal(left_out[1], other[1]), (typ, k.name)
    for k in _numeric(NORMAL_LAW_KEYS):
        law = {"type": "lankarani_nikravesh", "ce": 0.8}
        assert make_normal_law(law, K=1e9).kernel_params() == make_normal_law({**law, k.name: k.default},
                                                                             K=1e9).kernel_params()


def test_the_declared_clearance_defaults_are_the_builders():
    """A bundled clearance joint that leaves stiffness and v_impact_min out loads to the same
    element as with both written out at their declared defaults, and to another with other values."""
    declared = {k.name: k.default for k in COMMON}
    bare = load("clr_hinge", clearances=["R"]).forces[-1]
    written = load("clr_hinge", clearances=["R"], overrides={"R.stiffness": declared["stiffness"],
                                                             "R.v_impact_min": declared["v_impact_min"]}).forces[-1]
    other = load("clr_hinge", clearances=["R"], overrides={"R.stiffness": "printed",
                                                           "R.v_impact_min": 2 * declared["v_impact_min"]}).forces[-1]

    def key(el):
        return el.describe(), el.v_impact_min, el.law.kernel_params()

    assert key(bare) == key(written)
    assert key(other)[1] != key(bare)[1] and key(other)[2] != key(bare)[2]


def test_plots_and_viewer_read_the_clearance_registry():
    """Each registered clearance type declares how it is drawn; the slider is the one that travels."""
    plots = {n: CLEARANCE_TYPES.get(n).plot for n in CLEARANCE_TYPES}
    assert all(isinstance(p, ClearancePlot) for p in plots.values())
    assert [n for n, p in plots.items() if p.travel] == ["prismatic"]
    assert {n for n, p in plots.items() if p.across_axis} == {"planar_revolute", "lubricated_revolute", "revolute",
                                                             "prismatic"}


# ------------------------------------------------------------------ a toy integrator (its "module")
def heun_tableau():
    """Heun's method (the explicit trapezoidal rule): second order, two stages (Butcher tableau
    A = [[0, 0], [1, 0]], b = [1/2, 1/2], c = [0, 1]; Hairer, Norsett & Wanner, Solving ODEs I,
    II.1), taken with fixed steps by the compiled RK step (kind RK_FIXED)."""
    from pinclear.dynamics.stepping.state import RK_FIXED, tableau

    return tableau(RK_FIXED, 1, A=[[0.0, 0.0], [1.0, 0.0]], B=[0.5, 0.5], C=[0.0, 1.0])


def _heun():
    from pinclear.dynamics.stepping.rk import ExplicitRK

    return ExplicitRK("toy_heun", heun_tableau, rows=3, adaptive=False, doc="Heun's method, fixed step h")


@pytest.fixture
def toy_heun():
    INTEGRATORS.add(_heun())                     # the one line
    try:
        yield
    finally:
        INTEGRATORS.remove("toy_heun")


def test_a_toy_integrator_converges_at_its_order(toys, toy_heun, tmp_path):
    """m x'' = -k (x - rest) from rest + A with no speed: x = rest + A cos(w t). Heun's global error
    is C h^2 + O(h^3) (its phase error; the amplitude's is O(h^3), which is why the error is taken
    in x and v / w at 5/4 of a period, not at a turning point): halving h divides it by 4 up to a
    relative O(w h) term (w h <= 0.08 here); [3.6, 4.4] excludes first order (2) and RK4's fourth (16), so a wrong
    tableau, a stage left out or a step of the wrong length fails. Through the registry the
    integrator is also one of the command line's and the atlas's."""
    from pinclear.dynamics.stepping import get
    from pinclear.studies.bench import atlas

    k, rest, A = 50.0, 0.1, 0.02
    path = _files(tmp_path, f"initial: {{q: {{slide: {rest + A}}}}}\n"
                  f"forces:\n  - {{name: spring, type: toy_joint_spring, joint: slide, k: {k}, rest: {rest}}}\n")
    mech = load(path)
    w = math.sqrt(k / M)
    T = 2.5 * math.pi / w
    errs = []
    for n in (100, 200, 400):
        tr = simulate(mech, T, integrator="toy_heun", h=T / n, q0=[rest + A], v0=[0.0], t_eval=[0.0, T])
        assert tr.status == "success", tr.message
        assert tr.stats["steps"] == pytest.approx(n, abs=1)     # a last sliver of round-off at most
        errs.append(math.hypot(tr.q[-1, 0] - (rest + A * math.cos(w * T)), tr.v[-1, 0] / w + A * math.sin(w * T)))
    ratios = np.array(errs[:-1]) / np.array(errs[1:])
    assert np.all((ratios > 3.6) & (ratios < 4.4)), (errs, ratios)
    assert get("toy_heun").name == "toy_heun" and "toy_heun" in atlas.INTEGRATORS
    with pytest.raises(ValueError, match="already registered"):
        INTEGRATORS.add(_heun())


def test_an_integrator_is_registered_as_a_method():
    with pytest.raises(TypeError, match="Method"):
        INTEGRATORS.add(JOINT_SPRING)


def _import_graph(package: Path) -> dict:
    """module -> the modules of ``package`` it imports anywhere (functions' imports included)."""
    import ast

    names = {}
    for p in package.rglob("*.py"):
        parts = p.relative_to(package.parent).with_suffix("").parts
        names[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = p
    graph = {}
    for mod, p in names.items():
        pkg = mod if p.name == "__init__.py" else mod.rsplit(".", 1)[0]
        deps = set()
        for node in ast.walk(ast.parse(p.read_text())):
            if isinstance(node, ast.ImportFrom):
                base = pkg
                for _ in range(node.level - 1):
                    base = base.rsplit(".", 1)[0]
                base = (f"{base}.{node.module}" if node.module else base) if node.level else node.module
                deps.update(f"{base}.{a.name}" if f"{base}.{a.name}" in names else base for a in node.names)
            elif isinstance(node, ast.Import):
                deps.update(a.name for a in node.names)
        graph[mod] = {d for d in deps if d in names and d != mod}
    return graph


def test_the_stepping_engine_has_no_import_circle():
    """base.py (the integrators' contract) imports no step logic, so rk.py and rosenbrock.py
    define their kernels and their Method in one file, and chunk.py imports them: no module of
    pinclear.dynamics.stepping reaches itself again through its imports (lazy ones included)."""
    graph = _import_graph(ROOT / "pinclear")
    inside = {m for m in graph if m.startswith("pinclear.dynamics.stepping")}
    for start in inside:
        seen, todo = set(), [d for d in graph[start] if d in inside]
        while todo:
            m = todo.pop()
            assert m != start, f"{start} imports itself through {sorted(seen)}"
            if m not in seen:
                seen.add(m)
                todo += [d for d in graph[m] if d in inside]
