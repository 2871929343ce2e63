"""Bounded inputs: every hostile file of the audit (issue 23) is refused at load with one line
naming the file and the key, before Pinocchio, LAPACK or a worker pool sees it.

One test per root cause: URDF size, depth, cycles and non-finite numbers; YAML duplicate keys
and nesting; non-regular files (FIFO, device); non-finite or zero geometric inputs; a python
law's index past its function's output; sweep workers outliving their parent, corrupted point
files and oversized grids; ``plot --ref`` with a run of another mechanism."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import pinclear
from pinclear.analysis.sweeps import MAX_SWEEP_POINTS, grid, parse_vary
from pinclear.core.errors import InputError, ModelFileError
from pinclear.io.sidecar import MAX_SIDECAR_BYTES, MAX_YAML_DEPTH, read_yaml
from pinclear.io.urdf_check import MAX_URDF_DEPTH, MAX_URDF_LINKS
from pinclear.model.timelaws import build_law

ROOT = Path(__file__).resolve().parents[2]
CLI_TIMEOUT = 300          # a hang guard only: every refusal here happens before any simulation


def _cli(*args, timeout=CLI_TIMEOUT):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "pinclear.cli", *map(str, args)], capture_output=True, text=True,
                          cwd=ROOT, env=env, timeout=timeout)


def _one_line_exit_2(r, *needles):
    assert r.returncode == 2, (r.returncode, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("pinclear: error: "), r.stderr
    for n in needles:
        assert str(n) in lines[0], (n, lines[0])
    return lines[0]


# ------------------------------------------------------------------------------- URDF files
def _link(name, mass="1.0"):
    return (f'<link name="{name}"><inertial><mass value="{mass}"/><inertia ixx="0.01" iyy="0.01" izz="0.01" '
            'ixy="0" ixz="0" iyz="0"/></inertial></link>')


def _joint(name, parent, child, axis="0 0 1"):
    return (f'<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
            f'<axis xyz="{axis}"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>')


def _chain(n):
    """A serial chain of n joints (n + 1 links): the tree's depth is n."""
    return _link("l0") + "".join(_link(f"l{i}") + _joint(f"j{i}", f"l{i - 1}", f"l{i}") for i in range(1, n + 1))


def _write(folder, name, body, sidecar=""):
    """name.urdf holding ``body`` and name.yaml naming it (with extra sidecar text)."""
    (folder / f"{name}.urdf").write_text(f'<?xml version="1.0"?>\n<robot name="{name}">{body}</robot>\n')
    path = folder / f"{name}.yaml"
    path.write_text(f"name: {name}\nurdf: {name}.urdf\n{sidecar}")
    return path


def test_a_6000_link_urdf_is_refused_before_pinocchio_parses_it(tmp_path):
    """It crashed Pinocchio's parser (SIGSEGV, exit 139): now exit 2 with the count and the limit."""
    path = _write(tmp_path, "big", _chain(5999))
    r = _cli("info", path)
    _one_line_exit_2(r, "big.urdf", "6000 links", f"at most {MAX_URDF_LINKS}")


def test_urdf_depth_is_bounded_at_the_stated_limit(tmp_path):
    """A chain exactly MAX_URDF_DEPTH deep loads (every joint a degree of freedom); one deeper
    is refused naming the first link past the limit (fewer links than the size limit)."""
    ok = pinclear.load(_write(tmp_path, "deep_ok", _chain(MAX_URDF_DEPTH)))
    assert ok.model.nq == MAX_URDF_DEPTH
    with pytest.raises(ModelFileError, match=rf"deep_no\.urdf: link 'l{MAX_URDF_DEPTH + 1}': lies "
                                             rf"{MAX_URDF_DEPTH + 1} joints below the root.*at most {MAX_URDF_DEPTH}"):
        pinclear.load(_write(tmp_path, "deep_no", _chain(MAX_URDF_DEPTH + 1)))


def test_a_urdf_joint_cycle_is_refused(tmp_path):
    """Links a and b each other's parent beside the root: Pinocchio built an empty model (nq = 0),
    exit 0. A cycle through every link (no root) is refused too."""
    beside = _write(tmp_path, "beside", _link("base") + _link("a") + _link("b") + _joint("ja", "a", "b")
                    + _joint("jb", "b", "a"))
    with pytest.raises(ModelFileError, match=r"beside\.urdf: link '[ab]': is its own ancestor \(joint cycle "
                                             r"(a -> b -> a|b -> a -> b)\).*below the root link 'base'"):
        pinclear.load(beside)
    ring = _write(tmp_path, "ring", _link("a") + _link("b") + _link("c") + _joint("j1", "a", "b")
                  + _joint("j2", "b", "c") + _joint("j3", "c", "a"))
    with pytest.raises(ModelFileError, match=r"ring\.urdf: link '[abc]': is its own ancestor"):
        pinclear.load(ring)
    selfj = _write(tmp_path, "selfj", _link("base") + _link("a") + _joint("j", "base", "a") + _joint("k", "a", "a"))
    with pytest.raises(ModelFileError, match=r"selfj\.urdf: joint 'k': joins link 'a' to itself"):
        pinclear.load(selfj)


@pytest.mark.parametrize("mass, why", [("nan", "not finite"), ("inf", "not finite"), ("-2", "a mass is >= 0"),
                                       ("heavy", "expected 1 number")])
def test_a_urdf_mass_that_is_not_a_finite_non_negative_number_is_refused(tmp_path, mass, why):
    """urdfdom dropped a 'nan' mass with its inertial element (mass 0, a run with other dynamics)."""
    path = _write(tmp_path, "m", _link("base") + _link("arm", mass) + _joint("j", "base", "arm"))
    with pytest.raises(ModelFileError, match=rf"m\.urdf: link 'arm'\.inertial\.mass: .*{why}"):
        pinclear.load(path)


def test_a_zero_urdf_joint_axis_and_an_entity_declaration_are_refused(tmp_path):
    zero = _write(tmp_path, "zero", _link("base") + _link("arm") + _joint("j", "base", "arm", axis="0 0 0"))
    with pytest.raises(ModelFileError, match=r"zero\.urdf: joint 'j'\.axis\.xyz: is the zero vector"):
        pinclear.load(zero)
    (tmp_path / "ent.urdf").write_text('<?xml version="1.0"?><!DOCTYPE robot [<!ENTITY x "1">]>'
                                       f'<robot name="ent">{_link("base")}</robot>')
    (tmp_path / "ent.yaml").write_text("urdf: ent.urdf\n")
    with pytest.raises(ModelFileError, match=r"ent\.urdf: urdf: has a DOCTYPE declaration"):
        pinclear.load(tmp_path / "ent.yaml")


# ------------------------------------------------------------------------------- YAML sidecars
def _ok_urdf(folder):
    (folder / "ok.urdf").write_text(f'<robot name="ok">{_link("base")}{_link("arm")}{_link("tip")}'
                                    f'{_joint("j", "base", "arm")}{_joint("k", "arm", "tip")}</robot>')


def test_duplicate_yaml_keys_are_refused_naming_the_key_and_both_lines(tmp_path):
    """The last one silently won: a closure 'type' given twice changed the closure."""
    _ok_urdf(tmp_path)
    path = tmp_path / "dup.yaml"
    path.write_text("urdf: ok.urdf\nclosures:\n  - name: c\n    type: spherical\n    frame1: tip\n"
                    "    frame2: base\n    type: distance\n    length: 0.1\n")
    with pytest.raises(ModelFileError, match=r"dup\.yaml: type: given twice \(lines 4 and 7\)"):
        pinclear.load(path)
    top = tmp_path / "top.yaml"
    top.write_text("urdf: ok.urdf\ngravity: [0, 0, -9.81]\ngravity: [0, 0, 0]\n")
    _one_line_exit_2(_cli("info", top), "top.yaml", "gravity: given twice (lines 2 and 3)")


def test_deeply_nested_yaml_is_refused_at_the_stated_depth(tmp_path):
    """5000 nested lists hit Python's recursion limit in PyYAML (RecursionError, exit 3)."""
    _ok_urdf(tmp_path)
    ok = tmp_path / "ok.yaml"
    ok.write_text("urdf: ok.urdf\ndescription: " + "[" * (MAX_YAML_DEPTH - 1) + "]" * (MAX_YAML_DEPTH - 1) + "\n")
    assert read_yaml(ok)["urdf"] == "ok.urdf"                      # the top mapping is level 1
    deep = tmp_path / "deep.yaml"
    deep.write_text("urdf: ok.urdf\ndescription: " + "[" * 5000 + "]" * 5000 + "\n")
    _one_line_exit_2(_cli("info", deep), "deep.yaml", f"nested more than {MAX_YAML_DEPTH} levels")
    with pytest.raises(InputError, match=f"nested more than {MAX_YAML_DEPTH}"):
        pinclear.io.sidecar.parse_assignments(["x=" + "[" * 100 + "]" * 100])


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this system")
def test_a_fifo_as_sidecar_is_refused_not_waited_on(tmp_path):
    """open() of a FIFO blocks until a writer comes: the CLI hung forever."""
    fifo = tmp_path / "pipe.yaml"
    os.mkfifo(fifo)
    _one_line_exit_2(_cli("info", fifo, timeout=120), "pipe.yaml", "FIFO", "not a regular sidecar file")


@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="no /dev/zero")
def test_a_device_as_sidecar_is_refused_not_read_until_memory_runs_out(tmp_path):
    """The size bound used st_size (0 for /dev/zero), then read without end."""
    with pytest.raises(ModelFileError, match=r"/dev/zero: path: is a character device"):
        read_yaml("/dev/zero")
    big = tmp_path / "big.yaml"
    big.write_bytes(b"#" * (MAX_SIDECAR_BYTES + 1))
    with pytest.raises(ModelFileError, match=f"at most {MAX_SIDECAR_BYTES}"):
        read_yaml(big)
    big.write_bytes(b"#" * MAX_SIDECAR_BYTES)
    assert read_yaml(big) is None                                  # the limit itself is accepted


# ------------------------------------------------------------------------------- numbers
@pytest.mark.parametrize("closure, key, why", [
    ("{name: c, type: revolute, frame1: {parent: tip, axis: [0, 0, 0]}, frame2: base}", r"closures\[0\]\.frame1\.axis",
     "has no direction"),
    ("{name: c, type: planar_point, frame1: tip, frame2: base, normal: [0, 0, 0]}", r"closures\[0\]\.normal",
     "has no direction"),
    ("{name: c, type: distance, frame1: tip, frame2: base, length: .nan}", r"closures\[0\]\.length", "not finite"),
    ("{name: c, type: distance, frame1: tip, frame2: base, length: 0}", r"closures\[0\]\.length", "must be > 0"),
    ("{name: c, type: spherical, frame1: {parent: tip, xyz: [.inf, 0, 0]}, frame2: base}",
     r"closures\[0\]\.frame1\.xyz\[0\]", "inf is not finite"),
])
def test_non_finite_or_zero_geometry_is_refused_at_load(tmp_path, closure, key, why):
    """These reached LAPACK ('SVD did not converge', exit 3)."""
    _ok_urdf(tmp_path)
    path = tmp_path / "geo.yaml"
    path.write_text(f"urdf: ok.urdf\nclosures:\n  - {closure}\n")
    with pytest.raises(ModelFileError, match=rf"geo\.yaml: {key}: .*{why}"):
        pinclear.load(path)


def test_a_zero_quaternion_in_the_initial_guess_is_refused_and_a_long_one_normalised(tmp_path):
    """A zero quaternion was kept (pin.normalize leaves it) and the run reported success with every
    rotation of that body the zero matrix."""
    (tmp_path / "free.urdf").write_text(f'<robot name="free"><link name="base"/>{_link("b")}<joint name="free" '
                                        'type="floating"><parent link="base"/><child link="b"/></joint></robot>')
    zero = tmp_path / "zero.yaml"
    zero.write_text("urdf: free.urdf\ninitial: {q: {free: [0, 0, 0, 0, 0, 0, 0]}}\n")
    with pytest.raises(ModelFileError, match=r"zero\.yaml: initial\.q\.free: .*zero length"):
        pinclear.load(zero)
    two = tmp_path / "two.yaml"
    two.write_text("urdf: free.urdf\ninitial: {q: {free: [0.1, 0, 0, 0, 0, 0, 2.0]}}\n")
    np.testing.assert_array_equal(pinclear.load(two).q0, [0.1, 0, 0, 0, 0, 0, 1.0])


def test_nan_anywhere_in_a_sidecar_or_an_override_is_refused_with_its_key(tmp_path):
    _ok_urdf(tmp_path)
    path = tmp_path / "spring.yaml"
    path.write_text("urdf: ok.urdf\nforces:\n  - {name: s, type: spring_damper, frame1: tip, frame2: base, k: .inf}\n")
    with pytest.raises(ModelFileError, match=r"spring\.yaml: forces\[0\]\.k: inf is not finite"):
        pinclear.load(path)
    with pytest.raises(ModelFileError, match=r"four_bar\.yaml: gravity\[1\]: nan is not finite"):
        pinclear.load("four_bar", overrides={"gravity[1]": ".nan"})
    # a clearance key (NAME.key override) whose value is not finite: refused before contact.build
    # (an infinite slider length was a ZeroDivisionError)
    with pytest.raises(ModelFileError, match=r"clr_slider\.yaml: clearances\.P\.length: inf is not finite"):
        pinclear.load("clr_slider", overrides={"P.length": float("inf")}, clearances=["P"])
    r = _cli("info", "four_bar", "--set", "closures[0].frame1.xyz=[.nan, 0, 0]")
    _one_line_exit_2(r, "four_bar.yaml", "closures[0].frame1.xyz[0]", "not finite")


# ------------------------------------------------------------------------------- python laws
def three_values(t, scale=1.0):
    """A vector law of three components (y, y', y'')."""
    return scale * np.array([t, 1.0, 2.0]), scale * np.array([1.0, 0.0, 0.0]), np.zeros(3)


def test_an_index_past_a_python_laws_output_is_a_load_error_naming_the_law():
    """Index 7 of a 3-vector was an IndexError at the first evaluation (exit 3)."""
    spec = {"type": "python", "function": "tests.io.test_inputs_bounds:three_values", "index": 7}
    with pytest.raises(ModelFileError, match=r"f\.yaml: drives\[2\]\.law\.index: 7 is past the values "
                                             r"tests.io.test_inputs_bounds:three_values returns \(3/3/3.*valid: 0\.\.2\)"):
        build_law(spec, "f.yaml", "drives[2].law", trust=True)
    law = build_law(dict(spec, index=2), "f.yaml", "drives[2].law", trust=True)
    assert law.eval(0.5) == (2.0, 0.0, 0.0)
    with pytest.raises(ModelFileError, match=r"drives\[0\]\.law\.index: missing: .* returns 3 values"):
        build_law({"type": "python", "function": "tests.io.test_inputs_bounds:three_values"}, "f.yaml", "drives[0].law",
                  trust=True)


def test_an_index_past_a_bundled_ik_is_refused_on_the_command_line(tmp_path):
    _ok_urdf(tmp_path)
    path = tmp_path / "ik.yaml"
    path.write_text("urdf: ok.urdf\ndrives:\n  - {name: d, joint: j, law: {type: python, function: "
                    "'pinclear.mechanisms.four_ups_upr:limb_lengths', index: 7}}\n")
    _one_line_exit_2(_cli("info", path), "ik.yaml", "drives[0].law.index", "valid: 0..3")


# ------------------------------------------------------------------------------- sweeps
SWEEP = ["clr_pendulum", "--clearance", "S", "--set", "S.friction_law=coulomb"]


def _children(pid):
    """Live (non-zombie) processes whose parent is ``pid``, from /proc."""
    out = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            stat = (d / "stat").read_text()
        except OSError:
            continue
        state, ppid = stat.rsplit(")", 1)[1].split()[:2]
        if int(ppid) == pid and state != "Z":
            out.append(int(d.name))
    return out


def _alive(pid):
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc to find the worker processes")
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])
def test_sweep_workers_end_when_the_parent_is_killed(tmp_path, sig):
    """Workers waited forever for jobs from a dead parent, holding the caller's pipes open."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    cmd = [sys.executable, "-m", "pinclear.cli", "sweep", *SWEEP, "--vary", "S.mu=0:0.3:4", "--t-end", "100",
           "--out", str(tmp_path / "s"), "--workers", "2", "--progress", "off"]
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=ROOT, env=env)
    workers = []
    try:
        deadline = time.monotonic() + 240            # start-up (imports, the validating load): a hang guard
        while time.monotonic() < deadline and p.poll() is None and len(workers) < 2:
            time.sleep(0.2)
            workers = _children(p.pid)
        assert len(workers) == 2, p.stderr.read().decode() if p.poll() is not None else "no workers"
        os.kill(p.pid, sig)
        p.communicate(timeout=10)                    # returns once no process holds the pipes
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and any(_alive(w) for w in workers):
            time.sleep(0.1)
        assert not [w for w in workers if _alive(w)]
    finally:
        for w in [p.pid] + workers:
            if _alive(w):
                os.kill(w, signal.SIGKILL)


def test_a_corrupted_point_file_is_named_and_computed_again(tmp_path, capsys):
    kw = dict(sim_options={"rtol": 1e-6, "dt_out": 1e-3}, executor="serial", progress=None,
              load_options={"clearances": ["S"], "overrides": {"S.friction_law": "coulomb"}})
    first = pinclear.sweep("clr_pendulum", {"S.mu": [0.0, 0.2]}, 0.01, tmp_path / "s", **kw)
    q0 = first.points[0].trajectory().q.copy()
    npz = first.points[0].file
    npz.write_bytes(npz.read_bytes()[:100])                       # truncated
    second = first.points[1].file
    second.unlink()
    err = second.with_suffix(".json")
    err.write_text("{not json")                                   # an unreadable error file
    again = pinclear.sweep("clr_pendulum", {"S.mu": [0.0, 0.2]}, 0.01, tmp_path / "s", **kw)
    text = capsys.readouterr().err
    assert again.computed == 2 and [p.status for p in again.points] == ["success", "success"]
    for f in (npz, err):
        assert f"{f}: unreadable sweep point file" in text and (f.parent / (f.name + ".corrupt")).exists()
    assert (npz.parent / (npz.name + ".corrupt")).stat().st_size == 100          # the bytes are kept aside
    assert "computed again" in text
    np.testing.assert_array_equal(again.points[0].trajectory().q, q0)            # the same run again


def test_sweep_grids_are_refused_above_the_stated_size_before_anything_is_built():
    """A 1e8-point grid was a MemoryError after 25 s; --vary a:b:1e8 allocated 800 MB first."""
    with pytest.raises(InputError, match=rf"--vary 'a=0:1:100000000': 100000000 values.*at most {MAX_SWEEP_POINTS}"):
        parse_vary("a=0:1:100000000")
    side = int(MAX_SWEEP_POINTS ** 0.5) + 1
    with pytest.raises(InputError, match=rf"--vary a, b has {side} \(a\) x {side} \(b\) = {side * side} points.*"
                                         rf"at most {MAX_SWEEP_POINTS}"):
        grid({"a": range(side), "b": range(side)})
    assert len(grid({"a": range(MAX_SWEEP_POINTS // 2), "b": [0, 1]})) == MAX_SWEEP_POINTS
    r = _cli("sweep", *SWEEP, "--vary", "S.mu=0:1:10000", "--vary", "S.clearance=1e-4:2e-4:10000",
             "--t-end", "0.01", "--out", "/nonexistent/never_written")
    _one_line_exit_2(r, "S.mu, S.clearance", "100000000 points", f"at most {MAX_SWEEP_POINTS}")


# ------------------------------------------------------------------------------- plot --ref
def test_plot_ref_with_a_run_of_another_mechanism_names_both_files(tmp_path, capsys):
    """It was a Pinocchio ValueError from forwardKinematics (q of the wrong size), exit 3."""
    from pinclear.cli.view import plot_main

    a = pinclear.simulate(pinclear.load("four_bar"), 0.01, dt_out=0.005).save(tmp_path / "a.npz")
    b = pinclear.simulate(pinclear.load("parallelogram"), 0.01, dt_out=0.005).save(tmp_path / "b.npz")
    assert plot_main([str(a), "--out", str(tmp_path / "figs"), "--ref", str(b)]) == 2
    line = capsys.readouterr().err.strip()
    assert len(line.splitlines()) == 1 and line.startswith("pinclear: error: --ref ")
    assert str(a) in line and str(b) in line and "'four_bar'" in line and "'parallelogram'" in line
    fifo = tmp_path / "ref.npz"
    if hasattr(os, "mkfifo"):
        os.mkfifo(fifo)
        assert plot_main([str(a), "--out", str(tmp_path / "figs"), "--ref", str(fifo)]) == 2
        assert "FIFO" in capsys.readouterr().err
