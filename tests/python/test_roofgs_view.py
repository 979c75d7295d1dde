# roofgs.view(): the rgs-view server in this process (docs/VIEWER.md). Its handle's URL serves the page (and
# nothing else), a WebSocket client gets frames, the notebook form is an iframe of that URL, stop() closes
# the port, and upgrades from other pages' origins or requests naming another host are refused.
import json
import socket
import struct
import urllib.error
import urllib.parse
import urllib.request

import pytest

from conftest import SOURCE_DIR, roofgs

pytestmark = pytest.mark.skipif(not hasattr(roofgs, "view"), reason="built without the viewer (RGS_BUILD_VIEWER)")

GUITAR = str(SOURCE_DIR / "samples" / "guitar.ply")


def get(url):
    try:
        with urllib.request.urlopen(url, timeout=10) as response:
            return response.status, response.read()
    except urllib.error.HTTPError as e:
        return e.code, b""


def status_of(url, host=None, origin=None, upgrade=False):
    """The status code of one raw GET of `url` with the given Host (default: the URL's) and Origin headers."""
    parts = urllib.parse.urlsplit(url)
    lines = [f"GET {parts.path or '/'}{'?' + parts.query if parts.query else ''} HTTP/1.1",
             f"Host: {host or parts.netloc}"]
    if origin:
        lines.append(f"Origin: {origin}")
    if upgrade:
        lines += ["Connection: Upgrade", "Upgrade: websocket", "Sec-WebSocket-Version: 13",
                  "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ=="]
    else:
        lines.append("Connection: close")
    with socket.create_connection((parts.hostname, parts.port), timeout=10) as s:
        s.sendall(("\r\n".join(lines) + "\r\n\r\n").encode())
        return int(s.recv(4096).split(b" ")[1])


def test_view_serves_the_page_and_stops(tmp_path):
    server = roofgs.view(GUITAR, device="cpu")
    try:
        assert server.url == f"http://127.0.0.1:{server.port}/"
        assert server.port > 0 and server.token == ""
        status, body = get(server.url)
        assert status == 200 and b"<html" in body
        assert get(server.url + "CMakeLists.txt")[0] == 404
        html = server._repr_html_()
        assert html.startswith("<iframe") and f'src="{server.url}"' in html
        assert repr(server) == f"<roofgs.ViewServer {server.url}>"

        websocket = pytest.importorskip("websocket")
        ws = websocket.create_connection(server.url.replace("http://", "ws://") + "ws", timeout=30)
        hello = json.loads(ws.recv())
        assert hello["type"] == "hello" and hello["backend"] == "cpu"
        assert hello["scenes"][0]["gaussians"] == 90854
        camera = dict(hello["home_camera"], width=64, height=36)
        camera["fx"] = camera["fy"] = hello["home_camera"]["fx"] * 64 / hello["home_camera"]["width"]
        ws.send(json.dumps({"type": "view", "seq": 7, "camera": camera, "encoding": "jpeg"}))
        message = ws.recv()
        (n,) = struct.unpack("<I", message[:4])
        header = json.loads(message[4:4 + n])
        assert header["seq"] == 7 and header["width"] == 64
        assert message[4 + n:4 + n + 2] == b"\xff\xd8" and len(message) == 4 + n + header["images"][0]["bytes"]
        assert server.clients == 1
        ws.close()
    finally:
        server.stop()
    with pytest.raises(OSError):
        urllib.request.urlopen(server.url, timeout=5)
    server.stop()  # idempotent


def test_view_refuses_other_origins_and_host_names():
    with roofgs.view(GUITAR, device="cpu") as server:
        ws, port = server.url + "ws", server.port
        assert status_of(ws, origin=f"http://127.0.0.1:{port}", upgrade=True) == 101
        assert status_of(ws, origin=f"http://localhost:{port}", upgrade=True) == 101
        for origin in ("http://evil.example", "null", "file://", f"http://127.0.0.1:{port + 1}"):
            assert status_of(ws, origin=origin, upgrade=True) == 403, origin
        # DNS rebinding: a page whose name now points here sends that name.
        assert status_of(server.url, host=f"evil.example:{port}") == 403
        assert status_of(ws, host=f"evil.example:{port}", origin=f"http://evil.example:{port}", upgrade=True) == 403
        assert server.clients == 0


def test_view_takes_a_scene_and_a_token():
    scene = roofgs.load(GUITAR, device="cpu")
    token = "abc-0123456789-token"
    with roofgs.view(scene, token=token) as server:
        assert server.url.endswith("/?token=" + token)
        assert get(server.url.split("?")[0])[0] == 403
        assert get(server.url)[0] == 200
        assert status_of(server.url.replace("/?", "/ws?"), host=f"viewer.example:{server.port}",
                         origin=f"http://viewer.example:{server.port}", upgrade=True) == 101
        assert status_of(server.url.split("?")[0] + "ws", upgrade=True) == 403
    with pytest.raises(roofgs.Error):
        roofgs.view(scene, token="not valid but long enough")
    with pytest.raises(roofgs.Error, match="at least 16"):
        roofgs.view(scene, token="abc-1")
    with pytest.raises(roofgs.Error):
        roofgs.view(scene, preset="nonsense")
    # The bandwidth budget: a finite number of Mbit/s in 0..100000, in the hello.
    for bad in (float("nan"), -1, 1e9, True):
        with pytest.raises((ValueError, TypeError), match="max_mbps"):
            roofgs.view(scene, max_mbps=bad)
    # Two scenes: the compare mode.
    with roofgs.view(scene, scene2=GUITAR, device="cpu") as server:
        assert get(server.url)[0] == 200
