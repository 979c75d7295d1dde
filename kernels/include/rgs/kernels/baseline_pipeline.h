// The 3DGS baseline rasterizer's stages as host-callable CUDA launches (docs/DESIGN.md#baseline, with the
// conventions above it; the CPU reference runtime/src/cpu_renderer.cpp does the same math on the host).
//
//   preprocess_baseline  → per Gaussian: depth, pixel mean, conic + opacity, RGB, radius, tiles touched
//   inclusive_scan       → pair offsets (uint64: no int32 overflow of the pair count)
//   duplicate_baseline   → (key, value) per touched tile: key = tile << 32 | float_bits(depth), value = index
//   sort_pairs           → CUB radix sort, stable, over 32 + ceil(log2(tiles)) bits
//   tile_ranges          → [begin, end) of each tile's pairs
//   render_baseline      → 16×16 tiles, one pixel per thread, front-to-back blending with expf
//
// Every function enqueues on `stream` and returns the launch's cudaError_t (cudaGetLastError after the
// launch); none synchronizes. Pointers are device memory of the sizes stated. Compiled with --fmad=false so
// that the per-Gaussian math gives the same bits as the CPU reference (kernels/shared/host_device.h).
#pragma once

#include <cuda_runtime_api.h>

#include <cstddef>
#include <cstdint>

#include "rgs/kernels/device_scene.h"

namespace rgs::kernels {

/// Per-Gaussian outputs of the preprocess stage, device arrays of N entries each (3DGS geomState).
struct ProjectedArrays {
  float* depths = nullptr;          ///< [N] view-space z (world units)
  float* means2d = nullptr;         ///< [N, 2] pixel mean (px, py), pixel centres at integers
  float* conic_opacity = nullptr;   ///< [N, 4] conic (a, b, c) and activated opacity o
  float* rgb = nullptr;             ///< [N, 3] colour from SH, max(Σ + 0.5, 0)
  int32_t* radii = nullptr;         ///< [N] ceil(3·sqrt(λmax)) in pixels; 0 = culled
  uint64_t* tiles_touched = nullptr;///< [N] tiles of the 3DGS rectangle; 0 = culled
};

/// Stage 1, one thread per Gaussian (3DGS preprocessCUDA): cull z ≤ near, EWA covariance with the Jacobian
/// clamp and 0.3 dilation, cull det == 0, conic, radius, tile rectangle, SH colour. Writes every entry of
/// `radii` and `tiles_touched` (0 for culled Gaussians); the other arrays only for visible ones.
cudaError_t preprocess_baseline(const Fp32GaussiansView& gaussians, const FrameParams& frame,
                                const ProjectedArrays& out, cudaStream_t stream);

/// Inclusive prefix sum of `count` uint64 values (CUB DeviceScan). Call with temp == nullptr to get
/// *temp_bytes; then with a buffer of that size.
cudaError_t inclusive_scan(void* temp, size_t* temp_bytes, const uint64_t* in, uint64_t* out, uint32_t count,
                           cudaStream_t stream);

/// Stage 2 (3DGS duplicateWithKeys): Gaussian i writes its pairs at [offsets[i−1], offsets[i]) (inclusive
/// scan of tiles_touched), its tiles in row-major order: keys[p] = tile << 32 | float_bits(depth),
/// values[p] = i. keys/values hold offsets[N−1] entries.
cudaError_t duplicate_baseline(const ProjectedArrays& projected, const uint64_t* offsets, uint32_t count,
                               const FrameParams& frame, uint64_t* keys, uint32_t* values, cudaStream_t stream);

/// Stage 3: stable LSD radix sort of `count` (key, value) pairs by key bits [begin_bit, end_bit) (CUB
/// DeviceRadixSort::SortPairs with CUB's own policies, as 3DGS calls it; keys equal in those bits keep their
/// input order). The baseline sorts bits [0, 32 + ceil(log2 tiles)). Inputs are left unchanged; sorted pairs
/// go to keys_out/values_out. Call with temp == nullptr to get *temp_bytes (it depends on count; a size
/// queried for a count serves every smaller count).
cudaError_t sort_pairs(void* temp, size_t* temp_bytes, const uint64_t* keys_in, uint64_t* keys_out,
                       const uint32_t* values_in, uint32_t* values_out, uint64_t count, int begin_bit, int end_bit,
                       cudaStream_t stream);

/// The RoofGS sort of 32-bit keys (end_bit ≤ 32): a stable LSD radix sort like sort_pairs, with 32-bit offsets,
/// passing the pairs back and forth between two buffers of each kind (CUB's DoubleBuffer with overwrite
/// allowed), so that its scratch holds no third copy of them (8 bytes a pair less GPU memory). The pairs start
/// in keys[0] / values[0]; *sorted receives the index, 0 or 1, of the buffers that hold them sorted, and the
/// other two buffers' contents are unspecified. Call with temp == nullptr to get *temp_bytes (a size queried
/// for a count serves every smaller count). It runs CUB's public DeviceRadixSort::SortPairs, or, when
/// sort_pairs_ping_pong_tuned() (built against CCCL 3.0.1, kernels/src/sort.cu), up to 2^28 − 16,384 pairs,
/// CUB's onesweep kernels launched here back to back with the histogram and onesweep block sizes measured
/// faster on an H100, on counters at the start of `temp` laid out for `counters_capacity` pairs (at least
/// `count`; 0: `count`), which must be zero: `counters_zeroed` says that clear_sort_counters() with that
/// capacity did so since the last sort on this scratch (the renderer enqueues it before it knows the count);
/// else this function zeroes them first. Both give the same sorted pairs. cudaErrorInvalidValue when
/// `*temp_bytes` is too small, or when `counters_zeroed` and the capacity is below `count`.
cudaError_t sort_pairs_ping_pong(void* temp, size_t* temp_bytes, uint32_t* const keys[2], uint32_t* const values[2],
                                 uint64_t count, uint64_t counters_capacity, int begin_bit, int end_bit,
                                 bool counters_zeroed, int* sorted, cudaStream_t stream);

/// Whether sort_pairs_ping_pong() launches the tuned onesweep kernels itself (this build's CCCL is 3.0.1, that
/// of CUDA 13.0, and RGS_PUBLIC_CUB_SORT was not defined) rather than calling CUB's public SortPairs.
bool sort_pairs_ping_pong_tuned();

/// Zeroes the counters that the next sort_pairs_ping_pong() of at most `capacity` pairs on `temp` (of
/// `temp_bytes`, the same bits) uses on the tuned path: one memset of a few bytes a pair (4 KB per 8,832 pairs
/// at 4 passes), which needs no pair count, for all of its passes. On the public path CUB zeroes its own
/// counters and this does nothing. cudaErrorInvalidValue when `temp_bytes` is too small for such a sort.
cudaError_t clear_sort_counters(void* temp, size_t temp_bytes, uint64_t capacity, int begin_bit, int end_bit,
                                cudaStream_t stream);

/// Stage 4 (3DGS identifyTileRanges): ranges[2·t], ranges[2·t + 1] = [begin, end) of tile t's pairs in the
/// sorted keys, tile = key >> tile_shift (32 for the 64-bit key, b_d for the 32-bit one). `ranges` holds
/// 2·num_tiles entries and is zeroed here first, so tiles without pairs get [0, 0). `sorted_keys` must be
/// 16-byte aligned (as cudaMalloc returns; read 16 bytes at a time), else cudaErrorMisalignedAddress.
cudaError_t tile_ranges(const uint64_t* sorted_keys, uint64_t count, int tile_shift, uint32_t num_tiles,
                        uint64_t* ranges, cudaStream_t stream);
cudaError_t tile_ranges(const uint32_t* sorted_keys, uint64_t count, int tile_shift, uint32_t num_tiles,
                        uint64_t* ranges, cudaStream_t stream);

/// Output image of the render stage, device memory, row-major, top row first.
struct ImageView {
  float* rgba = nullptr;   ///< [H, W, 4] float32: C + T·bg (linear, not clamped), alpha = 1 − T
  float* depth = nullptr;  ///< [H, W] float32 expected depth Σ wᵢzᵢ / Σ wᵢ (0 where nothing blended); optional
};

/// Stage 5 (3DGS renderCUDA): one 16×16 block per tile, one thread per pixel; batches of 256 Gaussians in
/// shared memory; per pixel skip power > 0, α = min(0.99, o·expf(power)), skip α < 1/255, stop before the
/// Gaussian that would make T < 1e−4; the block stops when all its pixels are done.
cudaError_t render_baseline(const uint64_t* ranges, const uint32_t* sorted_values, const ProjectedArrays& projected,
                            const FrameParams& frame, const ImageView& image, cudaStream_t stream);

/// Widens the compact runtime profile into FP32 arrays of the Fp32GaussiansView layout, exactly as
/// format::dequantize() does on the host (FP16 widened exactly, exp of log scales, SH = s[d][c]·q; means are
/// not copied: FP32 already). Output arrays: rotations [N, 4], scales [N, 3], opacities [N], sh [N, K, 3].
cudaError_t dequantize(const CompactGaussiansView& compact, float* rotations, float* scales, float* opacities,
                       float* sh, cudaStream_t stream);

}  // namespace rgs::kernels
