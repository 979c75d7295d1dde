# rgs-view as a command: prints its URL, serves the page, refuses requests without the token off loopback, refuses
# WebSocket upgrades from other pages' origins and requests naming another host, and shuts down cleanly on SIGINT
# and SIGTERM (exit 0, port closed); usage errors (a short token among them) exit 2.
# Usage: test_rgs_view_cli.py RGS_VIEW SCENE
import signal
import socket
import subprocess
import sys
import urllib.error
import urllib.parse
import urllib.request

rgs_view, scene = sys.argv[1], sys.argv[2]


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


def serve(*args):
    process = subprocess.Popen([rgs_view, scene, "--backend", "cpu", "--port", "0", *args], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    first = process.stdout.readline()
    url = process.stdout.readline().strip()
    assert first.startswith("rgs-view: serving "), first
    assert url.startswith("http://"), url
    return process, url


def checked(process, checks):
    """Runs `checks`; a failing one kills the server first, so that no server outlives the test."""
    try:
        checks()
    except BaseException:
        process.kill()
        process.wait()
        raise


def stop(process, url, signal_number):
    process.send_signal(signal_number)
    code = process.wait(timeout=20)
    stderr = process.stderr.read()
    assert code == 0, (code, stderr)
    assert f"stopped (signal {int(signal_number)})" in stderr, stderr
    try:
        urllib.request.urlopen(url, timeout=5)
        raise AssertionError("the port still answers after the signal")
    except urllib.error.URLError:
        pass


def loopback_checks():
    assert url.startswith("http://127.0.0.1:") and "token" not in url, url
    status, body = get(url)
    assert status == 200 and b"<html" in body, status
    assert get(url + "CMakeLists.txt")[0] == 404
    port = urllib.parse.urlsplit(url).port
    assert status_of(url + "ws", origin=f"http://127.0.0.1:{port}", upgrade=True) == 101
    for origin in ("http://evil.example", "null", "file://", f"http://evil.example:{port}"):
        assert status_of(url + "ws", origin=origin, upgrade=True) == 403, origin
    assert status_of(url, host=f"evil.example:{port}") == 403  # DNS rebinding
    rebound = f"evil.example:{port}"
    assert status_of(url + "ws", host=rebound, origin="http://" + rebound, upgrade=True) == 403


process, url = serve()
checked(process, loopback_checks)
stop(process, url, signal.SIGINT)


def token_checks():
    assert len(token) == 32, url
    assert get(local)[0] == 403
    assert get(local + "?token=" + token)[0] == 200


process, url = serve("--host", "0.0.0.0")
base, _, token = url.partition("?token=")
local = base.replace("0.0.0.0", "127.0.0.1")
checked(process, token_checks)
stop(process, local, signal.SIGTERM)

usage = subprocess.run([rgs_view, scene, "--backend", "tpu"], capture_output=True, text=True)
assert usage.returncode == 2, usage
short = subprocess.run([rgs_view, scene, "--token", "fifteen-chars-x"], capture_output=True, text=True)
assert short.returncode == 2 and "at least 16" in short.stderr, short
for option, value in (("--idle-timeout", "0"), ("--frame-memory", "1MiB"), ("--max-mbps", "nan"),
                      ("--max-mbps", "-1"), ("--max-mbps", "1e9")):
    bad = subprocess.run([rgs_view, scene, option, value], capture_output=True, text=True)
    assert bad.returncode == 2, (option, bad)
missing = subprocess.run([rgs_view, scene + ".missing", "--port", "0"], capture_output=True, text=True)
assert missing.returncode == 1 and "no such file" in missing.stderr, missing
print("rgs-view: URL, page, token, Origin and Host checks, SIGINT and SIGTERM shutdown, usage and input errors as "
      "expected")
