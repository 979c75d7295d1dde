#!/usr/bin/env python3
"""Times roofgs.rasterization() on torch CUDA tensors against the C++ path on the same views.

GPU host, after scripts/gpu_python.sh built the module (PYTHONPATH=STAGE/py/package), e.g. on taebak:

    PYTHONPATH=.device_data/py/package python3 scripts/bench_python_rasterization.py /tmp/rgs_taebak/taebak.rgs \\
        --cameras .device_data/data/taebak_cameras.json --resolution 1920x1080 \\
        --rgs-bench .device_data/bin/rgs-bench --out OUT/python_bench

The scene (any format roofgs.load reads; other formats quantized as load() does by default, so that both paths
render the same Gaussians) is read on the CPU and its Gaussians (Scene.arrays(): what the GPU's compact reads
give) are put into torch CUDA tensors. The views of an INRIA cameras.json (as rgs-bench --cameras takes it, every
K-th, resized keeping the field of view) are rendered in one rasterization() call with the preset (default
fastest), after warm-up calls; the call is timed with CUDA events on torch's stream and the median over the
repetitions divided by the view count is the time per view. Also timed: one call a view (the per-call host work
counted once per view), and a call that uploads the tensors again (cache=False). The C++ path is the same scene loaded by roofgs.load (compact .rgs sections on the GPU), rendered by
Scene.render with the same preset; with --rgs-bench, rgs-bench's median total per frame of the same views and
preset is run and reported beside it. Printed: both times and their ratio, and per view the PSNR (clamped RGB) of
the Python image against the C++ image and of both against the faithful preset's. --out writes PPM images of
both paths and a JSON summary.
"""
import argparse
import json
import math
import pathlib
import subprocess
import sys
import tempfile

import numpy as np

try:
    import torch
except ImportError:
    sys.exit("bench_python_rasterization: needs PyTorch with CUDA")
import roofgs


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("scene", help="scene file (.rgs, PLY, SOG, SPZ, ...)")
    p.add_argument("--cameras", required=True, help="INRIA cameras.json (rgs-bench --cameras)")
    p.add_argument("--every", type=int, default=1, help="every K-th camera")
    p.add_argument("--limit", type=int, default=0, help="at most N views (0: all)")
    p.add_argument("--resolution", default="1920x1080", help="WIDTHxHEIGHT, or 'native' for the cameras' sizes")
    p.add_argument("--preset", default="fastest")
    p.add_argument("--warmup", type=int, default=3, help="untimed calls first")
    p.add_argument("--repeat", type=int, default=10, help="timed calls")
    p.add_argument("--rgs-bench", help="rgs-bench binary: also run it on the same views and preset")
    p.add_argument("--out", help="folder for PPM images and summary.json")
    return p.parse_args()


def gsplat_views(cameras, device):
    viewmats = np.zeros((len(cameras), 4, 4), np.float32)
    Ks = np.zeros((len(cameras), 3, 3), np.float32)
    for i, c in enumerate(cameras):
        viewmats[i, :3, :3], viewmats[i, :3, 3], viewmats[i, 3, 3] = c.rotation, c.translation, 1
        Ks[i] = [[c.fx, 0, c.cx], [0, c.fy, c.cy], [0, 0, 1]]
    return torch.from_numpy(viewmats).to(device), torch.from_numpy(Ks).to(device)


def psnr(a, b):
    a = a.clamp(0, 1).double()
    b = b.clamp(0, 1).double()
    mse = float(((a - b) ** 2).mean())
    return math.inf if mse == 0 else 10 * math.log10(1 / mse)


def write_ppm(path, rgb):
    pixels = (rgb.clamp(0, 1) * 255 + 0.5).floor().to(torch.uint8).cpu().numpy()
    with open(path, "wb") as f:
        f.write(b"P6\n%d %d\n255\n" % (pixels.shape[1], pixels.shape[0]))
        f.write(pixels.tobytes())


def timed_ms(call, repeat):
    """Median CUDA-event time of `call` on torch's current stream, and its last result."""
    times, result = [], None
    for _ in range(repeat):
        start, end = torch.cuda.Event(enable_timing=True), torch.cuda.Event(enable_timing=True)
        start.record()
        result = call()
        end.record()
        end.synchronize()
        times.append(start.elapsed_time(end))
    return float(np.median(times)), result


def run_rgs_bench(args, cameras_used):
    with tempfile.TemporaryDirectory() as tmp:
        out = pathlib.Path(tmp) / "bench.json"
        command = [args.rgs_bench, args.scene, "--cameras", args.cameras, "--every", str(args.every), "--mode",
                   args.preset, "--warmup", str(args.warmup), "--repeat", str(args.repeat), "--json", str(out)]
        if args.limit:
            command += ["--limit", str(args.limit)]
        if args.resolution != "native":
            command += ["--resolution", args.resolution]
        subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
        report = json.loads(out.read_text())
    run = next(r for r in report["results"] if r["mode"] == args.preset)
    assert run["views"] == cameras_used, "rgs-bench selected other views"
    return run["median_ms"]["total_ms"]


def main():
    args = parse_args()
    if not torch.cuda.is_available():
        sys.exit("bench_python_rasterization: no CUDA device")
    device = torch.device("cuda", 0)
    cameras = roofgs.load_cameras(args.cameras)[::args.every]
    if args.limit:
        cameras = cameras[:args.limit]
    if args.resolution != "native":
        width, height = (int(v) for v in args.resolution.split("x"))
        cameras = [c.resized(width, height) for c in cameras]
    width, height = cameras[0].width, cameras[0].height
    if any((c.width, c.height) != (width, height) for c in cameras):
        sys.exit("bench_python_rasterization: the views differ in size; give --resolution")

    host = roofgs.load(args.scene, device="cpu")
    means, quats, scales, opacities, sh = (torch.from_numpy(a).to(device) for a in host.arrays())
    degree = host.info["sh_degree"]
    del host
    gpu = roofgs.load(args.scene, device="cuda", presets=[args.preset, "faithful"])
    viewmats, Ks = gsplat_views(cameras, device)
    near_plane = cameras[0].near_plane

    def rasterize(cache=True, views=slice(None)):
        return roofgs.rasterization(means, quats, scales, opacities, sh, viewmats[views], Ks[views], width, height,
                                    sh_degree=degree, near_plane=near_plane, preset=args.preset, cache=cache)

    def one_call_per_view():
        return [rasterize(views=slice(i, i + 1)) for i in range(len(cameras))]

    for _ in range(args.warmup):
        rasterize()
        one_call_per_view()
    call_ms, (colors, _, meta) = timed_ms(rasterize, args.repeat)
    assert not meta["uploaded"], "the warm calls should reuse the upload"
    single_ms, _ = timed_ms(one_call_per_view, args.repeat)
    upload_call_ms, _ = timed_ms(lambda: rasterize(cache=False), max(1, args.repeat // 2))
    per_view_ms = call_ms / len(cameras)

    # The C++ path's images (compact sections, the same preset) and the faithful reference of each view.
    psnr_rows = []
    out = pathlib.Path(args.out) if args.out else None
    if out:
        out.mkdir(parents=True, exist_ok=True)
    for i, camera in enumerate(cameras):
        cpp = torch.from_dlpack(gpu.render(camera, preset=args.preset))[..., :3]
        faithful = torch.from_dlpack(gpu.render(camera, preset="faithful"))[..., :3]
        py = colors[i]
        psnr_rows.append({"view": camera.name, "python_vs_cpp_db": psnr(py, cpp),
                          "python_vs_faithful_db": psnr(py, faithful), "cpp_vs_faithful_db": psnr(cpp, faithful)})
        if out:
            write_ppm(out / ("view%02d_python.ppm" % i), py)
            write_ppm(out / ("view%02d_cpp.ppm" % i), cpp)

    bench_ms = run_rgs_bench(args, len(cameras)) if args.rgs_bench else None
    name = torch.cuda.get_device_name(device)
    print("device: %s; scene %s, %d Gaussians, SH %d; %d views at %dx%d; preset %s; %d warm-up, %d timed calls"
          % (name, args.scene, means.shape[0], degree, len(cameras), width, height, args.preset, args.warmup,
             args.repeat))
    print("python rasterization (tensors cached): %.3f ms a call of %d views, %.3f ms a view (median)"
          % (call_ms, len(cameras), per_view_ms))
    print("python rasterization, one call a view (tensors cached): %.3f ms a view" % (single_ms / len(cameras)))
    print("python rasterization with upload (cache=False): %.3f ms a call, %.3f ms a view"
          % (upload_call_ms, upload_call_ms / len(cameras)))
    if bench_ms is not None:
        print("rgs-bench %s: %.3f ms a frame (median total); python / rgs-bench = %.3f"
              % (args.preset, bench_ms, per_view_ms / bench_ms))
    for row in psnr_rows:
        print("view %-12s PSNR python vs C++ %6.2f dB; vs faithful: python %6.2f dB, C++ %6.2f dB (difference %+.3f)"
              % (row["view"], row["python_vs_cpp_db"], row["python_vs_faithful_db"], row["cpp_vs_faithful_db"],
                 row["python_vs_faithful_db"] - row["cpp_vs_faithful_db"]))
    if out:
        summary = {"device": name, "scene": args.scene, "gaussians": int(means.shape[0]), "sh_degree": degree,
                   "views": len(cameras), "width": width, "height": height, "preset": args.preset,
                   "warmup": args.warmup, "repeat": args.repeat, "python_call_ms": call_ms,
                   "python_view_ms": per_view_ms, "python_one_call_a_view_ms": single_ms / len(cameras),
                   "python_upload_call_ms": upload_call_ms,
                   "rgs_bench_frame_ms": bench_ms, "pairs": meta["pairs"], "psnr": psnr_rows}
        (out / "summary.json").write_text(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
