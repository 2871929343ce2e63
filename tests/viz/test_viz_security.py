"""The viewer's hostile cases (issue 11): where its server listens and that it stops, which
files a URDF may make it read and what of them reaches a page, which mechanism a saved run
may be shown with, and that viewing a run runs no code unless trusted.

Nothing here is mocked: real meshcat servers are started and inspected through the kernel's
own socket tables (/proc), real files are refused or read.
"""
from __future__ import annotations

import base64
import json
import os
import re
import select
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import pinclear
from pinclear.cli.view import plot_main, view_main
from pinclear.core.errors import ModelFileError
from pinclear.core.models import model_path
from pinclear.viz import build_scene, export_html

pytestmark = pytest.mark.skipif(not Path("/proc/net/tcp").exists(), reason="needs Linux /proc")

SECRET = "SECRET-7f3a9c-do-not-leak"


# ----------------------------------------------------------------------------- helpers
def listening_sockets(pid: int) -> list[tuple[str, int]]:
    """(address, port) of every TCP socket in LISTEN state that process ``pid`` holds, read
    from the kernel's tables (/proc/net/tcp, tcp6) and the process's descriptors."""
    inodes = set()
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        try:
            m = re.fullmatch(r"socket:\[(\d+)\]", os.readlink(fd))
        except OSError:
            continue
        if m:
            inodes.add(m.group(1))
    out = []
    for table, family in (("/proc/net/tcp", socket.AF_INET), ("/proc/net/tcp6", socket.AF_INET6)):
        if not Path(table).exists():
            continue
        for line in Path(table).read_text().splitlines()[1:]:
            f = line.split()
            if f[3] != "0A" or f[9] not in inodes:          # 0A = LISTEN
                continue
            hexaddr, hexport = f[1].split(":")
            raw = bytes.fromhex(hexaddr)
            # the kernel prints each 32-bit word in host (little-endian) order
            raw = b"".join(raw[i:i + 4][::-1] for i in range(0, len(raw), 4))
            out.append((socket.inet_ntop(family, raw), int(hexport, 16)))
    return out


def children(pid: int) -> list[int]:
    kids = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                stat = (d / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                kids.append(int(d.name))
    return kids


def alive(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def wait_gone(pid: int, timeout: float = 15.0) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if not alive(pid):
            return True
        time.sleep(0.1)
    return False


def own_external_ipv4() -> str | None:
    """This machine's address on its default route (a UDP connect sends nothing)."""
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.connect(("192.0.2.1", 9))          # TEST-NET-1: never routed anywhere real
            ip = s.getsockname()[0]
    except OSError:
        return None
    return None if ip.startswith("127.") else ip


def assert_loopback_only(server_pid: int, web_port: int):
    socks = listening_sockets(server_pid)
    # meshcat's HTTP/WebSocket port and its ZMQ command port
    assert len(socks) >= 2, socks
    assert web_port in {p for _, p in socks}, socks
    assert all(addr == "127.0.0.1" for addr, _ in socks), socks
    ip = own_external_ipv4()
    if ip is not None:
        for _, port in socks:
            with socket.socket() as s:
                s.settimeout(5.0)
                assert s.connect_ex((ip, port)) != 0, f"{ip}:{port} accepted a connection"


def read_line_with(proc, pattern: str, timeout: float = 180.0) -> re.Match:
    end, buf = time.monotonic() + timeout, b""
    while time.monotonic() < end:
        if proc.poll() is not None:
            break
        r, _, _ = select.select([proc.stdout], [], [], 0.5)
        if r:
            chunk = os.read(proc.stdout.fileno(), 4096)
            buf += chunk
            m = re.search(pattern, buf.decode("utf-8", "replace"))
            if m:
                return m
    raise AssertionError(f"no line matching {pattern!r} (exit {proc.poll()}): {buf.decode(errors='replace')}")


def page_payload(html: str) -> bytes:
    """Everything a page carries: its text and its decoded meshcat commands."""
    m = re.search(r"var commands = (\[.*?\]);", html, re.S)
    cmds = json.loads(m.group(1)) if m else []
    return html.encode() + b"".join(base64.b64decode(c) for c in cmds)


ARM_URDF = """<robot name="arm">
  <link name="base"/>
  <link name="arm">
    <inertial><origin xyz="0.1 0 0"/><mass value="1"/>
      <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><mesh filename="{mesh}" scale="2 2 2"/></geometry></visual>
  </link>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
</robot>
"""

#: a well-formed OBJ (a tetrahedron) that also carries text: comments and an object name
OBJ = f"# {SECRET}\no {SECRET}\nv 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
OBJ_VERTICES = np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]])


def hostile_tree(tmp_path, how: str, fifo: bool):
    """A URDF in tmp/tree whose mesh lies in tmp/secret (``how`` it is named)."""
    tree, secret = tmp_path / "tree", tmp_path / "secret"
    tree.mkdir()
    secret.mkdir()
    target = secret / "leak.obj"
    if fifo:
        # opening a FIFO for reading blocks until a writer comes: any read of it hangs
        os.mkfifo(target)
    else:
        target.write_text(OBJ)
    mesh = {"relative": "../secret/leak.obj", "absolute": str(target), "file_uri": f"file://{target}",
            "symlink": "inside.obj"}[how]
    if how == "symlink":
        (tree / "inside.obj").symlink_to(target)
    urdf = tree / "arm.urdf"
    urdf.write_text(ARM_URDF.format(mesh=mesh))
    return urdf


def cli(*args, timeout=240.0, env=None):
    return subprocess.run([sys.executable, "-m", "pinclear.cli", *map(str, args)], capture_output=True,
                          text=True, timeout=timeout, env=dict(os.environ, **(env or {})))


# ----------------------------------------------------------------------------- server
@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT, signal.SIGKILL], ids=["TERM", "INT", "KILL"])
def test_view_server_listens_on_loopback_only_and_stops_with_the_viewer(sig, tmp_path):
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    env.pop("PINCLEAR_TRUST", None)
    viewer = subprocess.Popen([sys.executable, "-m", "pinclear.cli", "view", str(model_path("nine_bar"))],
                              stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL,
                              env=env, cwd=tmp_path)
    try:
        m = read_line_with(viewer, r"viewer at http://127\.0\.0\.1:(\d+)/")
        kids = [k for k in children(viewer.pid) if alive(k)]
        assert len(kids) == 1, kids
        server = kids[0]
        assert_loopback_only(server, int(m.group(1)))
        os.kill(viewer.pid, sig)
        rc = viewer.wait(timeout=60)
        if sig == signal.SIGTERM:
            assert rc == -signal.SIGTERM         # ended by the signal, as without a handler
        elif sig == signal.SIGINT:
            assert rc == 0                       # Ctrl-C is the normal way to leave the viewer
        # SIGKILL cannot be handled: the server notices its parent is gone by itself
        assert wait_gone(server), f"meshcat server {server} still running after {sig.name}"
        assert not alive(server)
    finally:
        if viewer.poll() is None:
            viewer.kill()
            viewer.wait()


def test_show_starts_a_loopback_server_that_close_stops():
    mech = pinclear.load("nine_bar")
    scene = pinclear.viz.show(mech)
    try:
        pid = scene.server.pid
        port = int(re.search(r":(\d+)/", scene.live.url()).group(1))
        assert scene.live.url().startswith("http://127.0.0.1:")
        assert_loopback_only(pid, port)
    finally:
        scene.close()
    assert wait_gone(pid, 10.0)
    scene.close()                               # idempotent


# ----------------------------------------------------------------------------- files
@pytest.mark.slow
@pytest.mark.parametrize("how", ["relative", "absolute", "file_uri", "symlink"])
def test_mesh_outside_the_tree_is_refused_without_being_opened(how, tmp_path):
    urdf = hostile_tree(tmp_path, how, fifo=True)
    out = tmp_path / "x.html"
    # a FIFO as the mesh: had anything opened it, this would hang until the timeout
    r = cli("view", urdf, "--html", out, env={"PINCLEAR_TRUST": "0"})
    assert r.returncode == 2, r.stderr
    err = r.stderr.strip()
    assert len(err.splitlines()) == 1 and err.startswith("pinclear: error:")
    assert "arm.urdf" in err and "leak.obj" in err and "--trust" in err
    assert not out.exists()


@pytest.mark.slow
def test_trusted_mesh_is_embedded_as_triangles_never_as_its_text(tmp_path, monkeypatch):
    monkeypatch.delenv("PINCLEAR_TRUST", raising=False)
    urdf = hostile_tree(tmp_path, "relative", fifo=False)
    mech = pinclear.load(urdf)
    with pytest.raises(ModelFileError, match="leak.obj"):
        build_scene(mech, q=mech.q0)
    for trust in ("argument", "environment"):
        if trust == "argument":
            scene = build_scene(mech, q=mech.q0, trust=True)
        else:
            monkeypatch.setenv("PINCLEAR_TRUST", "1")
            scene = build_scene(mech, q=mech.q0)
            monkeypatch.delenv("PINCLEAR_TRUST")
        meshes = [scene.recorder.nodes[p].object.object.geometry for p in scene.paths()
                  if "/urdf" in p and scene.recorder.nodes[p].object is not None]
        assert len(meshes) == 1
        g = meshes[0]
        # the tetrahedron's vertices, scaled by the URDF's scale="2 2 2", and its four faces
        assert type(g).__name__ == "TriangularMeshGeometry"
        # (the mesh loader may renumber vertices: compare the triangles as point sets)
        V = np.asarray(g.vertices, float).reshape(-1, 3)
        tris = {frozenset(tuple(np.round(V[i], 6)) for i in f) for f in np.asarray(g.faces).reshape(-1, 3)}
        P = np.round(2.0 * OBJ_VERTICES, 6)
        want = {frozenset(tuple(P[i - 1]) for i in f) for f in ((1, 3, 2), (1, 2, 4), (1, 4, 3), (2, 3, 4))}
        assert len(V) == 4 and tris == want
        html = export_html(scene, tmp_path / f"{trust}.html").read_text()
        assert SECRET.encode() not in page_payload(html)
        assert SECRET.encode() not in b"".join(scene.recorder.packed())
    r = cli("view", urdf, "--trust", "--html", tmp_path / "cli.html", env={"PINCLEAR_TRUST": "0"})
    assert r.returncode == 0, r.stderr
    assert SECRET.encode() not in page_payload((tmp_path / "cli.html").read_text())


def test_a_text_file_named_like_a_mesh_is_not_embedded(tmp_path, monkeypatch):
    monkeypatch.delenv("PINCLEAR_TRUST", raising=False)
    tree = tmp_path / "tree"
    tree.mkdir()
    (tree / "notes.obj").write_text(f"api_key = {SECRET}\nnot a mesh at all\n")
    (tree / "arm.urdf").write_text(ARM_URDF.format(mesh="notes.obj"))
    mech = pinclear.load(tree / "arm.urdf")
    with pytest.warns(UserWarning, match="URDF visuals not used"):
        scene = build_scene(mech, q=mech.q0)
    # the automatic primitives stand in: the arm still has a body drawn
    arm = [p for p in scene.paths() if p.startswith("/meshcat/pinclear/bodies/arm/")
           and scene.recorder.nodes[p].object is not None]
    assert arm and not any("/urdf" in p for p in arm)
    html = export_html(scene, tmp_path / "t.html").read_text()
    assert SECRET.encode() not in page_payload(html)


# ----------------------------------------------------------------------------- runs
@pytest.fixture(scope="module")
def four_bar_run(tmp_path_factory):
    d = tmp_path_factory.mktemp("run")
    mech = pinclear.load("four_bar")
    traj = pinclear.simulate(mech, 0.05, dt_out=0.01)
    return traj.save(d / "run.npz"), d


def test_view_refuses_a_run_with_another_mechanism_of_the_same_size(four_bar_run, capsys):
    npz, d = four_bar_run
    other = pinclear.load("parallelogram")
    own = pinclear.load("four_bar")
    # the case of the issue: same nq (and even the same closure names), another mechanism
    assert other.nq == own.nq and other.name != own.name
    assert view_main([str(npz), "--mech", str(model_path("parallelogram")), "--html", str(d / "x.html")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "four_bar" in err and "parallelogram" in err
    assert not (d / "x.html").exists()
    assert plot_main([str(npz), "--mech", str(model_path("parallelogram")), "--out", str(d / "figs")]) == 2
    assert "parallelogram" in capsys.readouterr().err
    # its own mechanism, named explicitly or recorded, is accepted
    assert view_main([str(npz), "--mech", str(model_path("four_bar")), "--html", str(d / "y.html")]) == 0
    assert view_main([str(npz), "--html", str(d / "z.html")]) == 0


def test_viewing_a_run_imports_no_code_unless_trusted(tmp_path, monkeypatch, capsys):
    monkeypatch.delenv("PINCLEAR_TRUST", raising=False)
    mod = "pinclear_test_hook_marker"
    marker = tmp_path / "imported"
    (tmp_path / f"{mod}.py").write_text(f"open({str(marker)!r}, 'a').write('x')\n"
                                        "def hook(model, options):\n    pass\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    side = tmp_path / "hooked.yaml"
    text = model_path("four_bar").read_text()
    text = re.sub(r"(?m)^urdf:.*$", f"urdf: {model_path('four_bar').with_suffix('.urdf')}", text)
    side.write_text(text + f"\nhook: \"{mod}:hook\"\n")
    mech = pinclear.load(side, trust=True)
    npz = pinclear.simulate(mech, 0.02, dt_out=0.01).save(tmp_path / "run.npz")
    assert marker.exists()                     # trusted: the module ran
    marker.unlink()
    monkeypatch.delitem(sys.modules, mod)
    assert view_main([str(npz), "--mech", str(side), "--html", str(tmp_path / "x.html")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"{mod}:hook" in err and "--trust" in err
    assert not marker.exists()                 # untrusted: the module never ran
    assert view_main([str(npz), "--trust", "--html", str(tmp_path / "y.html")]) == 2    # recorded: never opened
    assert not marker.exists()
    assert view_main([str(npz), "--mech", str(side), "--trust", "--html", str(tmp_path / "y.html")]) == 0
    assert marker.exists()


@pytest.mark.parametrize("args, what", [(["--size", "abc"], "--size"), (["--fps", "nan"], "--fps"),
                                        (["--slowdown", "0"], "--slowdown"), (["--max-frames", "1"], "--max-frames")])
def test_bad_scene_options_are_one_line_errors(args, what, tmp_path, capsys):
    out = tmp_path / "x.html"
    assert view_main([str(model_path("nine_bar")), "--html", str(out), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("pinclear: error:") and what in err
    assert not out.exists()
