#!/usr/bin/env python3
"""rgs-view-bench against `rgs-view --backend cpu` on the bundled guitar (converted to .rgs here): not a timing
test. Checks that a fly-through of 20 views at 320x240 through three key cameras (a cameras.json written here)
gets 20 frames, that the JSON report is well-formed and complete (frames per second, latency median/p95/max,
bytes per frame, the server's medians), the same for an orbit with two views in flight and WebP frames, through the
shaping relay with and without a bandwidth budget (round trip, smaller frames, PSNR against lossless), and that
the client fails cleanly (exit 1, an error line) without the token a non-loopback server requires.

    test_view_bench.py RGS_VIEW RGS_VIEW_BENCH RGS_CONVERT GUITAR_PLY WORK_DIR

Exit status: 0 passed, 1 failed. Every process it starts is stopped (timeouts; killed in `finally`).
"""
import json
import math
import os
import re
import signal
import subprocess
import sys
import threading


def fail(why):
    print(f"FAILED: {why}", flush=True)
    sys.exit(1)


def start_server(exe, args, work, name):
    log = open(os.path.join(work, f"{name}.log"), "w")
    proc = subprocess.Popen([exe] + args, stdout=subprocess.PIPE, stderr=log, text=True, cwd=work)
    url = []
    got = threading.Event()

    def pump():
        for line in proc.stdout:
            log.write(line)
            log.flush()
            m = re.search(r"(https?://\S+)", line)
            if m and not url:
                url.append(m.group(1))
                got.set()
        got.set()
    threading.Thread(target=pump, daemon=True).start()
    if not got.wait(120) or not url:
        proc.kill()
        proc.wait(10)
        fail(f"{name} printed no URL (see {name}.log)")
    return proc, url[0]


def stop(proc):
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            return proc.wait(20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(10)
            return None
    return proc.returncode


def finite(v):
    return isinstance(v, (int, float)) and math.isfinite(v)


def bench(exe, url, args, out, work, expect_views):
    r = subprocess.run([exe, url] + args + ["--json", out], capture_output=True, text=True, timeout=240, cwd=work)
    print(r.stdout, end="")
    if r.returncode != 0:
        fail(f"rgs-view-bench {' '.join(args)} exited {r.returncode}: {r.stderr[-1500:]}")
    with open(out) as f:
        rep = json.load(f)
    for key in ("tool", "url", "backend", "views", "width", "height", "encoding", "in_flight", "frames",
                "measured_frames", "dropped_views", "failed_views", "seconds", "frames_per_second", "latency_ms",
                "bytes_per_frame", "server_median"):
        if key not in rep:
            fail(f"{out}: no '{key}'")
    # one view in flight: every view gets its frame; more: the server may replace a pending view by a newer one
    # (latest wins), and the client counts it as dropped
    if rep["views"] != expect_views or rep["frames"] + rep["dropped_views"] != expect_views or rep["frames"] < 1:
        fail(f"{out}: {rep['frames']} frames + {rep['dropped_views']} dropped for {rep['views']} views, "
             f"expected {expect_views}")
    if rep["failed_views"] != 0 or (rep["in_flight"] == 1 and rep["dropped_views"] != 0):
        fail(f"{out}: {rep['failed_views']} failed, {rep['dropped_views']} dropped views")
    if rep["measured_frames"] < 1 or not finite(rep["frames_per_second"]) or rep["frames_per_second"] <= 0:
        fail(f"{out}: frames_per_second {rep['frames_per_second']} over {rep['measured_frames']} frames")
    lat = rep["latency_ms"]
    if not all(finite(lat.get(k)) for k in ("median", "p95", "max")) or not 0 < lat["median"] <= lat["p95"] <= lat["max"]:
        fail(f"{out}: latency {lat}")
    if not finite(rep["bytes_per_frame"].get("median")) or rep["bytes_per_frame"]["median"] <= 100:
        fail(f"{out}: bytes_per_frame {rep['bytes_per_frame']}")
    sm = rep["server_median"]
    if not finite(sm.get("render_call_ms")) or not finite(sm.get("encode_ms")) or not sm.get("splats"):
        fail(f"{out}: server medians {sm}")
    if "token=" in json.dumps(rep) and "token=..." not in json.dumps(rep):
        fail(f"{out}: the report shows the token")
    if rep["backend"] != "cpu":
        fail(f"{out}: backend {rep['backend']}")
    return rep


def main():
    if len(sys.argv) != 6:
        fail(__doc__)
    rgs_view, rgs_bench, rgs_convert, guitar, work = sys.argv[1:]
    work = os.path.abspath(work)
    os.makedirs(work, exist_ok=True)
    scene = os.path.join(work, "guitar.rgs")
    r = subprocess.run([rgs_convert, guitar, scene], capture_output=True, text=True, timeout=300)
    if r.returncode != 0:
        fail(f"rgs-convert: {r.stderr[-800:]}")
    procs = []
    try:
        proc, url = start_server(rgs_view, [scene, "--backend", "cpu", "--port", "0"], work, "rgs-view")
        procs.append(proc)
        # three key cameras around the guitar (up is -y), 640x480: the fly-through is asked at 320x240
        keys = []
        for i, (pos, tgt) in enumerate((([0.0, -3.0, -4.5], [0.1, -2.1, 0.2]), ([3.0, -2.5, -3.0], [0.1, -2.1, 0.2]),
                                         ([4.0, -2.0, 1.0], [0.1, -2.1, 0.2]))):
            f = [t - p for p, t in zip(pos, tgt)]
            n = math.sqrt(sum(x * x for x in f))
            f = [x / n for x in f]
            right = [f[1] * 0 - f[2] * -1, f[2] * 0 - f[0] * 0, f[0] * -1 - f[1] * 0]  # f x (0,-1,0)
            n = math.sqrt(sum(x * x for x in right))
            right = [x / n for x in right]
            down = [f[1] * right[2] - f[2] * right[1], f[2] * right[0] - f[0] * right[2], f[0] * right[1] - f[1] * right[0]]
            keys.append({"id": i, "img_name": f"key_{i}", "width": 640, "height": 480, "position": pos,
                         "rotation": [[right[j], down[j], f[j]] for j in range(3)], "fx": 520.0, "fy": 520.0})
        keys_path = os.path.join(work, "keys.json")
        with open(keys_path, "w") as fk:
            json.dump(keys, fk)
        rep = bench(rgs_bench, url, ["--cameras", keys_path, "--fly", "20", "--width", "320", "--height", "240",
                                     "--warmup", "2"], os.path.join(work, "fly.json"), work, 20)
        if (rep["width"], rep["height"], rep["measured_frames"]) != (320, 240, 18):
            fail(f"fly.json: {rep['width']}x{rep['height']}, {rep['measured_frames']} measured")
        print(f"fly: 20 frames, {rep['frames_per_second']:.1f} frames/s, latency median "
              f"{rep['latency_ms']['median']:.1f} ms (not a timing test)")
        rep = bench(rgs_bench, url, ["--orbit", "8", "--width", "160", "--height", "120", "--in-flight", "2",
                                     "--encoding", "webp"], os.path.join(work, "orbit.json"), work, 8)
        if rep["in_flight"] != 2 or rep["encoding"] != "webp":
            fail(f"orbit.json: in_flight {rep['in_flight']}, encoding {rep['encoding']}")
        print(f"orbit: {rep['frames']} frames, {rep['dropped_views']} views replaced by newer ones, with two views "
              "in flight, WebP")
        # through the shaping relay (1 Mbit/s, 40 ms round trip): every frame takes the round trip at least; with
        # the budget the moving frames are smaller and their PSNR against the lossless frames is finite
        shaped = ["--orbit", "10", "--width", "320", "--height", "180", "--warmup", "2", "--shape-mbps", "1",
                  "--shape-rtt-ms", "40", "--psnr-every", "2"]
        plain = bench(rgs_bench, url, shaped, os.path.join(work, "shaped.json"), work, 10)
        budget = bench(rgs_bench, url, shaped + ["--max-mbps", "1"], os.path.join(work, "budget.json"), work, 10)
        for rep in (plain, budget):
            if rep["latency_ms"]["median"] < 40 or rep["shaping"] != {"mbps": 1, "rtt_ms": 40}:
                fail(f"shaped: latency {rep['latency_ms']}, shaping {rep['shaping']}")
            if rep["psnr_db"]["views"] != 4 or not finite(rep["psnr_db"]["mean"]) or not finite(rep["mbps"]):
                fail(f"shaped: PSNR {rep['psnr_db']}, {rep['mbps']} Mbit/s")
        if plain["quality_median"] != 85 or plain["max_mbps"] is not None or budget["max_mbps"] != 1 or \
                not (budget["quality_median"] < 85 or budget["scale_median"] < 1) or \
                budget["bytes_per_frame"]["median"] >= plain["bytes_per_frame"]["median"]:
            fail(f"budget: quality {budget['quality_median']} scale {budget['scale_median']} bytes "
                 f"{budget['bytes_per_frame']['median']} against {plain['bytes_per_frame']['median']} without")
        print(f"shaped 1 Mbit/s, 40 ms: {plain['frames_per_second']:.1f} frames/s, "
              f"{plain['bytes_per_frame']['median']:.0f} B/frame, PSNR {plain['psnr_db']['mean']:.1f} dB; with a "
              f"1 Mbit/s budget {budget['frames_per_second']:.1f} frames/s, quality {budget['quality_median']:.0f} "
              f"scale {budget['scale_median']}, {budget['bytes_per_frame']['median']:.0f} B/frame, PSNR "
              f"{budget['psnr_db']['mean']:.1f} dB (not a timing test)")
        code = stop(proc)
        if code != 0:
            fail(f"rgs-view exited {code} on SIGTERM")
        # a non-loopback server requires its token: without it the client fails cleanly
        proc, url = start_server(rgs_view, [scene, "--backend", "cpu", "--port", "0", "--host", "0.0.0.0"], work,
                                 "rgs-view-token")
        procs.append(proc)
        port = re.search(r":(\d+)/", url).group(1)
        r = subprocess.run([rgs_bench, f"http://127.0.0.1:{port}/", "--orbit", "2", "--width", "64", "--height", "48",
                            "--timeout", "30"], capture_output=True, text=True, timeout=120, cwd=work)
        if r.returncode != 1 or "rgs-view-bench: error:" not in r.stderr:
            fail(f"without the token: exit {r.returncode}, stderr {r.stderr[-500:]!r}")
        print(f"without the token: exit 1, {r.stderr.strip().splitlines()[-1][:120]}")
        r = subprocess.run([rgs_bench, url.replace("0.0.0.0", "127.0.0.1"), "--orbit", "2", "--width", "64",
                            "--height", "48", "--json", os.path.join(work, "token.json")],
                           capture_output=True, text=True, timeout=120, cwd=work)
        if r.returncode != 0:
            fail(f"with the token: exit {r.returncode}: {r.stderr[-500:]}")
        if "token=" in r.stdout + r.stderr and "token=..." not in r.stdout + r.stderr:
            fail("the client printed the token")
        print("with the token: 2 frames")
    finally:
        for p in procs:
            if p.poll() is None:
                stop(p)
    print("passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
