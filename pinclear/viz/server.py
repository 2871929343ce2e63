"""A meshcat server that listens on the loopback interface only and stops with its viewer.

meshcat-python's own launcher (``meshcat.servers.zmqserver``) binds its ZMQ socket to
127.0.0.1 but lets tornado serve HTTP and the WebSocket on every interface (0.0.0.0 and
[::]) while announcing a 127.0.0.1 URL: anyone on the network could watch, or push commands
to, the scene.  Here the same bridge runs with tornado bound to 127.0.0.1.

Two more gates (docs/security.md, "The viewer's server"):

* **Host**: every HTTP request and WebSocket handshake must name the server as ``127.0.0.1:PORT``,
  ``localhost:PORT`` or ``[::1]:PORT``. A page of another site that rebinds its DNS name to
  127.0.0.1 sends its own name as Host, so it can neither load the page nor open the socket.
* **A per-run secret**: the page and the WebSocket need the run's token (``?token=``, 128 random
  bits, compared in constant time), and the ZMQ command socket speaks CURVE with a server key
  pair and one allowed client key, all made by the server for this run and handed to the viewer
  over the private stdout pipe (never on a command line, which other users can read in /proc).
  Another local user can connect to both ports but can neither read the scene nor change it.

The server is a child process (``python -m pinclear.viz.server --parent PID``), stopped

* by :meth:`LocalServer.close` (the viewer's normal end),
* when the viewer process gets SIGINT or SIGTERM (chained signal handlers) or exits (atexit),
* by itself when its parent process is gone (it polls its parent id), so even a SIGKILL of
  the viewer leaves nothing listening.
"""
from __future__ import annotations

import argparse
import atexit
import hmac
import json
import os
import secrets
import select
import signal
import subprocess
import sys
import tempfile
import threading
import time

LOOPBACK = "127.0.0.1"
#: the ZAP domain of the command socket (the authenticator answers for this domain only)
ZAP_DOMAIN = "pinclear-viewer"


def allowed_hosts(port: int) -> frozenset[str]:
    """The Host header values the server answers (lower case): the loopback names with its port."""
    return frozenset(f"{h}:{port}" for h in (LOOPBACK, "localhost", "[::1]"))


class ServerKeys:
    """The per-run secrets: the page/WebSocket token and the CURVE key pairs (Z85 text) of the
    command socket (server) and of the one client allowed on it (the viewer)."""

    def __init__(self, token: str, server_public: str, server_secret: str, client_public: str,
                 client_secret: str):
        self.token, self.server_public, self.server_secret = token, server_public, server_secret
        self.client_public, self.client_secret = client_public, client_secret

    @classmethod
    def new(cls) -> ServerKeys:
        import zmq

        sp, ss = zmq.curve_keypair()
        cp, cs = zmq.curve_keypair()
        return cls(secrets.token_urlsafe(16), sp.decode(), ss.decode(), cp.decode(), cs.decode())

    def client(self) -> dict:
        """What the viewer needs: the token, the server's public key and the client's key pair."""
        return {"token": self.token, "server_public": self.server_public, "client_public": self.client_public,
                "client_secret": self.client_secret}


def curve_client_options(client: dict) -> list[tuple[int, bytes]]:
    """The socket options that make a ZMQ REQ socket a CURVE client of the server ``client`` names."""
    import zmq

    return [(zmq.CURVE_SERVERKEY, client["server_public"].encode()),
            (zmq.CURVE_PUBLICKEY, client["client_public"].encode()),
            (zmq.CURVE_SECRETKEY, client["client_secret"].encode())]


class LocalServer:
    """A meshcat server child process bound to 127.0.0.1; ``zmq_url`` and ``web_url`` name it
    (``web_url`` carries the run's token), ``client`` holds the secrets of its command socket
    (:meth:`ServerKeys.client`)."""

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
            self.client = json.loads(self._read_value("client", timeout))
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


def _bridge_class(keys: ServerKeys):
    """meshcat's ZMQ/WebSocket bridge with tornado listening on 127.0.0.1 only, answering only
    loopback Host names, the page and the WebSocket only with the run's token, and the command
    socket only to the CURVE client key of ``keys``."""
    import tornado.web
    import zmq
    from meshcat.servers import zmqserver
    from zmq.eventloop.zmqstream import ZMQStream

    port_box = {}

    def check_host(handler):
        host = (handler.request.headers.get("Host") or "").lower()
        if host not in allowed_hosts(port_box.get("port", -1)):
            # DNS rebinding: a page of another site reaches 127.0.0.1 under its own name
            raise tornado.web.HTTPError(403, "Host not allowed")

    def check_token(handler):
        given = handler.get_query_argument("token", "")
        if not hmac.compare_digest(given.encode(), keys.token.encode()):
            raise tornado.web.HTTPError(403, "missing or wrong token")

    class LoopbackApplication(tornado.web.Application):
        def listen(self, port, address=None, **kwargs):
            server = super().listen(port, address=LOOPBACK, **kwargs)
            port_box["port"] = port
            return server

    class StaticHandler(zmqserver.StaticFileHandlerNoCache):
        def prepare(self):
            check_host(self)

    class PageHandler(tornado.web.RequestHandler):
        """meshcat's index page, connecting its WebSocket with the run's token."""

        def prepare(self):
            check_host(self)
            check_token(self)

        def get(self):
            with open(os.path.join(zmqserver.VIEWER_ROOT, zmqserver.VIEWER_HTML), encoding="utf-8") as fh:
                page = fh.read()
            # the token is URL-safe base64 (letters, digits, - and _): nothing to escape in JS
            url = "(location.protocol == 'https:' ? 'wss://' : 'ws://') + location.host + '/?token=" + keys.token + "'"
            if "viewer.connect();" not in page:      # another meshcat: never serve a page without the token
                raise tornado.web.HTTPError(500, "meshcat's page has no viewer.connect() to give the token")
            page = page.replace("viewer.connect();", f"viewer.connect({url});")
            self.set_header("Cache-Control", "no-store")
            self.set_header("Content-Type", "text/html; charset=utf-8")
            self.write(page)

    class SocketHandler(zmqserver.WebSocketHandler):
        def prepare(self):
            check_host(self)
            check_token(self)

    class LoopbackBridge(zmqserver.ZMQWebSocketBridge):
        def make_app(self):
            return LoopbackApplication([
                (r"/static/(?:index\.html)?", PageHandler),
                # the viewer's script only; meshcat's development pages connect without a token
                (r"/static/(main\.min\.js)", StaticHandler, {"path": zmqserver.VIEWER_ROOT}),
                (r"/", SocketHandler, {"bridge": self}),
            ])

        def setup_zmq(self, url):
            sock = self.context.socket(zmq.REP)
            sock.curve_server = True
            sock.curve_secretkey = keys.server_secret.encode()
            sock.zap_domain = ZAP_DOMAIN.encode()
            sock.bind(url)
            stream = ZMQStream(sock)
            stream.on_recv(self.handle_zmq)
            return sock, stream, url

    return LoopbackBridge


def _start_authenticator(context, keys: ServerKeys):
    """A ZAP handler on ``context`` that admits the one client key of ``keys`` (CURVE without a
    ZAP handler admits every client that knows the server's public key)."""
    from zmq.auth.thread import ThreadAuthenticator

    class OneKey:
        def callback(self, domain, key):
            k = key.decode() if isinstance(key, bytes) else str(key)
            return domain == ZAP_DOMAIN and hmac.compare_digest(k.encode(), keys.client_public.encode())

    auth = ThreadAuthenticator(context)
    auth.start()
    auth.configure_curve_callback(domain=ZAP_DOMAIN, credentials_provider=OneKey())
    return auth


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m pinclear.viz.server",
                                 description="meshcat server on 127.0.0.1 (started by pinclear's viewer)")
    ap.add_argument("--parent", type=int, default=None, help="stop when this process is gone")
    a = ap.parse_args(argv)
    import tornado.ioloop
    from meshcat.servers import zmqserver

    keys = ServerKeys.new()
    auth = _start_authenticator(zmqserver.ZMQWebSocketBridge.context, keys)
    bridge = _bridge_class(keys)(host=LOOPBACK)
    # what meshcat's "url" command answers: the page with the run's token
    bridge.web_url = f"{bridge.web_url}?token={keys.token}"
    print(f"zmq_url={bridge.zmq_url}", flush=True)
    print(f"web_url={bridge.web_url}", flush=True)
    # the stdout pipe is the viewer's alone: the secrets travel nowhere else
    print(f"client={json.dumps(keys.client())}", flush=True)
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
    finally:
        auth.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
