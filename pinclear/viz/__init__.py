"""Layer 7, viz: visual checks: meshcat scenes, standalone HTML animations, the standard plots.

Headless by default: nothing opens a browser or blocks unless asked.

>>> scene = pinclear.viz.show(mech, traj, html="out/run.html")     # file only, no server
>>> scene = pinclear.viz.show(mech, traj)          # meshcat server on 127.0.0.1, prints URL
>>> scene.close()                                   # stops that server
>>> pinclear.viz.plots.save_all(traj, "out/plots")
"""
from __future__ import annotations

import sys
import time

import numpy as np

from pinclear.viz.animate import animate, resample
from pinclear.viz.elements import active_clearances
from pinclear.viz.html import export_html, scene_html, screenshot
from pinclear.viz.scene import MechanismScene, SceneRecorder
from pinclear.viz.server import LocalServer

__all__ = ["show", "build_scene", "animate", "resample", "export_html", "scene_html", "screenshot",
           "MechanismScene", "SceneRecorder", "active_clearances", "start_viewer", "LocalServer"]


def _assembled(mech, q=None):
    """The configuration to show: q if given, else mech.q0 with the loops closed (drives at
    t = 0) when the core can assemble it, else q0 as it is."""
    if q is not None:
        return np.asarray(q, float)
    try:
        from pinclear.model import kinematics
        return kinematics.assemble(mech, mech.q0)
    except Exception:      # an unassemblable guess is still worth looking at
        return np.asarray(mech.q0, float)


def build_scene(mech, traj=None, *, q=None, fps: float = 30.0, slowdown: float | None = None,
                max_frames: int = 1500, ecc_scale: float | None = None, force_scale: float | None = None,
                play: bool = True, loop: bool = False, use_urdf_visuals: bool = True,
                trust: bool | None = None, wear_scale: float | None = None) -> MechanismScene:
    """Scene of ``mech`` (at q, or assembled from q0), animated with ``traj`` if given.

    slowdown: playback seconds per simulated second; None = real time, or slowed by a round
    factor so that runs shorter than 5 s play for 5 s (:func:`pinclear.viz.animate.auto_slowdown`).
    ecc_scale: eccentricity magnification (None = a 1-2-5 factor drawing the clearance at
    most 8 % of the mechanism); force_scale: metres of arrow per newton (None = longest force
    arrow a quarter of the mechanism).  Both are stated in the page's legend.
    trust: URDF meshes may come from anywhere (default: only from the mechanism's folders,
    pinclear's models and example-robot-data; see :class:`MechanismScene`).
    wear_scale: magnification of a worn bearing's depth (None = a 1-2-5 factor drawing the deepest
    wear a quarter of its bearing's radius; stated in the legend)."""
    q0 = traj.q[0] if (traj is not None and q is None) else _assembled(mech, q)
    scene = MechanismScene(mech, q0, ecc_scale=ecc_scale, force_scale=force_scale,
                           use_urdf_visuals=use_urdf_visuals, trust=trust, wear_scale=wear_scale)
    if traj is not None:
        animate(scene, traj, fps=fps, slowdown=slowdown, max_frames=max_frames, play=play, loop=loop)
    return scene


#: seconds any exchange with a meshcat server may take before the viewer gives up
ZMQ_TIMEOUT_S = 10.0


def start_viewer(scene: MechanismScene, zmq_url: str | None = None, open_browser: bool = False):
    """Push a scene to a meshcat server and return the live ``meshcat.Visualizer``.

    Without ``zmq_url`` a server is started that listens on 127.0.0.1 only and stops with
    this process (SIGINT, SIGTERM, exit) or with :meth:`MechanismScene.close`; it is kept in
    ``scene.server``.  ``zmq_url`` names a server that is already running (not stopped here)."""
    import meshcat
    import zmq
    from meshcat.visualizer import ViewerWindow

    from pinclear.core.errors import InputError
    from pinclear.viz.server import curve_client_options

    server, curve = None, []
    if zmq_url is None:
        server = LocalServer()
        zmq_url, curve = server.zmq_url, curve_client_options(server.client)
    # every wait on the server is bounded: meshcat's REQ sockets wait forever by default (a URL
    # nobody answers on blocked `pinclear view --zmq-url tcp://127.0.0.1:1 --no-block` forever)
    ms = int(ZMQ_TIMEOUT_S * 1000)
    for opt, value in ((zmq.RCVTIMEO, ms), (zmq.SNDTIMEO, ms), (zmq.LINGER, 0)):
        ViewerWindow.context.setsockopt(opt, value)
    try:
        vis = meshcat.Visualizer(window=_keyed_window(ViewerWindow, zmq_url, curve))
        scene.push(vis)
    except zmq.ZMQError as exc:
        if server is not None:
            server.close()
        raise InputError(f"no meshcat server answered at {zmq_url!r} within {ZMQ_TIMEOUT_S:g} s ({exc}); start one "
                         "(meshcat-server) or omit --zmq-url") from None
    except BaseException:
        if server is not None:
            server.close()
        raise
    if server is not None:
        # meshcat's own attribute for the process behind a visualizer
        vis.window.server_proc = server.proc
    scene.server, scene.live = server, vis
    if open_browser:
        vis.open()
    return vis


def _keyed_window(base, zmq_url: str, curve: list):
    """meshcat's ViewerWindow whose command sockets are CURVE clients with ``curve``'s keys (the
    local server admits no other client; an external ``--zmq-url`` server gets plain sockets)."""

    import zmq

    class KeyedWindow(base):
        def connect_zmq(self):
            sock = self.context.socket(zmq.REQ)
            for opt, value in curve:
                sock.setsockopt(opt, value)
            sock.connect(self.zmq_url)
            self.zmq_socket = sock

    return KeyedWindow(zmq_url=zmq_url, start_server=False, server_args=[])


def show(mech, traj=None, *, html=None, open_browser: bool = False, block: bool = False,
         zmq_url: str | None = None, **scene_kw) -> MechanismScene:
    """Show a mechanism (and animate a trajectory).

    html: write a standalone page there and start no server.  Otherwise a meshcat server is
    started on 127.0.0.1 (or ``zmq_url`` is used), its URL printed; ``open_browser`` opens it,
    ``block`` waits until Ctrl-C (then stops the server).  The live visualizer is
    ``scene.live``; ``scene.close()`` stops the server.
    Scene options (fps, slowdown, ecc_scale, force_scale, trust, ...): see :func:`build_scene`.
    """
    scene = build_scene(mech, traj, **scene_kw)
    if html is not None:
        scene.html_path = export_html(scene, html)
        return scene
    start_viewer(scene, zmq_url=zmq_url, open_browser=open_browser)
    if block:
        try:
            wait_forever()
        finally:
            scene.close()
    return scene


def wait_forever():
    print("meshcat viewer running; press Ctrl-C to stop.", file=sys.stderr, flush=True)
    try:
        while True:
            time.sleep(3600)
    except KeyboardInterrupt:
        pass
