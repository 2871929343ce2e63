"""A meshcat server that listens on the loopback interface only and stops with its viewer.

meshcat-python's own launcher (``meshcat.servers.zmqserver``) binds its ZMQ socket to
127.0.0.1 but lets tornado serve HTTP and the WebSocket on every interface (0.0.0.0 and
[::]) while announcing a 127.0.0.1 URL: anyone on the network could watch, or push commands
to, the scene.  Here the same bridge runs with tornado bound to 127.0.0.1.

The server is a child process (``python -m pinclear.viz.server --parent PID``), stopped

* by :meth:`LocalServer.close` (the viewer's normal end),
* when the viewer process gets SIGINT or SIGTERM (chained signal handlers) or exits (atexit),
* by itself when its parent process is gone (it polls its parent id), so even a SIGKILL of
  the viewer leaves nothing listening.
"""
from __future__ import annotations

import argparse
import atexit
import os
import select
import signal
import subprocess
import sys
import tempfile
import threading
import time

LOOPBACK = "127.0.0.1"


class LocalServer:
    """A meshcat server child process bound to 127.0.0.1; ``zmq_url`` and ``web_url`` name it."""

    def __init__(self, timeout: float = 60.0):
        # stderr goes to a file: meshcat logs every WebSocket to stderr, and a pipe nobody reads
        # would fill and block the server
        self._log = tempfile.TemporaryFile()
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        self.proc = subprocess.Popen(
            [sys.executable, "-u", "-m", "pinclear.viz.server", "--parent", str(os.getpid())],
            stdout=subprocess.PIPE, stderr=self._log, stdin=subprocess.DEVNULL, env=env,
            # its own session: a Ctrl-C in the terminal reaches the viewer, which then stops
            # the server, rather than killing the server behind the viewer's back
            start_new_session=True)
        atexit.register(self.close)
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                self._chain_handler(sig)
        try:
            self.zmq_url = self._read_value("zmq_url", timeout)
            self.web_url = self._read_value("web_url", timeout)
        except BaseException:
            self.close()
            raise

    @property
    def pid(self) -> int:
        return self.proc.pid

    def _read_value(self, key: str, timeout: float) -> str:
        deadline = time.monotonic() + timeout
        buf = b""
        while True:
            if self.proc.poll() is not None:
                raise RuntimeError(f"the meshcat server exited with code {self.proc.returncode} before "
                                   f"announcing its {key}: {self._stderr()}")
            left = deadline - time.monotonic()
            if left <= 0:
                raise RuntimeError(f"the meshcat server did not announce its {key} within {timeout:g} s: "
                                   f"{self._stderr()}")
            ready, _, _ = select.select([self.proc.stdout], [], [], min(left, 0.5))
            if not ready:
                continue
            byte = os.read(self.proc.stdout.fileno(), 1)
            if not byte:
                continue          # EOF: poll() reports the exit on the next pass
            if byte != b"\n":
                buf += byte
                continue
            line = buf.decode("utf-8", "replace").strip()
            buf = b""
            if line.startswith(key + "="):
                return line[len(key) + 1:]

    def _stderr(self) -> str:
        self._log.seek(0)
        text = self._log.read().decode("utf-8", "replace").strip()
        return " ".join(text.split())[-1000:] or "(no output)"

    def _chain_handler(self, sig):
        previous = signal.getsignal(sig)

        def handler(signum, frame):
            self.close()
            if callable(previous):
                return previous(signum, frame)        # SIGINT: raises KeyboardInterrupt
            if previous == signal.SIG_IGN:
                return None
            # the default action: end the process by the same signal, as if we had not looked
            signal.signal(signum, signal.SIG_DFL)
            os.kill(os.getpid(), signum)
            return None

        signal.signal(sig, handler)

    @property
    def running(self) -> bool:
        return self.proc.poll() is None

    def close(self):
        """Stop the server (idempotent)."""
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=5.0)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        if self.proc.stdout is not None and not self.proc.stdout.closed:
            self.proc.stdout.close()
        atexit.unregister(self.close)


def _bridge_class():
    """meshcat's ZMQ/WebSocket bridge with tornado listening on 127.0.0.1 only."""
    import tornado.web
    from meshcat.servers import zmqserver

    class LoopbackApplication(tornado.web.Application):
        def listen(self, port, address=None, **kwargs):
            return super().listen(port, address=LOOPBACK, **kwargs)

    class LoopbackBridge(zmqserver.ZMQWebSocketBridge):
        def make_app(self):
            return LoopbackApplication([
                (r"/static/(.*)", zmqserver.StaticFileHandlerNoCache,
                 {"path": zmqserver.VIEWER_ROOT, "default_filename": zmqserver.VIEWER_HTML}),
                (r"/", zmqserver.WebSocketHandler, {"bridge": self}),
            ])

    return LoopbackBridge


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m pinclear.viz.server",
                                 description="meshcat server on 127.0.0.1 (started by pinclear's viewer)")
    ap.add_argument("--parent", type=int, default=None, help="stop when this process is gone")
    a = ap.parse_args(argv)
    import tornado.ioloop

    bridge = _bridge_class()(host=LOOPBACK)
    print(f"zmq_url={bridge.zmq_url}", flush=True)
    print(f"web_url={bridge.web_url}", flush=True)
    # nobody reads stdout past the two lines above: a full pipe must not block the server
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    if a.parent is not None:
        def check_parent():
            # orphaned (the viewer died, even by SIGKILL): re-parented, so the id changes
            if os.getppid() != a.parent:
                bridge.ioloop.stop()

        tornado.ioloop.PeriodicCallback(check_parent, 500).start()
    try:
        bridge.run()
    except KeyboardInterrupt:
        pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
