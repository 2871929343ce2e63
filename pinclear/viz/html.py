"""Standalone HTML export of a scene: plays offline, no server, no network.

meshcat-python's viewer bundle (``meshcat/viewer/dist/main.min.js``, three.js included) is
inlined, followed by the scene's commands in meshcat's own wire format (msgpack, base64)
which are applied synchronously, in order, once the page loads.

The page reads its URL fragment (or query string):

* ``#t=1.25``   pause the animation at simulated time 1.25 s
* ``#t=1.25&play`` start playing from there

and sets ``document.title`` to ``"<name> ready"`` when the scene is built; a legend states
the overlay scale factors.  ``window.pinclear.seek(t)`` seeks from a console or a test.
"""
from __future__ import annotations

import base64
import html as _html
import json
from pathlib import Path

import meshcat

from pinclear.core import safeio
from pinclear.viz.scene import MechanismScene

_MAIN_JS = Path(meshcat.__file__).parent / "viewer" / "dist" / "main.min.js"

_TEMPLATE = """<!DOCTYPE html>
<html>
<head><meta charset="utf-8"><title>{title}</title>
<style>
  body {{ margin: 0; }}
  #meshcat-pane {{ width: 100vw; height: 100vh; overflow: hidden; }}
  #pinclear-legend {{ position: absolute; left: 8px; bottom: 8px; font: 12px sans-serif;
    color: #222; background: rgba(255,255,255,0.75); padding: 4px 8px; border-radius: 4px;
    pointer-events: none; }}
</style>
</head>
<body>
<div id="meshcat-pane"></div>
<div id="pinclear-legend">{legend}<br><span id="pinclear-time"></span></div>
<script>
{mainjs}
</script>
<script>
(function () {{
  var info = {info};
  var commands = {commands};
  var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
  function bytes(b64) {{
    var s = atob(b64), a = new Uint8Array(s.length);
    for (var i = 0; i < s.length; i++) a[i] = s.charCodeAt(i);
    return a;
  }}
  for (var k = 0; k < commands.length; k++) viewer.handle_command_bytearray(bytes(commands[k]));
  var anim = info.animation;
  function seek(t) {{
    if (!anim) return;
    var p = Math.max(0, (t - anim.t0) * anim.slowdown);
    viewer.animator.seek(p);
    viewer.animator.display_progress(p);
  }}
  var arg = (window.location.hash || window.location.search).replace(/^[#?]/, "");
  var params = {{}};
  arg.split("&").forEach(function (kv) {{
    if (!kv) return;
    var i = kv.indexOf("=");
    params[i < 0 ? kv : kv.slice(0, i)] = i < 0 ? "" : decodeURIComponent(kv.slice(i + 1));
  }});
  if (anim && params.t !== undefined) {{
    viewer.animator.pause();
    seek(parseFloat(params.t));
    if (params.play !== undefined) viewer.animator.play();
  }}
  var label = document.getElementById("pinclear-time");
  function tick() {{
    if (anim) label.textContent = "t = " + (anim.t0 + viewer.animator.time / anim.slowdown).toFixed(4) + " s";
    requestAnimationFrame(tick);
  }}
  tick();
  window.pinclear = {{ viewer: viewer, seek: seek, info: info, ready: true }};
  document.title = info.name + " ready";
}})();
</script>
</body>
</html>
"""


def legend(info: dict) -> str:
    parts = [f"<b>{_html.escape(str(info.get('name', '')))}</b>"]
    if info.get("clearances"):
        parts.append(f"eccentricity &times;{info['ecc_scale']:g} (magenta)")
        fs = info.get("force_scale") or 0.0
        if fs > 0:
            parts.append(f"forces {1.0 / fs:.4g} N per m of arrow (normal blue, friction orange)")
    if info.get("worn"):
        parts.append(f"worn bearing depth &times;{info['wear_scale']:g} (dark red; new bearing grey)")
    if info.get("animation"):
        a = info["animation"]
        parts.append(f"playback {a['slowdown']:g}&times; slower than real time"
                     if a["slowdown"] != 1 else "real time")
    return " &middot; ".join(parts)


def scene_html(scene: MechanismScene) -> str:
    """The scene (with its animation, if any) as one self-contained HTML page."""
    info = dict(scene.info)
    info["clearances"] = [el.name for el in scene.clearances]
    cmds = [base64.b64encode(b).decode("ascii") for b in scene.recorder.packed()]
    return _TEMPLATE.format(
        title=_html.escape(f"pinclear: {info.get('name', '')}"),
        legend=legend(info),
        mainjs=_MAIN_JS.read_text(encoding="utf-8"),
        info=json.dumps(info, default=float),
        commands=json.dumps(cmds),
    )


def export_html(scene: MechanismScene, path) -> Path:
    return safeio.write_text(path, scene_html(scene))


CHROMIUM_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--hide-scrollbars", "--mute-audio",
                  # WebGL on the CPU (SwiftShader) when there is no GPU; the page is our own
                  "--enable-unsafe-swiftshader", "--use-angle=swiftshader")


def find_chromium() -> str | None:
    import shutil
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        p = shutil.which(name)
        if p:
            return p
    return None


def screenshot(html_path, png_path, t: float | None = None, size=(960, 720), timeout=120.0,
               budget_ms: int = 2000) -> Path:
    """Render an exported page in headless Chromium and save a PNG (paused at simulated time
    ``t`` if given).  Raises FileNotFoundError if no Chromium is installed."""
    import subprocess
    import tempfile

    exe = find_chromium()
    if exe is None:
        raise FileNotFoundError("no chromium/google-chrome executable on PATH")
    url = Path(html_path).resolve().as_uri() + (f"#t={t!r}" if t is not None else "")
    png_path = Path(png_path).resolve()
    with tempfile.TemporaryDirectory(prefix="pinclear-chromium-") as prof:
        cmd = [exe, *CHROMIUM_FLAGS, f"--user-data-dir={prof}",
               f"--window-size={size[0]},{size[1]}", f"--virtual-time-budget={budget_ms}",
               f"--screenshot={png_path}", url]
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    if not png_path.exists():
        raise RuntimeError(f"chromium wrote no screenshot (exit {proc.returncode}): "
                           f"{proc.stderr[-2000:]}")
    return png_path
