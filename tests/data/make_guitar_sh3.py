#!/usr/bin/env python3
"""Generates tests/data/guitar_sh3.ply: a small SH-degree-3 scene that ships with the project, so the GPU
kernels are checked against the CPU reference at SH degrees 1, 2 and 3 from a clone (tests/gpu).

No real SH-3 capture whose licence allows shipping it was found; samples/guitar.ply may be shipped but has SH
degree 0. So the geometry and DC colours are real and the view-dependent bands are synthetic:

* Gaussians: the N_GAUSSIANS of samples/guitar.ply with the smallest y (ties by index: the headstock and the
  top of the neck), kept in their order in the sample. Their x, y, z, f_dc_*, opacity, scale_* and rot_*
  are copied bit for bit; nx, ny, nz are 0 as in the sample.
* f_rest (INRIA layout, channel-major: f_rest_{15c + k} is coefficient k of channel c, k = 0..14, band
  l = 1 for k < 3, 2 for k < 8, 3 otherwise): a smooth function of position, so neighbouring Gaussians
  agree, with the per-band RMS of a real SH-3 scene and its correlation between colour channels:
      f_rest[c][k](p) = BAND_RMS[l] * (sqrt(CHANNEL_CORRELATION) * W(A[k][3] . q + PHASE[k][3])
                                       + sqrt(1 - CHANNEL_CORRELATION) * W(A[k][c] . q + PHASE[k][c]))
  where q = (p - lo) / (hi - lo) is the position in the crop's bounding box (lo, hi: the per-axis minimum and
  maximum of the chosen means), W(t) = sqrt(105/8) * (x - x^3) with x = 2 frac(t) - 1 is a periodic, C1,
  zero-mean wave of unit RMS, and each wave vector A[k][j] (3 integers in [-2, 2], not all 0: at most two
  periods across the box) and phase PHASE[k][j] (a multiple of 1/64) come from xorshift32 seeded with SEED,
  in the order k, j, then the three components, then the phase. Index j = 3 is the wave the three channels
  share; j = 0..2 each channel's own.
* BAND_RMS and CHANNEL_CORRELATION are rounded from mipnerf360_flowers_c3dgs.ply (a real SH-3 capture of the
  real scenes that are not shipped; `--measure PATH` prints them for any INRIA PLY): per-band RMS 0.0402,
  0.0387, 0.0420 and channel correlations 0.76-0.89.

Only IEEE-754 double arithmetic (+, -, *, /, sqrt, floor) and a final rounding to float32 are used, so every
platform writes the same bytes. data.guitar_sh3_up_to_date (CTest) runs `--check`.

    python3 tests/data/make_guitar_sh3.py           # writes tests/data/guitar_sh3.ply (python3 stdlib only)
    python3 tests/data/make_guitar_sh3.py --check   # exit 1 when the committed file differs
    python3 tests/data/make_guitar_sh3.py --measure $RGS_DATA_DIR/mipnerf360_flowers_c3dgs.ply
"""
import math
import os
import struct
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SAMPLE = os.path.join(ROOT, "samples", "guitar.ply")
OUTPUT = os.path.join(ROOT, "tests", "data", "guitar_sh3.ply")

N_GAUSSIANS = 8000
BAND_RMS = {1: 0.040, 2: 0.039, 3: 0.042}
CHANNEL_CORRELATION = 0.8
SEED = 20240611

SH0_PROPERTIES = ["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1",
                  "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]
REST = 45  # SH degree 3: 15 coefficients x 3 channels


def read_ply(path):
    """(property names, vertex count, flat tuple of float32 values) of a binary little-endian float PLY."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    names, count = [], None
    for line in data[:end].decode("ascii").splitlines():
        parts = line.split()
        if parts[:2] == ["element", "vertex"]:
            count = int(parts[2])
        elif parts[:1] == ["property"]:
            if parts[1] != "float":
                sys.exit(f"{path}: property {parts[2]} is {parts[1]}, not float")
            names.append(parts[2])
        elif parts[:1] == ["format"] and parts[1] != "binary_little_endian":
            sys.exit(f"{path}: not binary_little_endian")
    values = struct.unpack_from(f"<{count * len(names)}f", data, end)
    return names, count, values


def band_of(k):
    return 1 if k < 3 else 2 if k < 8 else 3


def wave(t):
    """W(t): period 1, C1, zero mean, unit RMS (the mean of (x - x^3)^2 over [-1, 1] is 8/105)."""
    x = 2.0 * (t - math.floor(t)) - 1.0
    return math.sqrt(105.0 / 8.0) * (x - x * x * x)


def wave_table():
    """A[k][j] (3 ints in [-2, 2], not all 0) and PHASE[k][j] (multiples of 1/64), k = 0..14, j = 0..3."""
    state = SEED

    def next_u32():
        nonlocal state
        state ^= (state << 13) & 0xFFFFFFFF
        state ^= state >> 17
        state ^= (state << 5) & 0xFFFFFFFF
        return state

    vectors, phases = [], []
    for _ in range(15):
        row_a, row_p = [], []
        for _ in range(4):
            a = (0, 0, 0)
            while a == (0, 0, 0):
                a = tuple(int(next_u32() % 5) - 2 for _ in range(3))
            row_a.append(a)
            row_p.append((next_u32() % 64) / 64.0)
        vectors.append(row_a)
        phases.append(row_p)
    return vectors, phases


def generate():
    names, count, values = read_ply(SAMPLE)
    if names != SH0_PROPERTIES:
        sys.exit(f"{SAMPLE}: expected the INRIA SH0 layout {SH0_PROPERTIES}, got {names}")
    stride = len(names)
    chosen = sorted(range(count), key=lambda i: (values[i * stride + 1], i))[:N_GAUSSIANS]
    chosen.sort()
    lo = [min(values[i * stride + a] for i in chosen) for a in range(3)]
    hi = [max(values[i * stride + a] for i in chosen) for a in range(3)]
    vectors, phases = wave_table()
    shared = math.sqrt(CHANNEL_CORRELATION)
    own = math.sqrt(1.0 - CHANNEL_CORRELATION)

    out_names = SH0_PROPERTIES[:9] + [f"f_rest_{r}" for r in range(REST)] + SH0_PROPERTIES[9:]
    header = ["ply", "format binary_little_endian 1.0",
              "comment samples/guitar.ply cropped, SH bands 1-3 synthetic: tests/data/make_guitar_sh3.py",
              f"element vertex {len(chosen)}"]
    header += [f"property float {n}" for n in out_names]
    header.append("end_header")
    rows = []
    for i in chosen:
        row = values[i * stride:(i + 1) * stride]
        q = [(row[a] - lo[a]) / (hi[a] - lo[a]) for a in range(3)]
        rest = [0.0] * REST
        for k in range(15):
            rms = BAND_RMS[band_of(k)]
            a = vectors[k][3]
            common = wave(a[0] * q[0] + a[1] * q[1] + a[2] * q[2] + phases[k][3])
            for c in range(3):
                a = vectors[k][c]
                mine = wave(a[0] * q[0] + a[1] * q[1] + a[2] * q[2] + phases[k][c])
                rest[15 * c + k] = rms * (shared * common + own * mine)
        rows.append(struct.pack(f"<{len(out_names)}f", *row[:9], *rest, *row[9:]))
    return ("\n".join(header) + "\n").encode("ascii") + b"".join(rows)


def measure(path):
    """Prints the per-band RMS of f_rest and the correlation of each channel pair over all coefficients."""
    names, count, values = read_ply(path)
    stride = len(names)
    index = {n: j for j, n in enumerate(names)}
    if f"f_rest_{REST - 1}" not in index:
        sys.exit(f"{path}: not SH degree 3")

    def column(c, k):
        j = index[f"f_rest_{15 * c + k}"]
        return values[j::stride]

    for band, ks in ((1, range(0, 3)), (2, range(3, 8)), (3, range(8, 15))):
        squares = sum(v * v for c in range(3) for k in ks for v in column(c, k))
        print(f"band {band}: RMS {math.sqrt(squares / (count * 3 * len(ks))):.4f}")
    for c0, c1 in ((0, 1), (0, 2), (1, 2)):
        dot = n0 = n1 = 0.0
        for k in range(15):
            for u, v in zip(column(c0, k), column(c1, k)):
                dot, n0, n1 = dot + u * v, n0 + u * u, n1 + v * v
        print(f"channels {c0},{c1}: correlation {dot / math.sqrt(n0 * n1):.3f}")


def main():
    args = sys.argv[1:]
    if args[:1] == ["--measure"] and len(args) == 2:
        measure(args[1])
        return 0
    data = generate()
    if args == ["--check"]:
        with open(OUTPUT, "rb") as f:
            if f.read() != data:
                print(f"{OUTPUT} is not what {os.path.basename(__file__)} writes: run it and commit the result")
                return 1
        print(f"{OUTPUT}: up to date ({len(data):,} bytes)")
        return 0
    if args:
        sys.exit(__doc__)
    with open(OUTPUT, "wb") as f:
        f.write(data)
    print(f"wrote {OUTPUT} ({len(data):,} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
