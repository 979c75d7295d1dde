#!/usr/bin/env python3
"""rgs-view's page in a real browser: headless Chromium driven over the DevTools protocol, against
`rgs-view --backend cpu` on the bundled guitar (converted to .rgs here; a second, lossy conversion for the
compare mode). Checks, in order:

  first_frame  the page connects (hello), and a first frame arrives and is drawn at the window's size
  navigate     a scripted mouse drag (Input.dispatchMouseEvent) orbits: the camera keeps its distance to the
               orbit target and the new frame differs; the wheel dollies out
  lossless     a lossless frame of a given camera, decoded by the browser, equals rgs-render --backend cpu's
               PPM of that camera (written to a cameras.json) byte for byte
  path         a camera path recorded in the page (cameras set through the test hook) is an INRIA
               cameras.json that rgs-render --cameras renders, one image per recorded view; replay draws them
  compare      with two scenes: the page opens on the split view (frames carry images a and b), PSNR shown and finite, the split
               slider follows a drag of its handle; the difference heatmap (image "diff")
  budget       the panel's "Max Mbit/s" control: a tiny budget typed in goes with the views; while a drag moves
               the camera the server sends smaller frames (scale or quality under the page's asking, the budget
               in the header), the statistics panel shows Mbit/s and the quality used; once still, the frame is
               full size at the asked quality; a value the server would refuse (negative, not a number) is sent
               as no budget
  security     the default server listens on loopback only (not reachable on another address of this machine,
               when it has one); with --host 0.0.0.0 a token is required: 403 without it (page and WebSocket),
               200 with it
  clients      8 raw WebSocket clients at once each get the frame of their own camera (size and seq); a 9th is
               told "busy"
  abuse        clients sending malformed JSON, an oversized message, a binary message or an invalid camera are
               closed with an error while two others keep getting frames; the page still works afterwards
  shutdown     SIGTERM: rgs-view exits 0

Screenshots (Page.captureScreenshot) go to WORK_DIR: first_frame.png, navigate.png, budget_moving.png,
compare_split.png, compare_diff.png; with --save-screenshot PATH a larger one of the page is written to PATH (docs/images).

    test_view_browser.py RGS_VIEW RGS_RENDER RGS_CONVERT GUITAR_PLY WORK_DIR [--only a,b] [--save-screenshot P]

Exit status: 0 passed, 1 failed, 77 skipped (no chromium, or no python3-websocket), with a "skipped: ..." line.
Every process this starts is stopped by the end (timeouts everywhere; killed in `finally`).
"""
import argparse
import base64
import json
import math
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request

SKIP = 77
CHROMIUM_CANDIDATES = ["/usr/bin/chromium", "/usr/bin/chromium-browser", "/usr/bin/google-chrome"]


def skip(why):
    print(f"skipped: {why}", flush=True)
    sys.exit(SKIP)


class Failed(Exception):
    pass


def check(cond, what):
    if not cond:
        raise Failed(what)


def log(text):
    print(text, flush=True)


try:
    import websocket  # python3-websocket (websocket-client)
except ImportError:
    websocket = None


# ---- processes ----------------------------------------------------------------------------------------------
class Server:
    """rgs-view started with `args`; its URL parsed from what it prints."""

    def __init__(self, exe, args, work, name):
        self.log_path = os.path.join(work, f"{name}.log")
        self.log_file = open(self.log_path, "w", encoding="utf-8")
        self.proc = subprocess.Popen([exe] + args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                     cwd=work)
        self.url = None
        self.lines = []
        found = threading.Event()

        def pump():
            for line in self.proc.stdout:
                self.lines.append(line)
                self.log_file.write(line)
                self.log_file.flush()
                m = re.search(r"(https?://[^\s]+)", line)
                if m and not self.url:
                    self.url = m.group(1).rstrip(".,)")
                    found.set()
            found.set()

        self.reader = threading.Thread(target=pump, daemon=True)
        self.reader.start()
        if not found.wait(120) or not self.url:
            out = "".join(self.lines)[-2000:]
            self.stop()
            raise Failed(f"rgs-view {' '.join(args)} printed no URL: {out}")
        m = re.match(r"https?://([^/:]+|\[[^\]]+\]):(\d+)", self.url)
        check(m, f"cannot read the port from {self.url}")
        self.port = int(m.group(2))
        self.token = (re.search(r"[?&]token=([A-Za-z0-9_-]+)", self.url) or [None, None])[1]

    def local_url(self, path="/", token=True):
        q = f"?token={self.token}" if token and self.token else ""
        return f"http://127.0.0.1:{self.port}{path}{q}"

    def ws_url(self, token=True):
        q = f"?token={self.token}" if token and self.token else ""
        return f"ws://127.0.0.1:{self.port}/ws{q}"

    def stop(self, sig=signal.SIGTERM, timeout=20):
        """Stops the server; returns its exit status (None if it had to be killed)."""
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(10)
                self.reader.join(5)
                self.log_file.close()
                return None
        self.reader.join(5)
        if not self.log_file.closed:
            self.log_file.close()
        return self.proc.returncode


class Cdp:
    """One DevTools connection to the browser; pages are attached targets (flat sessions)."""

    def __init__(self, url):
        self.ws = websocket.create_connection(url, timeout=60, suppress_origin=True)
        self.next_id = 0
        self.events = []
        self.exceptions = []  # every Runtime.exceptionThrown, kept whole

    def call(self, method, params=None, session=None, timeout=60):
        self.next_id += 1
        mid = self.next_id
        msg = {"id": mid, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        self.ws.send(json.dumps(msg))
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise Failed(f"DevTools: no answer to {method} within {timeout} s")
            self.ws.settimeout(left)
            try:
                reply = json.loads(self.ws.recv())
            except websocket.WebSocketTimeoutException:
                raise Failed(f"DevTools: no answer to {method} within {timeout} s")
            if reply.get("id") == mid:
                if "error" in reply:
                    raise Failed(f"DevTools {method}: {reply['error']}")
                return reply.get("result", {})
            if reply.get("method") == "Runtime.exceptionThrown":
                self.exceptions.append(reply)
            self.events.append(reply)
            del self.events[:-500]

    def close(self):
        try:
            self.ws.close()
        except Exception:
            pass


class Page:
    def __init__(self, cdp, width, height):
        self.cdp = cdp
        self.target = cdp.call("Target.createTarget", {"url": "about:blank"})["targetId"]
        self.session = cdp.call("Target.attachToTarget", {"targetId": self.target, "flatten": True})["sessionId"]
        self.call("Runtime.enable")
        self.call("Page.enable")
        self.call("Log.enable")
        self.call("Emulation.setDeviceMetricsOverride",
                  {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False})
        self.width, self.height = width, height

    def call(self, method, params=None, timeout=60):
        return self.cdp.call(method, params, self.session, timeout)

    def goto(self, url):
        self.call("Page.navigate", {"url": url})
        self.wait("document.readyState === 'complete' && !!window.rgsView", 30, "the page did not load")

    def eval(self, expr, timeout=60):
        r = self.call("Runtime.evaluate", {"expression": expr, "awaitPromise": True, "returnByValue": True,
                                            "timeout": timeout * 1000}, timeout=timeout + 5)
        if "exceptionDetails" in r:
            d = r["exceptionDetails"]
            text = (d.get("exception") or {}).get("description") or d.get("text")
            raise Failed(f"in the page: {expr[:120]}: {text}")
        return r["result"].get("value")

    def wait(self, expr, timeout, what):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                if self.eval(f"(() => {{ try {{ return !!({expr}); }} catch (e) {{ return false; }} }})()"):
                    return
            except Failed:
                pass
            time.sleep(0.1)
        raise Failed(f"{what} (waited {timeout} s for {expr}); page console: {self.console()}")

    def console(self):
        out = []
        for e in self.cdp.events:
            if e.get("sessionId") != self.session:
                continue
            if e.get("method") == "Runtime.consoleAPICalled":
                out.append(" ".join(str(a.get("value", a.get("description", ""))) for a in e["params"]["args"]))
            elif e.get("method") == "Log.entryAdded":
                out.append(f"{e['params']['entry'].get('level')}: {e['params']['entry'].get('text')}")
            elif e.get("method") == "Runtime.exceptionThrown":
                d = e["params"]["exceptionDetails"]
                out.append("exception: " + str((d.get("exception") or {}).get("description") or d.get("text")))
        return out[-10:]

    def screenshot(self, path):
        data = self.call("Page.captureScreenshot", {"format": "png"})["data"]
        with open(path, "wb") as f:
            f.write(base64.b64decode(data))
        check(os.path.getsize(path) > 1000, f"screenshot {path} is empty")
        return path

    def mouse(self, kind, x, y, button="none", buttons=0, **extra):
        p = {"type": kind, "x": x, "y": y, "button": button, "buttons": buttons}
        p.update(extra)
        self.call("Input.dispatchMouseEvent", p)

    def click(self, selector):
        x, y = self.eval(f"(() => {{ const e = document.querySelector('{selector}'); "
                         "e.scrollIntoView({block: 'nearest'}); const b = e.getBoundingClientRect(); "
                         "return [b.left + b.width / 2, b.top + b.height / 2]; })()")
        check(0 <= x < self.width and 0 <= y < self.height, f"{selector} is outside the window at ({x}, {y})")
        self.mouse("mouseMoved", x, y)
        self.mouse("mousePressed", x, y, "left", 1, clickCount=1)
        self.mouse("mouseReleased", x, y, "left", 0, clickCount=1)

    def drag(self, x0, y0, x1, y1, steps=8, button="left"):
        mask = {"left": 1, "right": 2, "middle": 4}[button]
        self.mouse("mouseMoved", x0, y0)
        self.mouse("mousePressed", x0, y0, button, mask, clickCount=1)
        for i in range(1, steps + 1):
            self.mouse("mouseMoved", x0 + (x1 - x0) * i / steps, y0 + (y1 - y0) * i / steps, button, mask)
            time.sleep(0.02)
        self.mouse("mouseReleased", x1, y1, button, 0, clickCount=1)

    def close(self):
        try:
            self.cdp.call("Target.closeTarget", {"targetId": self.target}, timeout=10)
        except Exception:
            pass


class Browser:
    def __init__(self, exe, work):
        self.profile = os.path.join(work, "chromium-profile")
        shutil.rmtree(self.profile, ignore_errors=True)
        os.makedirs(self.profile)
        self.log = open(os.path.join(work, "chromium.log"), "w")
        self.proc = subprocess.Popen(
            [exe, "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--no-first-run",
             "--no-default-browser-check", "--disable-extensions", "--disable-background-networking",
             "--disable-background-timer-throttling", "--disable-renderer-backgrounding",
             "--disable-backgrounding-occluded-windows", "--remote-allow-origins=*",
             "--remote-debugging-address=127.0.0.1", "--remote-debugging-port=0",
             f"--user-data-dir={self.profile}", "about:blank"],
            stdout=self.log, stderr=subprocess.STDOUT)
        port_file = os.path.join(self.profile, "DevToolsActivePort")
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise Failed(f"chromium exited ({self.proc.returncode}); see chromium.log")
            if os.path.exists(port_file):
                lines = open(port_file).read().split()
                if len(lines) >= 2:
                    self.cdp = Cdp(f"ws://127.0.0.1:{lines[0]}{lines[1]}")
                    return
            time.sleep(0.1)
        raise Failed("chromium did not open its DevTools port within 60 s")

    def stop(self):
        if getattr(self, "cdp", None):
            try:
                self.cdp.call("Browser.close", timeout=10)
            except Exception:
                pass
            self.cdp.close()
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(10)
        self.log.close()


# ---- cameras and images -------------------------------------------------------------------------------------
def look_at(position, target, width, height, fov_y_deg, up=(0.0, -1.0, 0.0), name="view", cid=0):
    """An INRIA camera at `position` looking at `target` (+y down is the scenes' convention: up = −y)."""
    def sub(a, b):
        return [a[i] - b[i] for i in range(3)]

    def cross(a, b):
        return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]

    def unit(a):
        n = math.sqrt(sum(x * x for x in a))
        return [x / n for x in a]
    fwd = unit(sub(target, position))
    right = unit(cross(fwd, list(up)))
    down = cross(fwd, right)
    f = height / (2 * math.tan(math.radians(fov_y_deg) / 2))
    return {"id": cid, "img_name": name, "width": width, "height": height, "position": list(position),
            "rotation": [[right[i], down[i], fwd[i]] for i in range(3)], "fx": f, "fy": f}


def orbit_camera(scene, azimuth_deg, width, height, elevation_deg=15.0, factor=1.6, name="view", cid=0):
    c, r = scene["center"], scene["radius"]
    az, el = math.radians(azimuth_deg), math.radians(elevation_deg)
    d = r * factor
    pos = [c[0] - d * math.cos(el) * math.sin(az), c[1] - d * math.sin(el), c[2] - d * math.cos(el) * math.cos(az)]
    return look_at(pos, c, width, height, 50.0, name=name, cid=cid)


def read_ppm(path):
    with open(path, "rb") as f:
        data = f.read()
    m = re.match(rb"P6\s+(\d+)\s+(\d+)\s+(\d+)\s", data)
    check(m and m.group(3) == b"255", f"{path} is not an 8-bit binary PPM")
    w, h = int(m.group(1)), int(m.group(2))
    pix = data[m.end():m.end() + w * h * 3]
    check(len(pix) == w * h * 3, f"{path} is truncated")
    return w, h, pix


def rgs_render(exe, scene, cameras_json, out_dir, work, extra=()):
    shutil.rmtree(out_dir, ignore_errors=True)
    r = subprocess.run([exe, scene, "--cameras", cameras_json, "-o", out_dir, "--format", "ppm", "--backend", "cpu"]
                       + list(extra), capture_output=True, text=True, timeout=300, cwd=work)
    check(r.returncode == 0, f"rgs-render --cameras {cameras_json} failed ({r.returncode}): {r.stderr[-1500:]}")
    return sorted(f for f in os.listdir(out_dir) if f.endswith(".ppm"))


# ---- raw WebSocket clients ----------------------------------------------------------------------------------
def ws_connect(url, timeout=30):
    return websocket.create_connection(url, timeout=timeout, suppress_origin=True)


def recv_hello(ws):
    msg = ws.recv()
    check(isinstance(msg, str), "the first message is not text")
    hello = json.loads(msg)
    check(hello.get("type") == "hello", f"the first message is not hello: {msg[:200]}")
    return hello


def parse_frame(data):
    check(isinstance(data, (bytes, bytearray)) and len(data) >= 4, "a frame is not a binary message")
    n = int.from_bytes(data[:4], "little")
    header = json.loads(data[4:4 + n].decode("utf-8"))
    check(header.get("type") == "frame", f"not a frame header: {header}")
    total = sum(im["bytes"] for im in header["images"])
    check(len(data) == 4 + n + total, f"frame {header['seq']}: {len(data)} bytes, header says {4 + n + total}")
    return header


def recv_frame(ws, seq, timeout=60):
    """The frame of `seq` (frames of older seqs are skipped); fails on an error message."""
    deadline = time.monotonic() + timeout
    while True:
        left = deadline - time.monotonic()
        check(left > 0, f"no frame of seq {seq} within {timeout} s")
        ws.settimeout(left)
        op, data = ws.recv_data()
        if op == websocket.ABNF.OPCODE_TEXT:
            msg = json.loads(data.decode("utf-8"))
            raise Failed(f"expected frame {seq}, got {msg}")
        if op == websocket.ABNF.OPCODE_CLOSE:
            raise Failed(f"closed while waiting for frame {seq}")
        header = parse_frame(data)
        if header["seq"] >= seq:
            return header


def view_message(seq, camera, encoding="jpeg", **extra):
    cam = {k: camera[k] for k in ("position", "rotation", "fx", "fy", "width", "height")}
    msg = {"type": "view", "seq": seq, "camera": cam, "preset": "fastest", "background": [0, 0, 0],
           "encoding": encoding, "quality": 80, "compare": "off"}
    msg.update(extra)
    return json.dumps(msg)


def expect_closed_with_error(ws, what, timeout=30):
    """Reads until the server closes: returns (its error message or None, close code or None). Frames are read
    from the socket directly: websocket-client 1.2 refuses close codes it does not know (1013)."""
    sock = ws.sock
    deadline = time.monotonic() + timeout
    error = None
    buf = b""

    def need(n):
        nonlocal buf
        while len(buf) < n:
            left = deadline - time.monotonic()
            if left <= 0:
                raise Failed(f"{what}: the server did not close the connection within {timeout} s")
            sock.settimeout(left)
            try:
                chunk = sock.recv(65536)
            except socket.timeout:
                continue
            except OSError:
                return False
            if not chunk:
                return False
            buf += chunk
        return True
    message = b""
    while True:
        if not need(2):
            return error, None
        b0, b1 = buf[0], buf[1]
        n, at = b1 & 0x7F, 2
        if n == 126:
            if not need(4):
                return error, None
            n, at = int.from_bytes(buf[2:4], "big"), 4
        elif n == 127:
            if not need(10):
                return error, None
            n, at = int.from_bytes(buf[2:10], "big"), 10
        if not need(at + n):
            return error, None
        payload, buf = buf[at:at + n], buf[at + n:]
        op = b0 & 0x0F
        if op == 8:
            return error, (int.from_bytes(payload[:2], "big") if len(payload) >= 2 else None)
        if op in (0, 1, 2):
            message += payload
            if b0 & 0x80:
                if op in (0, 1):
                    try:
                        msg = json.loads(message.decode("utf-8"))
                        if isinstance(msg, dict) and msg.get("type") == "error":
                            error = msg
                    except ValueError:
                        pass
                message = b""


def non_loopback_address():
    """An IPv4 address of this machine other than 127.x, or None."""
    candidates = []
    for probe in ("192.0.2.1", "10.255.255.255"):
        try:
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
                s.connect((probe, 9))
                candidates.append(s.getsockname()[0])
        except OSError:
            pass
    try:
        candidates += [i[4][0] for i in socket.getaddrinfo(socket.gethostname(), None, socket.AF_INET)]
    except OSError:
        pass
    for a in candidates:
        if not a.startswith("127.") and a != "0.0.0.0":
            return a
    return None


def http_status(url):
    try:
        with urllib.request.urlopen(url, timeout=20) as r:
            return r.status, r.read()
    except urllib.error.HTTPError as e:
        return e.code, b""


# ---- the checks ---------------------------------------------------------------------------------------------
class Run:
    def __init__(self, args):
        self.a = args
        self.work = os.path.abspath(args.work_dir)
        self.servers = []
        self.browser = None

    def start_server(self, name, scenes, *extra):
        s = Server(self.a.rgs_view, scenes + ["--backend", "cpu", "--port", "0"] + list(extra), self.work, name)
        self.servers.append(s)
        log(f"  {name}: {s.url}")
        return s

    def first_frame(self):
        page = self.page
        page.goto(self.main.local_url())
        page.wait("rgsView.connected", 60, "the page did not receive hello")
        hello = page.eval("rgsView.hello")
        check(hello["version"] == 1 and hello["backend"] == "cpu", f"hello: {hello}")
        check(len(hello["scenes"]) == 1 and hello["scenes"][0]["gaussians"] > 0, f"hello scenes: {hello['scenes']}")
        self.scene = hello["scenes"][0]
        page.wait("rgsView.frameCount >= 1", 60, "no frame was drawn")
        self.wait_still(page)
        f = page.eval("rgsView.lastFrame()")
        check((f["width"], f["height"]) == (page.width, page.height),
              f"the still frame is {f['width']}x{f['height']}, the window {page.width}x{page.height}")
        check(f["images"] and f["images"][0]["role"] == "a" and f["images"][0]["encoding"] == "jpeg",
              f"images: {f['images']}")
        check(f["stats"].get("render_call_ms") is not None and f["stats"].get("splats", 0) > 0, f"stats: {f['stats']}")
        text = page.eval("document.getElementById('stats').innerText")
        check("splats" in text and "latency" in text, f"the stats panel shows: {text!r}")
        page.screenshot(os.path.join(self.work, "first_frame.png"))
        log(f"  first frame: seq {f['seq']}, {f['width']}x{f['height']}, {f['bytes']} bytes, "
            f"latency {f['latency_ms']:.0f} ms; screenshot first_frame.png")

    def wait_still(self, page, timeout=30):
        """Waits until the page has drawn the full-resolution frame of its current (still) camera."""
        page.wait("(() => { const f = rgsView.lastFrame(), c = rgsView.camera(); return f && f.camera && "
                  "f.width === c.width && f.height === c.height && "
                  "JSON.stringify(f.camera.position) === JSON.stringify(c.position) && "
                  "JSON.stringify(f.camera.rotation) === JSON.stringify(c.rotation); })()",
                  timeout, "the page did not settle on a full-resolution frame of its camera")
        time.sleep(0.3)  # the frame of a last pending view, if any
        page.wait("(() => { const f = rgsView.lastFrame(), c = rgsView.camera(); return "
                  "JSON.stringify(f.camera) === JSON.stringify(c); })()", timeout, "the page did not settle")

    def navigate(self):
        page = self.page
        centre = page.eval("rgsView.target()")
        dist = lambda c: math.dist(c["position"], centre)
        before = page.eval("({c: rgsView.camera(), f: rgsView.lastFrame()})")
        d0 = dist(before["c"])
        page.drag(200, 180, 330, 230)
        page.wait(f"rgsView.lastFrame().seq > {before['f']['seq']}", 30, "no frame after the drag")
        self.wait_still(page)
        after = page.eval("({c: rgsView.camera(), f: rgsView.lastFrame()})")
        # while moving the page asks for half resolution, once still for the full size
        sizes = [(f["width"], f["height"]) for f in page.eval("rgsView.frameLog()") if f["seq"] > before["f"]["seq"]]
        check((page.width // 2, page.height // 2) in sizes and sizes[-1] == (page.width, page.height),
              f"frame sizes during and after the drag: {sizes}")
        moved = math.dist(after["c"]["position"], before["c"]["position"])
        check(moved > 0.05 * self.scene["radius"], f"the drag moved the camera by {moved} only")
        # the home view orbits the scene centre: the distance to it is kept
        check(abs(dist(after["c"]) - d0) < 1e-4 * d0, f"orbit changed the distance to the target: {d0} -> {dist(after['c'])}")
        check(after["f"]["digest"] != before["f"]["digest"], "the frame after the drag is the same image")
        # the wheel dollies out: farther from the target, the same direction
        page.mouse("mouseWheel", 300, 220, deltaX=0, deltaY=300)
        self.wait_still(page)
        wheel = page.eval("({c: rgsView.camera(), f: rgsView.lastFrame()})")
        check(dist(wheel["c"]) > dist(after["c"]) * 1.2, f"the wheel did not dolly out: {dist(after['c'])} -> {dist(wheel['c'])}")
        check(wheel["c"]["rotation"] == after["c"]["rotation"], "dolly turned the camera")
        page.screenshot(os.path.join(self.work, "navigate.png"))
        log(f"  navigate: drag moved the camera {moved:.3f} (distance to the target {d0:.4f} kept), wheel "
            f"{dist(after['c']):.3f} -> {dist(wheel['c']):.3f}; frames {before['f']['digest']} -> {after['f']['digest']}")
        self.fly_and_touch()

    def fly_and_touch(self):
        page = self.page
        cam = lambda: page.eval("rgsView.camera()")
        fwd = lambda c: [c["rotation"][i][2] for i in range(3)]
        # fly: W moves along the view direction, a drag turns the camera in place
        page.eval("rgsView.setOptions({mode: 'fly'})")
        c0 = cam()
        key = {"code": "KeyW", "key": "w", "windowsVirtualKeyCode": 87, "nativeVirtualKeyCode": 87}
        page.call("Input.dispatchKeyEvent", dict(key, type="keyDown"))
        time.sleep(0.4)
        page.call("Input.dispatchKeyEvent", dict(key, type="keyUp"))
        self.wait_still(page)
        c1 = cam()
        step = [a - b for a, b in zip(c1["position"], c0["position"])]
        n = math.sqrt(sum(x * x for x in step))
        check(n > 0.02 * self.scene["radius"], f"W moved the camera by {n}")
        along = sum(a * b for a, b in zip(step, fwd(c0))) / n
        check(along > 0.999 and c1["rotation"] == c0["rotation"], f"W moved at {along} to the view direction, or turned")
        page.drag(400, 225, 470, 205)
        self.wait_still(page)
        c2 = cam()
        turned = math.degrees(math.acos(max(-1.0, min(1.0, sum(a * b for a, b in zip(fwd(c1), fwd(c2)))))))
        check(c2["position"] == c1["position"] and turned > 3, f"fly look: moved or turned {turned:.2f} deg only")
        page.eval("rgsView.setOptions({mode: 'orbit'})")
        # touch: one finger orbits (distance to the target kept), two fingers pinching out dolly in
        page.call("Emulation.setTouchEmulationEnabled", {"enabled": True, "maxTouchPoints": 5})
        t = page.eval("rgsView.target()")
        d = lambda c: math.dist(c["position"], t)
        c3 = cam()

        def touch(kind, points):
            page.call("Input.dispatchTouchEvent",
                      {"type": kind, "touchPoints": [{"x": x, "y": y, "id": i} for i, (x, y) in enumerate(points)]})
        touch("touchStart", [(300, 200)])
        for i in range(1, 7):
            touch("touchMove", [(300 + 12 * i, 200 + 3 * i)])
            time.sleep(0.02)
        touch("touchEnd", [])
        self.wait_still(page)
        c4 = cam()
        check(math.dist(c4["position"], c3["position"]) > 0.05 * self.scene["radius"], "a one-finger drag did not orbit")
        check(abs(d(c4) - d(c3)) < 1e-4 * d(c3), f"one-finger orbit changed the distance to the target {d(c3)} -> {d(c4)}")
        touch("touchStart", [(350, 225), (450, 225)])
        for i in range(1, 7):
            touch("touchMove", [(350 - 10 * i, 225), (450 + 10 * i, 225)])
            time.sleep(0.02)
        touch("touchEnd", [])
        self.wait_still(page)
        c5 = cam()
        t5 = page.eval("rgsView.target()")
        check(math.dist(c5["position"], t5) < 0.75 * d(c4), f"pinching out did not dolly in: {d(c4)} -> {math.dist(c5['position'], t5)}")
        page.call("Emulation.setTouchEmulationEnabled", {"enabled": False})
        log(f"  fly: W moved {n:.3f} along the view, a drag turned {turned:.1f} deg in place; touch: one finger "
            f"orbited (distance {d(c3):.3f} kept), a pinch dollied {d(c4):.3f} -> {math.dist(c5['position'], t5):.3f}")

    def budget(self):
        page = self.page
        set_budget = ("(v) => { const e = document.getElementById('max-mbps'); e.value = v; "
                      "e.dispatchEvent(new Event('change')); return rgsView.camera(); }")
        page.eval(f"({set_budget})('0.2')")
        page.wait("rgsView.lastFrame().max_mbps === 0.2", 30, "no frame under the budget typed in")
        self.wait_still(page)
        before = page.eval("rgsView.lastFrame()")
        check(before["quality"] == 85 and before["scale"] == 1 and before["max_mbps"] == 0.2,
              f"the still frame under a budget: quality {before['quality']}, scale {before['scale']}, "
              f"budget {before['max_mbps']}")
        # a drag held down: moving frames under 0.2 Mbit/s
        x, y = 250, 200
        page.mouse("mouseMoved", x, y)
        page.mouse("mousePressed", x, y, "left", 1, clickCount=1)
        moving = []
        deadline = time.monotonic() + 60
        while len(moving) < 3 and time.monotonic() < deadline:
            x += 6
            page.mouse("mouseMoved", x, y, "left", 1)
            time.sleep(0.05)
            f = page.eval("rgsView.lastFrame()")
            if f["seq"] > before["seq"] and f["camera"] and f["camera"]["width"] < page.width and \
                    (not moving or f["seq"] != moving[-1]["seq"]):
                moving.append(f)
        text = page.eval("document.getElementById('stats').innerText")
        page.eval("document.getElementById('stats').scrollIntoView({block: 'end'})")
        page.screenshot(os.path.join(self.work, "budget_moving.png"))
        page.mouse("mouseReleased", x, y, "left", 0, clickCount=1)
        check(len(moving) >= 3, f"only {len(moving)} moving frames in 60 s")
        last = moving[-1]
        asked = (last["camera"]["width"], last["camera"]["height"])
        check(last["max_mbps"] == 0.2 and (last["scale"] < 1 or last["quality"] < 85),
              f"a moving frame under 0.2 Mbit/s: quality {last['quality']}, scale {last['scale']}")
        check(last["width"] == round(asked[0] * last["scale"]), f"frame {last['width']} wide for {asked} "
              f"at scale {last['scale']}")
        check("Mbit/s" in text and "budget 0.2" in text and "quality" in text, f"the stats panel shows: {text!r}")
        self.wait_still(page)
        still = page.eval("rgsView.lastFrame()")
        check((still["width"], still["height"]) == (page.width, page.height) and still["quality"] == 85 and
              still["scale"] == 1, f"the still frame: {still['width']}x{still['height']} q{still['quality']}")
        log(f"  budget: moving frames {[(f['width'], f['quality'], f['bytes']) for f in moving]} (asked {asked}), "
            f"still {still['width']}x{still['height']} q{still['quality']} {still['bytes']} bytes; "
            f"screenshot budget_moving.png")
        # values the server would refuse are not sent: no budget, no error
        errors = len(page.eval("rgsView.errors"))
        for bad in ("-5", "abc", "1e400"):
            page.eval(f"({set_budget})('{bad}')")
            check(page.eval("document.getElementById('max-mbps').value") == "0", f"the control kept {bad!r}")
            page.drag(300, 200, 320, 210, steps=3)
            self.wait_still(page)
            f = page.eval("rgsView.lastFrame()")
            check(f["max_mbps"] is None, f"budget {bad!r}: the frame says {f['max_mbps']}")
        check(len(page.eval("rgsView.errors")) == errors and page.eval("rgsView.connected"),
              "a bad budget in the control made an error")

    def lossless(self):
        page = self.page
        cam = orbit_camera(self.scene, 35.0, 256, 192, elevation_deg=10.0, name="lossless_view")
        path = os.path.join(self.work, "lossless_cameras.json")
        with open(path, "w") as f:
            json.dump([cam], f)
        # the default preset on black, and another preset on a coloured background
        for preset, background in (("fastest", [0, 0, 0]), ("paper", [0.2, 0.4, 0.6])):
            tag = f"{preset}_bg{'_'.join(str(v) for v in background)}"
            out = os.path.join(self.work, f"lossless_render_{tag}")
            files = rgs_render(self.a.rgs_render, self.scene_path, path, out, self.work,
                               ["--preset", preset, "--background", ",".join(str(v) for v in background)])
            check(len(files) == 1, f"rgs-render wrote {files}")
            w, h, ref = read_ppm(os.path.join(out, files[0]))
            page.eval(f"rgsView.setOptions({{preset: '{preset}', background: {json.dumps(background)}}})")
            got = page.eval(f"rgsView.requestLossless({{camera: {json.dumps(cam)}, pixels: true}})", timeout=120)
            check((got["width"], got["height"]) == (w, h),
                  f"lossless frame {got['width']}x{got['height']}, rgs-render {w}x{h}")
            f = page.eval("rgsView.lastFrame()")
            check(f["images"][0]["encoding"] == "webp-lossless", f"the lossless frame is {f['images']}")
            check(f["preset"] in (None, preset), f"the frame says preset {f['preset']}, asked {preset}")
            pix = base64.b64decode(got["rgb"])
            with open(os.path.join(self.work, f"lossless_page_{tag}.png"), "wb") as o:
                o.write(base64.b64decode(got["png"].split(",", 1)[1]))
            if pix != ref:
                diff = [abs(a - b) for a, b in zip(pix, ref)]
                bad = sum(1 for i in range(0, len(diff), 3) if diff[i] or diff[i + 1] or diff[i + 2])
                raise Failed(f"{preset}: the page's lossless frame differs from rgs-render's in {bad} of {w * h} "
                             f"pixels (max {max(diff)}); lossless_page_{tag}.png vs {out}/{files[0]}")
            check(len(set(ref)) > 16, "the reference image is (nearly) blank: the camera misses the scene")
            log(f"  lossless: preset {preset}, background {background}: the {w}x{h} frame equals rgs-render "
                f"--backend cpu's image byte for byte ({len(set(pix))} levels)")
        page.eval("rgsView.setOptions({preset: 'fastest', background: [0, 0, 0]})")
        self.wait_still(page)
        # interactive WebP frames decode too
        for enc, name in (("webp", "webp"), ("lossless", "webp-lossless"), ("jpeg", "jpeg")):
            page.eval(f"rgsView.setOptions({{encoding: '{enc}'}})")
            page.wait(f"rgsView.lastFrame().images[0].encoding === '{name}'", 30, f"no {name} frame drawn")
        # the screenshot button: a lossless frame of the current view at full size, saved as PNG
        downloads = os.path.join(self.work, "downloads")
        os.makedirs(downloads, exist_ok=True)
        self.browser.cdp.call("Browser.setDownloadBehavior", {"behavior": "allow", "downloadPath": downloads})
        page.eval("document.getElementById('screenshot').click()")
        png = self.wait_download(downloads, ".png")
        with open(png, "rb") as f:
            head = f.read(24)
        check(head[:8] == b"\x89PNG\r\n\x1a\n", f"{png} is not a PNG")
        size = (int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big"))
        check(size == (page.width, page.height), f"the screenshot is {size}, the window {page.width}x{page.height}")
        log(f"  screenshot button: {os.path.basename(png)} ({size[0]}x{size[1]} PNG); interactive webp, "
            "lossless and jpeg frames drawn")

    def wait_download(self, folder, suffix, timeout=60):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            done = [f for f in os.listdir(folder) if f.endswith(suffix)]
            if done:
                path = os.path.join(folder, done[0])
                time.sleep(0.3)
                return path
            time.sleep(0.1)
        raise Failed(f"no {suffix} file was downloaded within {timeout} s; page console: {self.page.console()}")

    def path(self):
        page = self.page
        cams = [orbit_camera(self.scene, az, 320, 240, name=f"set_{i}") for i, az in enumerate((0, 60, 120, 180))]
        page.eval("rgsView.record.start()")
        for c in cams:
            page.eval(f"rgsView.waitForFrame(rgsView.setCamera({json.dumps(c)}), 60000).then(() => true)", timeout=90)
        page.eval("rgsView.record.stop()")
        recorded = page.eval("rgsView.record.cameras()")
        text = page.eval("rgsView.record.json()")
        check(len(recorded) == len(cams), f"recorded {len(recorded)} views for {len(cams)} cameras set")
        keys = {"id", "img_name", "width", "height", "position", "rotation", "fx", "fy"}
        for i, (r, c) in enumerate(zip(recorded, cams)):
            check(set(r) == keys, f"recorded camera {i} has keys {sorted(r)}")
            check(r["id"] == i and isinstance(r["img_name"], str), f"recorded camera {i}: id {r['id']}, {r['img_name']}")
            check(math.dist(r["position"], c["position"]) < 1e-9, f"camera {i}: position {r['position']} != {c['position']}")
            err = max(abs(r["rotation"][a][b] - c["rotation"][a][b]) for a in range(3) for b in range(3))
            check(err < 1e-6, f"camera {i}: rotation differs by {err}")
            fov_set = 2 * math.atan(c["height"] / (2 * c["fy"]))
            fov_rec = 2 * math.atan(r["height"] / (2 * r["fy"]))
            check(abs(fov_set - fov_rec) < 1e-6, f"camera {i}: vertical field of view {fov_rec} != {fov_set}")
        path = os.path.join(self.work, "recorded_path.json")
        with open(path, "w") as f:
            f.write(text)
        # the Save button downloads the same file
        downloads = os.path.join(self.work, "downloads")
        page.eval("document.getElementById('save-path').click()")
        saved = self.wait_download(downloads, ".json")
        with open(saved) as f:
            check(f.read() == text, f"{saved} differs from the recorded path")
        files = rgs_render(self.a.rgs_render, self.scene_path, path, os.path.join(self.work, "path_render"), self.work)
        check(len(files) == len(recorded), f"rgs-render rendered {len(files)} views of {len(recorded)}")
        # the panel's Record / Stop buttons: the view at the start and each distinct pose sent while recording
        page.click("#record")
        check(page.eval("rgsView.record.recording"), "the Record button did not start recording")
        page.drag(150, 300, 250, 300)
        self.wait_still(page)
        page.drag(150, 300, 120, 260)
        self.wait_still(page)
        page.click("#record")
        ui = page.eval("rgsView.record.cameras()")
        check(not page.eval("rgsView.record.recording") and len(ui) >= 3,
              f"recording with the buttons around two drags gave {len(ui)} views")
        check(ui[-1]["position"] == page.eval("rgsView.camera()")["position"], "the last recorded view is not the current one")
        with open(os.path.join(self.work, "recorded_ui.json"), "w") as f:
            f.write(page.eval("rgsView.record.json()"))
        files = rgs_render(self.a.rgs_render, self.scene_path, os.path.join(self.work, "recorded_ui.json"),
                           os.path.join(self.work, "path_ui_render"), self.work)
        check(len(files) == len(ui), f"rgs-render rendered {len(files)} views of {len(ui)} recorded with the buttons")
        recorded = ui
        n0 = page.eval("rgsView.frameCount")
        page.eval("rgsView.record.replay().then(() => true)", timeout=120)
        n1 = page.eval("rgsView.frameCount")
        check(n1 - n0 >= len(recorded), f"replay drew {n1 - n0} frames for {len(recorded)} views")
        last = page.eval("rgsView.lastFrame().camera")
        check(last["position"] == recorded[-1]["position"], "replay did not end at the last recorded view")
        log(f"  path: {len(cams)} cameras set and recorded, rgs-render --cameras rendered them; recorded with the "
            f"buttons around two drags: {len(ui)} views, all rendered; replay drew {n1 - n0} frames")

    def compare(self):
        # the scene's own cameras too (--cameras): the page starts at the first, the list jumps to the others
        cams = [orbit_camera(self.scene, az, 640, 480, name=f"scene_cam_{i}", cid=i)
                for i, az in enumerate((-30.0, 40.0, 200.0))]
        cams_path = os.path.join(self.work, "scene_cameras.json")
        with open(cams_path, "w") as f:
            json.dump(cams, f)
        cmp_server = self.start_server("rgs-view-compare", [self.scene_path, self.scene2_path], "--cameras", cams_path)
        page = Page(self.browser.cdp, 800, 450)
        try:
            page.goto(cmp_server.local_url())
            page.wait("rgsView.connected", 60, "the compare page did not receive hello")
            hello = page.eval("rgsView.hello")
            check(hello["compare"] and len(hello["scenes"]) == 2, f"compare hello: {hello['scenes']}")
            check(len(hello["cameras"]) == 3, f"hello has {len(hello['cameras'])} cameras, the file 3")

            def same_pose(got, want, what):
                check(math.dist(got["position"], want["position"]) < 1e-9, f"{what}: position {got['position']}")
                err = max(abs(got["rotation"][a][b] - want["rotation"][a][b]) for a in range(3) for b in range(3))
                check(err < 1e-6, f"{what}: rotation differs by {err}")
                fov = lambda c: 2 * math.atan(c["height"] / (2 * c["fy"]))
                check(abs(fov(got) - fov(want)) < 1e-6, f"{what}: field of view {fov(got)} != {fov(want)}")
            same_pose(page.eval("rgsView.camera()"), cams[0], "the starting view (the first scene camera)")
            check(page.eval("document.getElementById('camera-list').options.length") == 4, "the camera list")
            page.eval("(() => { const s = document.getElementById('camera-list'); s.value = '2'; "
                      "s.dispatchEvent(new Event('change')); })()")
            same_pose(page.eval("rgsView.camera()"), cams[2], "after jumping to camera 2")
            page.eval("(() => { const s = document.getElementById('camera-list'); s.value = '0'; "
                      "s.dispatchEvent(new Event('change')); })()")
            log("  scene cameras: the page starts at the first; the list jumps to camera 2 and back")
            check(page.eval("!document.getElementById('compare-box').hidden"), "the compare panel is hidden")
            page.wait("rgsView.frameCount >= 1", 60, "no frame in the compare page")
            # Two scenes open on the split view: the first frame already carries images a and b.
            check(page.eval("document.getElementById('cmp-split').classList.contains('on')"),
                  "the compare page did not open on the split view")
            page.wait("rgsView.lastFrame().images.map(i => i.role).join() === 'a,b'", 60,
                      "the first compare frames are not split frames (images a, b)")
            page.click("#cmp-off")  # the panel's buttons, clicked with the mouse
            page.wait("rgsView.lastFrame().images.map(i => i.role).join() === 'a'", 60, "no plain frame after 'off'")
            n = page.eval("rgsView.lastFrame().seq")
            page.click("#cmp-split")
            page.wait(f"(() => {{ const f = rgsView.lastFrame(); return f.seq > {n} && "
                      "f.images.map(i => i.role).join() === 'a,b'; })()", 60, "no split frame (images a, b)")
            self.wait_still(page)
            f = page.eval("rgsView.lastFrame()")
            check(f["psnr"] is not None and math.isfinite(f["psnr"]) and f["psnr"] > 10,
                  f"split frame PSNR {f['psnr']} (mse {f.get('mse')}, diff_max {f.get('diff_max')})")
            shown = page.eval("document.getElementById('psnr').textContent")
            check(f"{f['psnr']:.2f} dB" == shown, f"the panel shows PSNR {shown!r}, the frame says {f['psnr']}")
            check(page.eval("!document.getElementById('split').hidden"), "the split slider is hidden")
            page.screenshot(os.path.join(self.work, "compare_split.png"))
            # drag the handle from the middle to a quarter of the view
            r = page.eval("(() => { const b = document.getElementById('split-handle').getBoundingClientRect(); "
                          "return [b.left + b.width / 2, b.top + b.height / 2]; })()")
            check(abs(r[0] - 400) < 2, f"the split handle starts at x {r[0]}, not the middle")
            page.drag(r[0], r[1], 200, r[1])
            split = page.eval("rgsView.split")
            r2 = page.eval("(() => { const b = document.getElementById('split-handle').getBoundingClientRect(); "
                           "return [b.left + b.width / 2, b.top + b.height / 2]; })()")
            check(abs(split - 0.25) < 0.01 and abs(r2[0] - 200) < 2, f"after the drag split = {split}, handle at {r2[0]}")
            check(page.eval("rgsView.lastFrame().seq") == f["seq"], "dragging the split handle moved the camera")
            page.screenshot(os.path.join(self.work, "compare_split_moved.png"))
            page.eval("rgsView.setOptions({compare: 'diff'})")
            page.wait("rgsView.lastFrame().images.map(i => i.role).join() === 'diff'", 60, "no difference frame")
            fd = page.eval("rgsView.lastFrame()")
            check(fd["psnr"] is not None and abs(fd["psnr"] - f["psnr"]) < 1e-6,
                  f"diff frame PSNR {fd['psnr']} != split frame's {f['psnr']} (same camera)")
            page.screenshot(os.path.join(self.work, "compare_diff.png"))
            n = fd["seq"]
            page.eval("rgsView.setOptions({diffScale: 4})")
            page.wait(f"rgsView.lastFrame().seq > {n}", 60, "no frame after the diff scale changed")
            self.wait_still(page)
            fd4 = page.eval("rgsView.lastFrame()")
            check(fd4["digest"] != fd["digest"], "the heatmap did not change with the diff scale")
            page.screenshot(os.path.join(self.work, "compare_diff_scale4.png"))
            log(f"  compare: split frame a+b, PSNR {f['psnr']:.2f} dB shown as {shown!r}, diff_max {f['diff_max']}; "
                f"slider dragged to {split:.3f}; heatmap frame; screenshots compare_split*.png, compare_diff.png")
        finally:
            page.close()
            code = cmp_server.stop()
            check(code == 0, f"the compare server exited {code} on SIGTERM")

    def security(self):
        # the default server binds to loopback only
        addr = non_loopback_address()
        if addr is None:
            log("  skipped: loopback-only check: this machine has no non-loopback IPv4 address")
        else:
            try:
                with socket.create_connection((addr, self.main.port), timeout=5):
                    raise Failed(f"the default server is reachable on {addr}:{self.main.port}")
            except (ConnectionRefusedError, socket.timeout, OSError) as e:
                if isinstance(e, Failed):
                    raise
                log(f"  security: default server not reachable on {addr}:{self.main.port} ({type(e).__name__})")
        # a non-loopback bind needs the token
        open_server = self.start_server("rgs-view-token", [self.scene_path], "--host", "0.0.0.0")
        try:
            check(open_server.token and len(open_server.token) >= 16,
                  f"with --host 0.0.0.0 the printed URL carries no token: {open_server.url}")
            st, _ = http_status(open_server.local_url("/", token=False))
            check(st == 403, f"GET / without the token: {st}, expected 403")
            st, _ = http_status(f"http://127.0.0.1:{open_server.port}/?token=0123456789abcdef0123456789abcdef")
            check(st == 403, f"GET / with a wrong token: {st}, expected 403")
            st, _ = http_status(open_server.local_url("/app.js", token=False))
            check(st == 403, f"GET /app.js without the token: {st}, expected 403")
            st, body = http_status(open_server.local_url("/"))
            check(st == 200 and b"rgs-view" in body, f"GET / with the token: {st}")
            try:
                ws_connect(open_server.ws_url(token=False), timeout=10).close()
                raise Failed("the WebSocket upgrade without the token was accepted")
            except websocket.WebSocketBadStatusException as e:
                check(e.status_code == 403, f"WebSocket upgrade without the token: {e.status_code}, expected 403")
            ws = ws_connect(open_server.ws_url())
            recv_hello(ws)
            ws.close()
            # the page passes its own token on to /ws
            page = Page(self.browser.cdp, 480, 270)
            try:
                page.goto(open_server.local_url("/"))
                page.wait("rgsView.frameCount >= 1", 60, "the page with a token got no frame")
            finally:
                page.close()
            log("  security: --host 0.0.0.0: token in the URL; 403 without it or with a wrong one (page, script, "
                "WebSocket), 200 and frames with it")
        finally:
            code = open_server.stop()
            check(code == 0, f"the token server exited {code} on SIGTERM")

    def clients(self):
        # the page's own connection is closed first: the server allows 8 clients
        self.page.call("Page.navigate", {"url": "about:blank"})
        time.sleep(0.5)
        socks = []
        try:
            deadline = time.monotonic() + 30
            while len(socks) < 8:
                ws = ws_connect(self.main.ws_url())
                first = json.loads(ws.recv())
                if first.get("type") == "error" and first.get("code") == "busy" and time.monotonic() < deadline:
                    ws.close()  # the page's connection may not have been closed on the server's side yet
                    time.sleep(0.2)
                    continue
                check(first.get("type") == "hello", f"client {len(socks)}: first message {first}")
                socks.append(ws)
            extra = ws_connect(self.main.ws_url())
            try:
                first = extra.recv()
                msg = json.loads(first)
                if msg.get("type") == "hello":  # a previous client may still be closing: give it a moment
                    raise Failed("a 9th client was accepted while 8 were connected")
                check(msg.get("type") == "error" and msg.get("code") == "busy", f"9th client got {msg}")
                err, code = expect_closed_with_error(extra, "9th client")
                check(code in (1013, None), f"9th client closed with {code}")
            finally:
                extra.close()
            results = [None] * 8
            errors = []

            def one(i):
                try:
                    cam = orbit_camera(self.scene, 45.0 * i, 96 + 8 * i, 64 + 4 * i)
                    seq = 1000 + i
                    socks[i].send(view_message(seq, cam, encoding="lossless"))
                    h = recv_frame(socks[i], seq, timeout=120)
                    results[i] = h
                except Exception as e:  # noqa: BLE001 - reported below
                    errors.append(f"client {i}: {e}")
            threads = [threading.Thread(target=one, args=(i,)) for i in range(8)]
            for t in threads:
                t.start()
            for t in threads:
                t.join(180)
            check(not errors, "; ".join(errors))
            for i, h in enumerate(results):
                check(h is not None, f"client {i} got no frame")
                check(h["seq"] == 1000 + i and (h["width"], h["height"]) == (96 + 8 * i, 64 + 4 * i),
                      f"client {i} got seq {h['seq']} {h['width']}x{h['height']}")
            log("  clients: 8 WebSocket clients at once, each got the frame of its own camera (seq and size); "
                "a 9th was told busy")
        finally:
            for ws in socks:
                ws.close()

    def abuse(self):
        stop = threading.Event()
        counts = [0, 0]
        errors = []

        def steady(i):
            try:
                ws = ws_connect(self.main.ws_url())
                recv_hello(ws)
                seq = 0
                while not stop.is_set():
                    seq += 1
                    cam = orbit_camera(self.scene, 10.0 * seq + 90 * i, 80, 60)
                    ws.send(view_message(seq, cam))
                    recv_frame(ws, seq, timeout=60)
                    counts[i] += 1
                ws.close()
            except Exception as e:  # noqa: BLE001
                errors.append(f"steady client {i}: {e}")
        threads = [threading.Thread(target=steady, args=(i,)) for i in range(2)]
        for t in threads:
            t.start()
        try:
            deadline = time.monotonic() + 60
            while min(counts) < 2 and time.monotonic() < deadline and not errors:
                time.sleep(0.05)
            check(not errors and min(counts) >= 2, f"the steady clients did not start: {counts} {errors}")
            good = orbit_camera(self.scene, 0, 64, 48)
            bad_rotation = dict(good, rotation=[[1, 0, 0], [0, 2, 0], [0, 0, 1]])
            cases = [
                ("malformed JSON", "text", '{"type":"view","seq":1,'),
                ("not an object", "text", "[1,2,3]"),
                ("unknown type", "text", '{"type":"launch"}'),
                ("a camera that is no rotation", "text", view_message(1, bad_rotation)),
                ("a negative width", "text", view_message(1, dict(good, width=-5))),
                ("a negative budget", "text", view_message(1, good, max_mbps=-1)),
                ("a huge budget", "text", view_message(1, good, max_mbps=1e12)),
                ("a budget that is no number", "text", view_message(1, good, max_mbps="50")),
                ("oversized message (100 KiB)", "text", json.dumps({"type": "view", "pad": "x" * 100000})),
                ("binary message", "binary", b"\x00\x01\x02\x03"),
            ]
            for what, kind, payload in cases:
                ws = ws_connect(self.main.ws_url())
                try:
                    recv_hello(ws)
                    if kind == "text":
                        ws.send(payload)
                    else:
                        ws.send_binary(payload)
                    err, code = expect_closed_with_error(ws, what)
                    if kind == "text" and len(payload) > 65536 and err is None:
                        # the message limit is enforced by the WebSocket layer: it may close (1009) at once
                        check(code == 1009, f"{what}: closed with {code} and no error message, expected 1009")
                    else:
                        check(err is not None and err.get("fatal") is True, f"{what}: error message {err}, "
                              f"close code {code}")
                    check(code is None or code in (1008, 1009, 1003, 1007), f"{what}: close code {code}")
                finally:
                    ws.close()
                log(f"  abuse: {what}: error {(err or {}).get('code')!r} ({(err or {}).get('message', '')[:60]}), "
                    f"closed {code}")
            c0 = list(counts)
            deadline = time.monotonic() + 60
            while min(counts[0] - c0[0], counts[1] - c0[1]) < 3 and time.monotonic() < deadline and not errors:
                time.sleep(0.05)
            check(not errors, "; ".join(errors))
            check(min(counts[0] - c0[0], counts[1] - c0[1]) >= 3, f"steady clients stalled: {c0} -> {counts}")
        finally:
            stop.set()
            for t in threads:
                t.join(120)
        check(not errors, "; ".join(errors))
        # the page still works
        self.page.goto(self.main.local_url())
        self.page.wait("rgsView.frameCount >= 1", 60, "the page got no frame after the abuse")
        log(f"  abuse: the two steady clients kept getting frames ({counts[0]}, {counts[1]}); the page reconnects and draws")

    def readme_screenshot(self):
        page = Page(self.browser.cdp, 1280, 720)
        try:
            page.goto(self.main.local_url())
            page.wait("rgsView.frameCount >= 1", 60, "no frame for the README screenshot")
            page.eval("rgsView.setOptions({scale: 1, quality: 92})")
            # the guitar's front, a little left of the middle (the panel covers the right)
            c = orbit_camera(self.scene, -35.0, 1280, 720, elevation_deg=12.0, factor=2.7)
            right = [c["rotation"][i][0] for i in range(3)]
            shift = 0.4 * self.scene["radius"]
            pos = [c["position"][i] + shift * right[i] for i in range(3)]
            cam = look_at(pos, [self.scene["center"][i] + shift * right[i] for i in range(3)], 1280, 720, 50.0)
            page.eval(f"rgsView.waitForFrame(rgsView.setCamera({json.dumps(cam)}), 60000).then(() => true)", timeout=90)
            self.wait_still(page)
            time.sleep(0.5)
            shot = page.screenshot(os.path.join(self.work, "readme.png"))
            os.makedirs(os.path.dirname(os.path.abspath(self.a.save_screenshot)), exist_ok=True)
            shutil.copyfile(shot, self.a.save_screenshot)
            log(f"  screenshot for the README: {self.a.save_screenshot} ({os.path.getsize(shot)} bytes)")
        finally:
            page.close()

    def run(self):
        os.makedirs(self.work, exist_ok=True)
        self.scene_path = os.path.join(self.work, "guitar.rgs")
        self.scene2_path = os.path.join(self.work, "guitar_archive.rgs")
        for out, extra in ((self.scene_path, []), (self.scene2_path, ["--profile", "archive"])):
            r = subprocess.run([self.a.rgs_convert, self.a.guitar, out] + extra, capture_output=True, text=True,
                               timeout=300)
            check(r.returncode == 0, f"rgs-convert {' '.join(extra)} failed: {r.stderr[-1000:]}")
        only = set(self.a.only.split(",")) if self.a.only else None
        steps = ["first_frame", "navigate", "budget", "lossless", "path", "compare", "security", "clients", "abuse"]
        self.main = self.start_server("rgs-view", [self.scene_path])
        self.browser = Browser(self.a.chromium, self.work)
        self.page = Page(self.browser.cdp, 800, 450)
        for step in steps:
            if only and step not in only and step != "first_frame":
                continue
            t0 = time.monotonic()
            log(f"{step}:")
            getattr(self, step)()
            log(f"  ({time.monotonic() - t0:.1f} s)")
        if self.a.save_screenshot:
            self.readme_screenshot()
        # no script error in any page, all along
        thrown = [e["params"]["exceptionDetails"] for e in self.browser.cdp.exceptions]
        check(not thrown, "the page threw: " +
              "; ".join(str((d.get("exception") or {}).get("description") or d.get("text")) for d in thrown))
        log("no script error in the pages")
        self.page.close()
        log("shutdown:")
        code = self.main.stop()
        check(code == 0, f"rgs-view exited {code} on SIGTERM (expected 0)")
        log("  rgs-view exited 0 on SIGTERM")

    def cleanup(self):
        if self.browser:
            try:
                self.browser.stop()
            except Exception as e:  # noqa: BLE001
                log(f"  (stopping chromium: {e})")
        for s in self.servers:
            if s.proc.poll() is None:
                s.stop(signal.SIGKILL, 10)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("rgs_view")
    ap.add_argument("rgs_render")
    ap.add_argument("rgs_convert")
    ap.add_argument("guitar")
    ap.add_argument("work_dir")
    ap.add_argument("--only", help="comma list of steps (first_frame always runs)")
    ap.add_argument("--save-screenshot", help="also write a screenshot of the page (1280x720) here")
    ap.add_argument("--chromium", default=os.environ.get("RGS_CHROMIUM"))
    a = ap.parse_args()
    if not a.chromium:
        a.chromium = next((c for c in CHROMIUM_CANDIDATES if os.access(c, os.X_OK)), None) or shutil.which("chromium")
    if not a.chromium or not os.access(a.chromium, os.X_OK):
        skip(f"no chromium ({a.chromium or 'Debian package chromium'} not found)")
    if websocket is None:
        skip("no python3-websocket (the websocket module)")
    run = Run(a)
    # a hard bound on the whole test, whatever hangs
    timer = threading.Timer(540, lambda: (log("FAILED: the test ran over 540 s"), run.cleanup(), os._exit(1)))
    timer.daemon = True
    timer.start()
    t0 = time.monotonic()
    try:
        run.run()
    except Failed as e:
        log(f"FAILED: {e}")
        for s in run.servers:
            if s.proc.poll() is not None and s.proc.returncode not in (0, None):
                log(f"  {os.path.basename(s.log_path)}: exited {s.proc.returncode}: {''.join(s.lines)[-800:]}")
        return 1
    finally:
        run.cleanup()
        timer.cancel()
    log(f"passed ({time.monotonic() - t0:.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
