# roofgs.view(): the rgs-view server in this process (docs/VIEWER.md). Its handle's URL serves the page (and
# nothing else), a WebSocket client gets frames, the notebook form is an iframe of that URL, and stop() closes
# the port.
import json
import struct
import urllib.error
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


def test_view_takes_a_scene_and_a_token():
    scene = roofgs.load(GUITAR, device="cpu")
    with roofgs.view(scene, token="abc-1") as server:
        assert server.url.endswith("/?token=abc-1")
        assert get(server.url.split("?")[0])[0] == 403
        assert get(server.url)[0] == 200
    with pytest.raises(roofgs.Error):
        roofgs.view(scene, token="not valid")
    with pytest.raises(roofgs.Error):
        roofgs.view(scene, preset="nonsense")
    # Two scenes: the compare mode.
    with roofgs.view(scene, scene2=GUITAR, device="cpu") as server:
        assert get(server.url)[0] == 200
