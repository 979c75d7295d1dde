#!/usr/bin/env python3
"""rgs-convert holds standard input whole, so it reads no more of it than --memory-limit allows a file of its
format read whole and held: (64 MiB less than the limit) / 2.5 bytes of a PLY (api::max_whole_input_bytes). Streams that
never end are fed to `rgs-convert - out.rgs --memory-limit 96MiB`:

  - a binary PLY whose header declares 100,000,000 vertices (6.8 GB), under --max-gaussians;
  - a binary PLY of 10 vertices followed by an element of 4,000,000,000 rows with a list property (no bound a
    header can prove);
  - an ascii PLY declaring 10,000,000 vertices, rows of text without end;
each must exit 1 within a bounded time with "standard input: more than 13,421,773 bytes, ... the memory limit
of 100,663,296 bytes (--memory-limit)", no output, and a peak resident memory below the limit. A PLY of 10
vertices followed by endless bytes is converted from its 10 vertices (exit 0): what follows a PLY's last element
is left unread.

Usage: test_stdin_memory_limit.py RGS_CONVERT WORK_DIR
"""
import os
import signal
import struct
import subprocess
import sys
import threading
import time

LIMIT = 96 << 20
MOST = ((LIMIT - (64 << 20)) * 2 + 1) // 5  # api::max_whole_input_bytes("ply"): n with floor(2.5 n) <= limit - 64 MiB
TIMEOUT_S = 60
PROPS = ["x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "scale_2",
         "rot_0", "rot_1", "rot_2", "rot_3"]


def header(storage, vertices, extra=""):
    lines = ["ply", "format %s 1.0" % storage, "element vertex %d" % vertices]
    lines += ["property float %s" % p for p in PROPS]
    return ("\n".join(lines) + "\n" + extra + "end_header\n").encode("ascii")


def binary_rows(n):
    row = struct.pack("<14f", *[0.1 * (i % 7) for i in range(10)], 1.0, 0.0, 0.0, 0.0)
    return row * n


def resident_bytes(pid):
    try:
        with open("/proc/%d/status" % pid) as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0


def feed(pipe, head, body, stop):
    """Writes `head`, then `body` again and again, until the reader closes the pipe or `stop` is set."""
    try:
        pipe.write(head)
        while not stop.is_set():
            pipe.write(body)
    except (BrokenPipeError, OSError):
        pass


def run(tool, work, name, head, body):
    """rgs-convert reading `head` and endless `body` on standard input: (exit code or -signal, stderr, peak RSS in
    bytes, seconds, the output exists)."""
    out = os.path.join(work, name + ".rgs")
    err_path = os.path.join(work, name + ".stderr")
    if os.path.exists(out):
        os.remove(out)
    with open(err_path, "wb") as err:
        process = subprocess.Popen([tool, "-", out, "-q", "--memory-limit", str(LIMIT)], stdin=subprocess.PIPE,
                                   stdout=subprocess.DEVNULL, stderr=err)
    stop = threading.Event()
    feeder = threading.Thread(target=feed, args=(process.stdin, head, body, stop), daemon=True)
    started = time.monotonic()
    feeder.start()
    status, usage, peak = None, None, 0
    while status is None:
        pid, status_now, usage_now = os.wait4(process.pid, os.WNOHANG)
        if pid != 0:
            status, usage = status_now, usage_now
            break
        peak = max(peak, resident_bytes(process.pid))
        if time.monotonic() - started > TIMEOUT_S or peak > 4 * LIMIT:
            os.kill(process.pid, signal.SIGKILL)  # never stopped, or held far more than its limit
        time.sleep(0.02)
    seconds = time.monotonic() - started
    process.returncode = 0  # reaped by wait4 above
    stop.set()
    try:
        process.stdin.close()
    except OSError:
        pass
    feeder.join(5)
    code = os.waitstatus_to_exitcode(status)
    peak = max(peak, usage.ru_maxrss * 1024)
    with open(err_path, "rb") as err:
        message = err.read().decode(errors="replace")
    return code, message, peak, seconds, os.path.exists(out)


def main():
    if len(sys.argv) != 3:
        print(__doc__)
        return 2
    tool, work = sys.argv[1], sys.argv[2]
    os.makedirs(work, exist_ok=True)
    endless = [
        ("binary_many_vertices", header("binary_little_endian", 100000000), binary_rows(4096)),
        ("binary_endless_element",
         header("binary_little_endian", 10, "element junk 4000000000\nproperty list uchar int v\n") + binary_rows(10),
         bytes([255]) + b"\0" * (255 * 4)),
        ("ascii_many_vertices", header("ascii", 10000000), b"0 0 0 0 0 0 0 0 0 0 1 0 0 0\n" * 4096),
    ]
    expected = "standard input: more than %s bytes, the most a PLY read whole may have within the memory limit " \
               "of %s bytes (--memory-limit)" % ("{:,}".format(MOST), "{:,}".format(LIMIT))
    failures = []
    for name, head, body in endless:
        code, message, peak, seconds, written = run(tool, work, name, head, body)
        print("%s: exit %d in %.1f s, peak RSS %.1f MiB: %s" % (name, code, seconds, peak / 2**20, message.strip()))
        if code != 1 or expected not in message:
            failures.append("%s: expected exit 1 with '%s'" % (name, expected))
        if peak >= LIMIT:
            failures.append("%s: peak RSS %d bytes, not below the limit of %d" % (name, peak, LIMIT))
        if written:
            failures.append("%s: an output was written" % name)
    # 10 valid vertices, then endless bytes: converted from the vertices its header declares.
    code, message, peak, seconds, written = run(tool, work, "ten_vertices_then_endless",
                                                header("binary_little_endian", 10) + binary_rows(10), b"\0" * 65536)
    print("ten_vertices_then_endless: exit %d in %.1f s, peak RSS %.1f MiB %s" % (code, seconds, peak / 2**20,
                                                                               message.strip()))
    if code != 0 or not written:
        failures.append("ten_vertices_then_endless: expected exit 0 and an output")
    for f in failures:
        print("FAIL:", f)
    if failures:
        return 1
    print("PASS")
    return 0


if __name__ == "__main__":
    sys.exit(main())
