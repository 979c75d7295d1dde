# rgs-view as a command: prints its URL, serves the page, refuses requests without the token off loopback, and
# shuts down cleanly on SIGINT and SIGTERM (exit 0, port closed); usage errors exit 2.
# Usage: test_rgs_view_cli.py RGS_VIEW SCENE
import signal
import subprocess
import sys
import urllib.error
import urllib.request

rgs_view, scene = sys.argv[1], sys.argv[2]


def get(url):
    try:
        with urllib.request.urlopen(url, timeout=10) as response:
            return response.status, response.read()
    except urllib.error.HTTPError as e:
        return e.code, b""


def serve(*args):
    process = subprocess.Popen([rgs_view, scene, "--backend", "cpu", "--port", "0", *args], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    first = process.stdout.readline()
    url = process.stdout.readline().strip()
    assert first.startswith("rgs-view: serving "), first
    assert url.startswith("http://"), url
    return process, url


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


process, url = serve()
assert url.startswith("http://127.0.0.1:") and "token" not in url, url
status, body = get(url)
assert status == 200 and b"<html" in body, status
assert get(url + "CMakeLists.txt")[0] == 404
stop(process, url, signal.SIGINT)

process, url = serve("--host", "0.0.0.0")
base, _, token = url.partition("?token=")
assert len(token) == 32, url
local = base.replace("0.0.0.0", "127.0.0.1")
assert get(local)[0] == 403
assert get(local + "?token=" + token)[0] == 200
stop(process, local, signal.SIGTERM)

usage = subprocess.run([rgs_view, scene, "--backend", "tpu"], capture_output=True, text=True)
assert usage.returncode == 2, usage
missing = subprocess.run([rgs_view, scene + ".missing", "--port", "0"], capture_output=True, text=True)
assert missing.returncode == 1 and "no such file" in missing.stderr, missing
print("rgs-view: URL, page, token, SIGINT and SIGTERM shutdown, usage and input errors as expected")
