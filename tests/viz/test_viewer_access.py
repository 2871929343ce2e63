"""Who may talk to the viewer's own meshcat server (issue 53, item 2): raw HTTP and WebSocket
handshakes with hostile Host headers, a missing or wrong token, and ZMQ clients without the
run's CURVE keys. Real servers, real sockets; nothing mocked."""
from __future__ import annotations

import base64
import re
import socket
import time

import pytest

from pinclear.viz.server import LocalServer

WS_KEY = "dGhlIHNhbXBsZSBub25jZQ=="


@pytest.fixture(scope="module")
def server():
    srv = LocalServer()
    try:
        yield srv
    finally:
        srv.close()


def _port(srv) -> int:
    return int(re.search(r"127\.0\.0\.1:(\d+)/", srv.web_url).group(1))


def status_line(port: int, path: str, host: str, origin: str | None = None, upgrade: bool = True) -> str:
    """The first line of the server's answer to one raw request."""
    head = [f"GET {path} HTTP/1.1", f"Host: {host}"]
    if origin is not None:
        head.append(f"Origin: {origin}")
    if upgrade:
        head += ["Upgrade: websocket", "Connection: Upgrade", f"Sec-WebSocket-Key: {WS_KEY}",
                 "Sec-WebSocket-Version: 13"]
    with socket.create_connection(("127.0.0.1", port), timeout=10) as c:
        c.sendall(("\r\n".join(head) + "\r\n\r\n").encode())
        data = b""
        while b"\r\n" not in data:
            chunk = c.recv(4096)
            if not chunk:
                break
            data += chunk
    return data.split(b"\r\n")[0].decode()


HOSTS_OK = ["127.0.0.1:{port}", "localhost:{port}", "LOCALHOST:{port}", "[::1]:{port}"]
HOSTS_BAD = ["attacker.example:{port}", "127.0.0.1", "localhost", "127.0.0.1:{other}", "127.0.0.2:{port}",
             "localhost.attacker.example:{port}", "", "0.0.0.0:{port}"]


def _host(tmpl: str, port: int) -> str:
    return tmpl.format(port=port, other=port + 1)


@pytest.mark.parametrize("host", HOSTS_OK)
def test_websocket_opens_for_a_loopback_host_with_the_token(server, host):
    port = _port(server)
    h = _host(host, port)
    line = status_line(port, f"/?token={server.client['token']}", h, origin=f"http://{h}")
    assert line.startswith("HTTP/1.1 101"), line


@pytest.mark.parametrize("host", HOSTS_BAD)
def test_websocket_refuses_another_host_even_with_the_token_and_a_matching_origin(server, host):
    """DNS rebinding: the attacker's page sends its own name as Host and as Origin."""
    port = _port(server)
    h = _host(host, port)
    line = status_line(port, f"/?token={server.client['token']}", h, origin=f"http://{h}")
    assert line.startswith("HTTP/1.1 403"), line


@pytest.mark.parametrize("query", ["", "?token=", "?token=wrong", "?tok=", "?token={token}x", "?token={short}"])
@pytest.mark.parametrize("what", ["websocket", "page"])
def test_missing_or_wrong_token_is_refused(server, query, what):
    port = _port(server)
    token = server.client["token"]
    q = query.format(token=token, short=token[:-1])
    path = ("/" if what == "websocket" else "/static/") + q
    line = status_line(port, path, f"127.0.0.1:{port}", upgrade=(what == "websocket"))
    assert line.startswith("HTTP/1.1 403"), (path, line)


def test_the_page_carries_the_token_to_its_websocket(server):
    """The URL the viewer prints opens a page whose script connects with the token."""
    port = _port(server)
    with socket.create_connection(("127.0.0.1", port), timeout=10) as c:
        c.sendall(f"GET /static/?token={server.client['token']} HTTP/1.1\r\nHost: localhost:{port}\r\n"
                  "Connection: close\r\n\r\n".encode())
        data = b""
        while chunk := c.recv(65536):
            data += chunk
    assert data.startswith(b"HTTP/1.1 200"), data[:100]
    assert f"/?token={server.client['token']}".encode() in data
    assert b"viewer.connect();" not in data
    # the script itself is public meshcat code; meshcat's other pages (which connect without a
    # token) are not served
    assert status_line(port, "/static/main.min.js", f"127.0.0.1:{port}", upgrade=False).startswith("HTTP/1.1 200")
    for page in ("animation-dev.html", "camera-dev.html", "index.html?token=x"):
        line = status_line(port, f"/static/{page}", f"127.0.0.1:{port}", upgrade=False)
        assert not line.startswith("HTTP/1.1 200"), (page, line)


def _req(server, curve: list, timeout_ms: int = 500):
    import zmq

    ctx = zmq.Context.instance()
    sock = ctx.socket(zmq.REQ)
    sock.setsockopt(zmq.LINGER, 0)
    sock.setsockopt(zmq.RCVTIMEO, timeout_ms)
    sock.setsockopt(zmq.SNDTIMEO, timeout_ms)
    for opt, value in curve:
        sock.setsockopt(opt, value)
    sock.connect(server.zmq_url)
    return sock


def _ask(sock, *frames: bytes):
    import zmq

    try:
        sock.send_multipart(list(frames))
        return sock.recv()
    except zmq.Again:
        return None
    finally:
        sock.close()


def _stranger_options(server, kind: str) -> list:
    """ZMQ options of a local user without the run's secrets."""
    import zmq

    if kind == "plain":
        return []
    pub, sec = zmq.curve_keypair()
    if kind == "own keys, right server key":
        return [(zmq.CURVE_SERVERKEY, server.client["server_public"].encode()), (zmq.CURVE_PUBLICKEY, pub),
                (zmq.CURVE_SECRETKEY, sec)]
    spub, _ = zmq.curve_keypair()
    return [(zmq.CURVE_SERVERKEY, spub), (zmq.CURVE_PUBLICKEY, pub), (zmq.CURVE_SECRETKEY, sec)]


@pytest.mark.parametrize("kind", ["plain", "own keys, right server key", "own keys, guessed server key"])
def test_a_zmq_client_without_the_run_keys_can_neither_read_nor_delete_the_scene(server, kind):
    import umsgpack

    from pinclear.viz.server import curve_client_options

    good = curve_client_options(server.client)
    path = f"/meshcat/probe-{len(kind)}".encode()
    cmd = {"type": "set_property", "path": path.decode(), "property": "visible", "value": True}
    assert _ask(_req(server, good), b"set_property", path, umsgpack.packb(cmd)) == b"ok"
    t0 = time.monotonic()
    assert _ask(_req(server, _stranger_options(server, kind)), b"url") is None
    assert _ask(_req(server, _stranger_options(server, kind)), b"get_scene") is None
    delete = {"type": "delete", "path": "/meshcat"}
    assert _ask(_req(server, _stranger_options(server, kind)), b"delete", b"/meshcat", umsgpack.packb(delete)) is None
    assert time.monotonic() - t0 < 30
    # the rightful client still reads the scene it set, untouched, and the URL with the token
    html = _ask(_req(server, good, 10000), b"get_scene")
    assert html is not None
    kept = [umsgpack.unpackb(base64.b64decode(b)) for b in re.findall(rb'base64,([A-Za-z0-9+/=]+)"', html)]
    assert cmd in kept, kept
    url = _ask(_req(server, good, 10000), b"url").decode()
    assert url == server.web_url and url.endswith("?token=" + server.client["token"])


def test_the_secrets_differ_per_run_and_never_reach_the_command_line(server):
    other = LocalServer()
    try:
        assert other.client["token"] != server.client["token"]
        assert other.client["client_secret"] != server.client["client_secret"]
        with open(f"/proc/{other.pid}/cmdline", "rb") as fh:
            cmdline = fh.read()
        for value in other.client.values():
            assert value.encode() not in cmdline
    finally:
        other.close()


def test_no_block_without_an_external_server_is_refused(capsys):
    """`view --no-block` printed a URL that nothing served once the command had returned."""
    from pinclear.cli.view import view_main

    assert view_main(["four_bar", "--no-block"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--no-block needs --zmq-url" in err[0]
