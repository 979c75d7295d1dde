// CPU reference renderer (cpu_renderer.h). Written to read like the 3DGS conventions of docs/DESIGN.md, stage by
// stage; not tuned. All per-Gaussian and per-pixel math lives in kernels/shared/ so the CUDA kernels use the
// same definitions.
#include <algorithm>
#include <cmath>
#include <limits>
#include <new>
#include <string>

#include "internal_parallel.h"
#include "rgs/kernels/shared/blend_math.h"
#include "rgs/kernels/shared/fast_exp.h"
#include "rgs/kernels/shared/frame_switches.h"
#include "rgs/kernels/shared/half_blend.h"
#include "rgs/kernels/shared/projection.h"
#include "rgs/kernels/shared/sort_key.h"
#include "rgs/kernels/shared/spherical_harmonics.h"
#include "rgs/kernels/shared/tile_chunks.h"
#include "rgs/kernels/shared/tile_culling.h"
#include "rgs/runtime/cpu_renderer.h"
#include "rgs/runtime/depth_key.h"

namespace rgs::runtime {
namespace {

namespace k = rgs::kernels;

/// Gaussians per preprocess/duplication work item.
constexpr uint64_t kGaussianChunk = 4096;

/// Tiles a visible Gaussian may receive: the grid, limited to the baseline rectangle when requested.
k::TileRect accutile_limit(const FrameSetup& frame, const RoofgsOptions& roofgs, const k::TileRect& baseline_rect) {
  const k::TileRect grid{0, 0, frame.tiles_x, frame.tiles_y};
  return roofgs.accutile_within_baseline_rect ? k::intersect(grid, baseline_rect) : grid;
}

/// Calls emit(tile_x, tile_y) for every tile of a visible Gaussian, in the order the pairs are emitted.
template <typename Emit>
void for_each_tile_of(const ProjectedGaussian& g, const FrameSetup& frame, const RoofgsOptions& roofgs,
                      Emit&& emit) {
  if (roofgs.snugbox_accutile) {
    const k::SnugBox box = k::make_snugbox(g.mean[0], g.mean[1], g.cov, g.snug_t);
    const k::TileRect baseline_rect = k::tile_rect(g.mean[0], g.mean[1], g.radius, frame.tiles_x, frame.tiles_y);
    k::for_each_accutile_tile(box, accutile_limit(frame, roofgs, baseline_rect), emit);
    return;
  }
  for (int ty = g.rect.y_min; ty < g.rect.y_max; ++ty) {
    for (int tx = g.rect.x_min; tx < g.rect.x_max; ++tx) emit(tx, ty);
  }
}

using detail::TileGaussian;
using detail::TileScratch;

/// Pairs whose exponent (power, or P = power + ln o) is below this can never reach alpha 1/255:
/// exp(−6) = 0.00248 < 1/255 = 0.00392 for any opacity ≤ 1, and the fast exp's ≤ 3.2 % error keeps it below
/// too. Skipping them before the exponential changes no result (they would fail the α < 1/255 test); it only
/// spares the CPU most of its expf calls.
constexpr float kNeverVisiblePower = -6.f;

/// The power below which a Gaussian of opacity o cannot reach α = 1/255: ln(1 / (255·o)), less 0.05 for the
/// error of expf and of the fast exp (e^−0.05 · 1.032 < 1), and never below kNeverVisiblePower. Tighter than
/// kNeverVisiblePower for faint Gaussians, so they skip more pixels before the exponential, with the same
/// results.
float visible_power_floor(float opacity) {
  if (!(opacity > 0.f)) return 1.f;  // never visible: every power (≤ 0) is below it
  return std::max(kNeverVisiblePower, std::log(k::kAlphaMin / opacity) - 0.05f);
}

/// Gathers the `count` Gaussians `ids` of tile (tx, ty) in list order.
void gather_tile(const std::vector<ProjectedGaussian>& gaussians, const uint32_t* ids, uint64_t count, int tx,
                 int ty, bool fold, std::vector<TileGaussian>* out) {
  const float origin_x = static_cast<float>(tx * k::kTileSize);
  const float origin_y = static_cast<float>(ty * k::kTileSize);
  out->resize(count);
  for (uint64_t j = 0; j < count; ++j) {
    const ProjectedGaussian& g = gaussians[ids[j]];
    TileGaussian& t = (*out)[j];
    t.mean[0] = g.mean[0];
    t.mean[1] = g.mean[1];
    t.conic = g.conic;
    t.opacity = g.opacity;
    t.log_opacity = g.log_opacity;
    for (int c = 0; c < 3; ++c) t.rgb[c] = g.rgb[c];
    t.depth = g.depth;
    t.skip_power = visible_power_floor(g.opacity);
    // Tile-local mean (u, v) = mean − tile origin; pixels are then at tile-local (0..15, 0..15).
    t.folded = fold ? k::fold_coefficients(g.conic, g.mean[0] - origin_x, g.mean[1] - origin_y, g.log_opacity)
                    : k::FoldedCoefficients{0, 0, 0, 0, 0, 0};
  }
}

/// Running state of one pixel during blending.
struct PixelState {
  float T = 1.f;                 // transmittance
  float C[3] = {0.f, 0.f, 0.f};  // accumulated colour
  float depth_sum = 0.f;         // Σ w·z
  float weight_sum = 0.f;        // Σ w
  bool done = false;
};

/// One front-to-back step with an alpha that passed the 1/255 test: stop before the Gaussian if it would make
/// T < 1e-4 (it is then not added), else C += c·α·T, T *= (1 − α).
inline void blend_step(PixelState& s, float alpha, const TileGaussian& g) {
  const float test_T = s.T * (1.f - alpha);
  if (test_T < k::kTransmittanceMin) {
    s.done = true;
    return;
  }
  for (int c = 0; c < 3; ++c) s.C[c] += g.rgb[c] * alpha * s.T;
  const float w = alpha * s.T;
  s.depth_sum += g.depth * w;
  s.weight_sum += w;
  s.T = test_T;
}

/// blend_step in the RoofGS rasterizer's form (render.cu blend_predicated): w = α·T once, the transmittance
/// after the Gaussian as T − w, and C += c·w as one fused multiply-add per channel (the folded loop's
/// accumulation, 2 fewer operations per pixel than blend_step).
inline void blend_step_fma(PixelState& s, float alpha, const TileGaussian& g) {
  const float w = alpha * s.T;
  const float test_T = s.T - w;
  if (test_T < k::kTransmittanceMin) {
    s.done = true;
    return;
  }
  for (int c = 0; c < 3; ++c) s.C[c] = std::fmaf(g.rgb[c], w, s.C[c]);
  s.depth_sum = std::fmaf(g.depth, w, s.depth_sum);
  s.weight_sum += w;
  s.T = test_T;
}

/// Alpha of Gaussian g from its power at a pixel on the unfolded path, or a negative value when the pair is
/// skipped (power > 0 or α < 1/255). std::min(kAlphaMax, x) is fminf(kAlphaMax, x) for every x, NaN included,
/// without a call into libm.
inline float unfolded_alpha(const TileGaussian& g, float power, const RoofgsOptions& roofgs) {
  if (power > 0.f || power < g.skip_power) return -1.f;  // α < 1/255 for sure below skip_power
  const float alpha = roofgs.fast_exp ? std::min(k::kAlphaMax, k::fast_exp(power + g.log_opacity, roofgs.fast_exp_sigma))
                                      : std::min(k::kAlphaMax, g.opacity * std::exp(power));
  return alpha < k::kAlphaMin ? -1.f : alpha;
}

/// Alpha from a folded power P = power + ln(o), or a negative value when skipped (P > 0 or α < 1/255).
inline float folded_alpha(float P, const RoofgsOptions& roofgs) {
  if (P > 0.f) return -1.f;
  if (P < kNeverVisiblePower) return -1.f;  // α < 1/255 for sure
  const float alpha = roofgs.fast_exp ? std::min(k::kAlphaMax, k::fast_exp(P, roofgs.fast_exp_sigma))
                                      : std::min(k::kAlphaMax, std::exp(P));
  return alpha < k::kAlphaMin ? -1.f : alpha;
}

/// Writes a finished pixel: rgb = C + T·bg, alpha = 1 − T, depth = Σ w·z / Σ w (0 without contributions).
inline void store_pixel(const PixelState& s, uint32_t x, uint32_t y, const RenderOptions& options,
                        RenderResult* out) {
  const size_t p = size_t(y) * out->width + x;
  for (int c = 0; c < 3; ++c) out->rgb[p * 3 + c] = s.C[c] + s.T * options.background[c];
  out->alpha[p] = 1.f - s.T;
  out->depth[p] = s.weight_sum > 0.f ? s.depth_sum / s.weight_sum : 0.f;
}

/// Pixels of a tile [x_min, x_max] × [y_min, y_max], tile-local and inclusive; empty when x_min > x_max.
struct PixelBox {
  int x_min, y_min, x_max, y_max;
};

/// The tile's pixels (w × h, origin (x0, y0)) where g's power can reach g.skip_power: the box of the ellipse
/// dᵀ Q d ≤ −2·skip_power (Q the conic), 1 % and a pixel wider for the rounding of the power in float; the whole
/// tile when the conic is not positive definite. Pixels outside it would be skipped before the exponential anyway.
PixelBox reach_box(const TileGaussian& g, uint32_t x0, uint32_t y0, uint32_t w, uint32_t h) {
  const PixelBox tile{0, 0, int(w) - 1, int(h) - 1};
  const double a = g.conic.a, b = g.conic.b, c = g.conic.c, det = a * c - b * b;
  if (!(a > 0 && c > 0 && det > 0)) return tile;
  if (g.skip_power > 0.f) return {0, 0, -1, -1};
  const double q = -2.0 * double(g.skip_power) * 1.01;
  const double rx = std::sqrt(q * c / det) + 1, ry = std::sqrt(q * a / det) + 1;
  const double cx = double(g.mean[0]) - x0, cy = double(g.mean[1]) - y0;
  if (!(std::isfinite(rx) && std::isfinite(ry) && std::isfinite(cx) && std::isfinite(cy))) return tile;
  const double lo_x = std::max(0.0, std::ceil(cx - rx)), hi_x = std::min(double(w) - 1, std::floor(cx + rx));
  const double lo_y = std::max(0.0, std::ceil(cy - ry)), hi_y = std::min(double(h) - 1, std::floor(cy + ry));
  if (lo_x > hi_x || lo_y > hi_y) return {0, 0, -1, -1};
  return {int(lo_x), int(lo_y), int(hi_x), int(hi_y)};
}

/// Baseline loop over one tile (3DGS renderCUDA, one pixel per thread). Each pixel blends the list in order and
/// stops where 3DGS stops, as a per-pixel loop does; the loop runs Gaussian by Gaussian so that each Gaussian
/// visits only the pixels it can reach (reach_box), a row at a time: the powers of a row are computed together
/// (vectorized: the same operations in the same order, so the same bits), and only the pixels that pass go on to
/// the exponential.
void blend_tile_baseline(const std::vector<TileGaussian>& list, int tx, int ty, const RenderOptions& options,
                         RenderResult* out) {
  constexpr uint32_t kSide = k::kTileSize;
  const uint32_t x0 = uint32_t(tx) * kSide, y0 = uint32_t(ty) * kSide;
  const uint32_t x1 = std::min<uint32_t>(x0 + kSide, out->width);
  const uint32_t y1 = std::min<uint32_t>(y0 + kSide, out->height);
  const uint32_t w = x1 - x0, h = y1 - y0;
  PixelState state[kSide * kSide];
  float pixf_x[kSide], power[kSide];
  for (uint32_t x = 0; x < w; ++x) pixf_x[x] = static_cast<float>(x0 + x);
  uint32_t live = w * h;
  for (size_t j = 0; j < list.size() && live > 0; ++j) {
    const TileGaussian& g = list[j];
    const PixelBox box = reach_box(g, x0, y0, w, h);
    for (int y = box.y_min; y <= box.y_max; ++y) {
      const float pixf_y = static_cast<float>(y0 + uint32_t(y));
      for (int x = box.x_min; x <= box.x_max; ++x) {
        power[x] = k::baseline_power(g.conic, g.mean[0] - pixf_x[x], g.mean[1] - pixf_y);
      }
      PixelState* row = state + size_t(y) * w;
      for (int x = box.x_min; x <= box.x_max; ++x) {
        if (row[x].done) continue;
        const float alpha = unfolded_alpha(g, power[x], options.roofgs);
        if (alpha < 0.f) continue;
        blend_step(row[x], alpha, g);
        live -= row[x].done;
      }
    }
  }
  for (uint32_t i = 0; i < w * h; ++i) store_pixel(state[i], x0 + i % w, y0 + i / w, options, out);
}

/// RoofGS folded loop over one tile: tile-local coordinates, each "thread" shading (x, y) and (x, y+1) with the
/// dual-pixel update P(x, y+1) = P(x, y) + C2·x + C3·(2y+1) + C5.
void blend_tile_folded(const std::vector<TileGaussian>& list, int tx, int ty, const RenderOptions& options,
                       RenderResult* out) {
  const uint32_t x0 = uint32_t(tx) * k::kTileSize, y0 = uint32_t(ty) * k::kTileSize;
  for (int ly = 0; ly < k::kTileSize; ly += 2) {
    for (int lx = 0; lx < k::kTileSize; ++lx) {
      const uint32_t x = x0 + uint32_t(lx), y = y0 + uint32_t(ly);
      PixelState first, second;
      first.done = x >= out->width || y >= out->height;
      second.done = x >= out->width || y + 1 >= out->height;
      const k::PixelTerms terms = k::pixel_terms(static_cast<float>(lx), static_cast<float>(ly));
      for (size_t j = 0; j < list.size() && !(first.done && second.done); ++j) {
        const TileGaussian& g = list[j];
        const float p_first = k::folded_power(g.folded, terms);
        const float p_second = k::dual_pixel_power(p_first, g.folded, terms);
        if (!first.done) {
          const float alpha = folded_alpha(p_first, options.roofgs);
          if (alpha >= 0.f) blend_step_fma(first, alpha, g);
        }
        if (!second.done) {
          const float alpha = folded_alpha(p_second, options.roofgs);
          if (alpha >= 0.f) blend_step_fma(second, alpha, g);
        }
      }
      if (x < out->width && y < out->height) store_pixel(first, x, y, options, out);
      if (x < out->width && y + 1 < out->height) store_pixel(second, x, y + 1, options, out);
    }
  }
}

/// Which pairs of a tile's list the GPU's lane group of each 4×4 block walks: bit b of (*masks)[j] (b = block_x +
/// 4·block_y) where pair j is in block b's list. Under block culling the pair's block_mask, computed as the
/// GPU's rasterizer computes it when it loads the pair; else every block.
void walk_masks(const std::vector<TileGaussian>& list, int tx, int ty, bool block_culling,
                std::vector<uint32_t>* masks) {
  const float origin_x = static_cast<float>(tx * k::kTileSize), origin_y = static_cast<float>(ty * k::kTileSize);
  masks->assign(list.size(), 0xffffu);
  if (!block_culling) return;
  for (size_t j = 0; j < list.size(); ++j) {
    const TileGaussian& g = list[j];
    (*masks)[j] = k::block_mask(g.conic, g.mean[0] - origin_x, g.mean[1] - origin_y, g.log_opacity);
  }
}

/// blend_tile_folded with half-precision blending (RoofgsOptions::half_blend; render.cu blend_pairs_half):
/// each "thread" keeps its two pixels' T and colour window as binary16 pairs and blends both with blend_half2,
/// α from half2_alpha on the folded powers in base 2 (coefficients from exp2_coefficients). The pairs are
/// walked as the GPU walks them, batch by batch (walk_batch_pairs), each batch's pairs that the thread's 4×4
/// block keeps (walk_masks), in colour windows of kColourWindowEntries of them (half_blend.h). Pairs where
/// neither pixel passes change no bit but count in their window. A list of more than `chunk_pairs` pairs
/// (frame_chunk_pairs; 0: off) is blended in chunks, each from T = 1, and the chunks' FP32 values merged in
/// order (kernels/shared/tile_chunks.h), as the GPU's chunk blocks do.
void blend_tile_folded_half(TileScratch& tile, int tx, int ty, const RenderOptions& options, uint32_t chunk_pairs,
                            bool block_culling, RenderResult* out) {
  const std::vector<TileGaussian>& list = tile.list;
  const uint32_t x0 = uint32_t(tx) * k::kTileSize, y0 = uint32_t(ty) * k::kTileSize;
  std::vector<k::FoldedCoefficients>& of_v = tile.exp2;  // the coefficients of the power in base 2, v
  of_v.resize(list.size());
  for (size_t j = 0; j < list.size(); ++j) of_v[j] = k::exp2_coefficients(list[j].folded);
  walk_masks(list, tx, ty, block_culling, &tile.masks);
  const std::vector<uint32_t>& masks = tile.masks;
  const size_t batch_pairs = k::walk_batch_pairs(block_culling);
  const uint32_t chunks = k::tile_chunk_count(list.size(), chunk_pairs);
  for (int ly = 0; ly < k::kTileSize; ly += 2) {
    for (int lx = 0; lx < k::kTileSize; ++lx) {
      const uint32_t x = x0 + uint32_t(lx), y = y0 + uint32_t(ly);
      const uint32_t block_bit = 1u << (lx / k::kCullBlockSize + k::kCullBlocksPerSide * (ly / k::kCullBlockSize));
      const k::PixelTerms terms = k::pixel_terms(static_cast<float>(lx), static_cast<float>(ly));
      k::ChunkPixel merged[2];
      for (uint32_t chunk = 0; chunk < chunks; ++chunk) {
        const size_t first = chunks == 1 ? 0 : size_t(chunk) * chunk_pairs;
        const size_t last = chunks == 1 ? list.size() : std::min(list.size(), first + chunk_pairs);
        k::HalfPixelPair pair;
        if (!(x < out->width && y < out->height)) pair.T |= 0x8000u;  // outside the image: done
        if (!(x < out->width && y + 1 < out->height)) pair.T |= 0x80000000u;
        float depth_sum[2] = {0.f, 0.f}, weight_sum[2] = {0.f, 0.f};
        for (size_t batch = first; batch < last && k::half_pair_live(pair); batch += batch_pairs) {
          int walked = 0;  // entries of this batch's walk list
          for (size_t j = batch; j < std::min(last, batch + batch_pairs) && k::half_pair_live(pair); ++j) {
            if ((masks[j] & block_bit) == 0) continue;
            const TileGaussian& g = list[j];
            const float v_first = k::folded_power(of_v[j], terms);
            const float v_second = k::dual_pixel_power(v_first, of_v[j], terms);
            const k::Half2Bits alpha = k::half2_alpha(v_first, v_second);
            if (alpha != 0) {
              const k::Half2Bits w = k::blend_half2(pair, alpha, k::half2_broadcast(g.rgb[0]),
                                                    k::half2_broadcast(g.rgb[1]), k::half2_broadcast(g.rgb[2]));
              for (int p = 0; p < 2; ++p) {
                const float wp = k::half_to_float(static_cast<uint16_t>(w >> (16 * p)));
                depth_sum[p] = std::fmaf(g.depth, wp, depth_sum[p]);
                weight_sum[p] += wp;
              }
            }
            if (++walked % k::kColourWindowEntries == 0) k::close_colour_window(pair);
          }
          k::close_colour_window(pair);  // the batch's last window, padded on the GPU
        }
        for (int p = 0; p < 2; ++p) {
          k::merge_chunk(merged[p], k::chunk_pixel_of_half(pair, p, depth_sum[p], weight_sum[p]));
        }
      }
      for (int p = 0; p < 2; ++p) {
        if (!(x < out->width && y + uint32_t(p) < out->height)) continue;
        PixelState s;
        s.T = merged[p].T;
        for (int c = 0; c < 3; ++c) s.C[c] = merged[p].C[c];
        s.depth_sum = merged[p].depth_sum, s.weight_sum = merged[p].weight_sum;
        store_pixel(s, x, y + uint32_t(p), options, out);
      }
    }
  }
}

}  // namespace

Result<FrameSetup> setup_frame(const format::GaussianCloud& cloud, const Camera& camera,
                               const RenderOptions& options) {
  RGS_RETURN_ERROR_IF(!cloud.is_consistent(), StatusCode::kInvalidArgument,
                      "render: Gaussian cloud arrays do not match its size " + std::to_string(cloud.size()) +
                          " and SH degree " + std::to_string(cloud.sh_degree));
  RGS_RETURN_ERROR_IF(cloud.size() > uint64_t{0xffffffffu}, StatusCode::kLimitExceeded,
                      "render: " + std::to_string(cloud.size()) + " Gaussians exceed the 2^32 - 1 index limit");
  RGS_RETURN_IF_ERROR(validate_camera(camera));
  const RoofgsOptions& roofgs = options.roofgs;
  RGS_RETURN_ERROR_IF(!(roofgs.fast_exp_sigma >= 0.f && roofgs.fast_exp_sigma < 1.f), StatusCode::kInvalidArgument,
                      "render: fast_exp_sigma " + std::to_string(roofgs.fast_exp_sigma) + " outside [0, 1)");
  for (float c : options.background) {
    RGS_RETURN_ERROR_IF(!std::isfinite(c), StatusCode::kInvalidArgument, "render: background is not finite");
  }

  FrameSetup frame;
  frame.width = camera.width;
  frame.height = camera.height;
  frame.tiles_x = k::tile_count_for(int(camera.width));
  frame.tiles_y = k::tile_count_for(int(camera.height));
  frame.ewa_clamp = k::ewa_clamp_for(camera.fx, camera.fy, camera.cx, camera.cy, static_cast<float>(camera.width),
                                     static_cast<float>(camera.height));
  if (roofgs.key32) {
    RGS_ASSIGN_OR_RETURN(frame.key, make_depth_key(camera, options.scene_bounds, uint32_t(frame.tiles_x),
                                                   uint32_t(frame.tiles_y)));
  }
  return frame;
}

namespace {

Status preprocess_into(const format::GaussianCloud& cloud, const Camera& camera, const FrameSetup& frame,
                       const RenderOptions& options, RenderStats* stats, std::vector<ProjectedGaussian>& out) {
  const uint64_t n = cloud.size();
  const RoofgsOptions& roofgs = options.roofgs;
  const int sh_degree = int(cloud.sh_degree);
  const uint64_t sh_stride = uint64_t(cloud.sh_coefficients()) * 3;
  const std::array<float, 3> centre = camera_centre(camera);
  out.assign(n, ProjectedGaussian{});
  // Per-chunk culling counters, summed in chunk order afterwards (integer sums: order-independent anyway).
  const uint64_t chunks = (n + kGaussianChunk - 1) / kGaussianChunk;
  std::vector<uint64_t> culled_near(chunks, 0), culled_range(chunks, 0), culled_opacity(chunks, 0);

  Status work = detail::parallel_chunks(n, kGaussianChunk, detail::resolve_thread_count(options.num_threads),
                                        [&](uint64_t begin, uint64_t end) {
    const uint64_t chunk = begin / kGaussianChunk;
    for (uint64_t i = begin; i < end; ++i) {
      ProjectedGaussian& g = out[i];
      const float* mean = &cloud.means[i * 3];
      // 1. View transform; cull at the near plane (3DGS in_frustum: z <= 0.2). NaN is culled too.
      float p_cam[3];
      k::world_to_camera(camera.rotation.data(), camera.translation.data(), mean, p_cam);
      if (!(p_cam[2] > camera.near_plane)) {
        ++culled_near[chunk];
        continue;
      }
      // 1b. RoofGS 32-bit key: cull outside the camera's quantization range [z_near, z_far] (plus margin).
      if (roofgs.key32 &&
          (frame.key.empty_depth_range || p_cam[2] < frame.key.cull_z_min || p_cam[2] > frame.key.cull_z_max)) {
        ++culled_range[chunk];
        continue;
      }
      // 2. 3D covariance Σ = R·S·Sᵀ·Rᵀ, then EWA 2D covariance with the Jacobian clamp and the 0.3 dilation.
      float cov3d[6];
      k::covariance_3d(&cloud.scales[i * 3], &cloud.rotations[i * 4], cov3d);
      const k::Cov2 cov = k::ewa_covariance_2d(cov3d, camera.rotation.data(), p_cam, camera.fx, camera.fy,
                                               frame.ewa_clamp);
      // 3. Cull only det == 0; conic = (c, −b, a) / det.
      const float det = k::determinant(cov);
      if (det == 0.f) continue;
      const k::Conic conic = k::conic_from_covariance(cov, det);
      // 4. Radius ceil(3·sqrt(λmax)), pixel mean fx·x/z + cx − 0.5, tile rectangle with (int) truncation.
      const int radius = k::screen_radius(cov, det);
      float px, py;
      k::project_to_pixel(p_cam, camera.fx, camera.fy, camera.cx, camera.cy, &px, &py);
      // Guard (not in 3DGS; no effect on finite input): non-finite projections cannot be rasterized.
      if (!std::isfinite(px) || !std::isfinite(py) || !std::isfinite(conic.a) || !std::isfinite(conic.b) ||
          !std::isfinite(conic.c)) {
        continue;
      }
      const k::TileRect rect = k::tile_rect(px, py, radius, frame.tiles_x, frame.tiles_y);
      if (k::tile_area(rect) == 0) continue;

      g.depth = p_cam[2];
      g.mean[0] = px;
      g.mean[1] = py;
      g.cov = cov;
      g.det = det;
      g.conic = conic;
      g.opacity = cloud.opacities[i];
      if (cloud.antialiased) g.opacity *= k::antialias_compensation(cov, det);
      g.log_opacity = std::log(g.opacity);
      g.radius = radius;
      g.rect = rect;

      // 5. RoofGS SnugBox + AccuTile: cull o <= 1/255, count the exact tiles.
      uint32_t tiles = uint32_t(k::tile_area(rect));
      if (roofgs.snugbox_accutile) {
        float t = 0.f;
        if (!k::snugbox_threshold(g.opacity, &t)) {
          ++culled_opacity[chunk];
          continue;
        }
        g.snug_t = t;
        const k::SnugBox box = k::make_snugbox(px, py, cov, t);
        const k::TileRect limit = accutile_limit(frame, roofgs, rect);
        g.rect = k::snugbox_rect(box, limit);
        tiles = k::for_each_accutile_tile(box, limit, [](int, int) {});
        if (tiles == 0) continue;
      }

      // 6. Colour from SH along dir = normalize(mean − camera centre); max(Σ + 0.5, 0).
      float dir[3] = {mean[0] - centre[0], mean[1] - centre[1], mean[2] - centre[2]};
      const float length = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
      for (float& d : dir) d = d / length;
      k::sh_to_colour(&cloud.sh[i * sh_stride], sh_degree, dir[0], dir[1], dir[2], g.rgb);

      if (roofgs.key32) g.depth_bin = k::quantize_depth(g.depth, frame.key.quantizer);
      g.tiles_touched = tiles;
    }
  });
  RGS_RETURN_IF_ERROR(work);

  if (stats != nullptr) {
    stats->gaussians = n;
    for (uint64_t c = 0; c < chunks; ++c) {
      stats->culled_near += culled_near[c];
      stats->culled_depth_range += culled_range[c];
      stats->culled_opacity += culled_opacity[c];
    }
    stats->visible = 0;
    for (const ProjectedGaussian& g : out) stats->visible += g.tiles_touched > 0 ? 1 : 0;
  }
  return Status();
}

}  // namespace

Status preprocess_cpu(const format::GaussianCloud& cloud, const Camera& camera, const FrameSetup& frame,
                      const RenderOptions& options, RenderStats* stats, std::vector<ProjectedGaussian>* out) {
  RGS_RETURN_ERROR_IF(out == nullptr, StatusCode::kInvalidArgument, "render: null preprocess output");
  try {
    Status s = preprocess_into(cloud, camera, frame, options, stats, *out);
    if (!s.ok()) {
      *out = {};
      return s.prepend("render: preprocess of " + std::to_string(cloud.size()) + " Gaussians");
    }
    return s;
  } catch (const std::bad_alloc&) {
    *out = {};
    return Status(StatusCode::kOutOfMemory,
                  "render: out of memory preprocessing " + std::to_string(cloud.size()) + " Gaussians");
  }
}

std::vector<ProjectedGaussian> preprocess_cpu(const format::GaussianCloud& cloud, const Camera& camera,
                                              const FrameSetup& frame, const RenderOptions& options,
                                              RenderStats* stats) {
  std::vector<ProjectedGaussian> out;
  const Status s = preprocess_cpu(cloud, camera, frame, options, stats, &out);
  if (s.code() == StatusCode::kOutOfMemory) throw std::bad_alloc();
  return out;
}

namespace {

/// bin_and_sort_cpu() into s.bins, with s.order, s.offsets and s.pairs as working memory.
Status bin_and_sort(const std::vector<ProjectedGaussian>& gaussians, const FrameSetup& frame,
                    const RenderOptions& options, CpuScratch& s) {
  const uint64_t n = gaussians.size();
  const RoofgsOptions& roofgs = options.roofgs;
  const unsigned threads = detail::resolve_thread_count(options.num_threads);

  // Emission order: Gaussian index, or (depth, index) with depth_order (depths are never NaN: culled ones are 0).
  std::vector<uint32_t>& order = s.order;
  order.resize(n);
  for (uint64_t i = 0; i < n; ++i) order[i] = uint32_t(i);
  if (roofgs.depth_order) {
    std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
      return gaussians[a].depth < gaussians[b].depth || (gaussians[a].depth == gaussians[b].depth && a < b);
    });
  }
  // Offsets of each emitted Gaussian's pairs: exclusive prefix sum of tiles_touched in emission order.
  std::vector<uint64_t>& offsets = s.offsets;
  offsets.assign(n + 1, 0);
  for (uint64_t t = 0; t < n; ++t) offsets[t + 1] = offsets[t] + gaussians[order[t]].tiles_touched;
  const uint64_t pairs = offsets[n];

  TileBins& bins = s.bins;
  const uint64_t num_tiles = uint64_t(frame.tiles_x) * uint64_t(frame.tiles_y);
  RGS_RETURN_IF_ERROR(catch_bad_alloc([&] {
    s.pairs.resize(pairs);
    bins.keys.resize(pairs);
    bins.values.resize(pairs);
    bins.tile_begin.assign(num_tiles + 1, 0);
    return Status();
  }, [&] { return "render: cannot allocate " + std::to_string(pairs) + " (tile, Gaussian) pairs"; }));

  // Duplicate with keys (3DGS duplicateWithKeys): the t-th emitted Gaussian writes (key, t) to
  // [offsets[t], offsets[t+1]).
  Status work = detail::parallel_chunks(n, kGaussianChunk, threads, [&](uint64_t begin, uint64_t end) {
    for (uint64_t t = begin; t < end; ++t) {
      const ProjectedGaussian& g = gaussians[order[t]];
      if (g.tiles_touched == 0) continue;
      uint64_t off = offsets[t];
      for_each_tile_of(g, frame, roofgs, [&](int tx, int ty) {
        const uint32_t tile = uint32_t(ty) * uint32_t(frame.tiles_x) + uint32_t(tx);
        const uint64_t key = roofgs.key32 ? k::make_key32(tile, g.depth_bin, frame.key.depth_bits)
                                          : k::make_key64(tile, g.depth);
        s.pairs[off++] = {key, uint32_t(t)};
      });
    }
  });
  RGS_RETURN_IF_ERROR(work);

  // Sort by (key, emission rank): the order of a stable sort by key, in which equal keys (same tile, same depth
  // or depth bin) keep emission order, as CUB's radix sort does in 3DGS; std::sort needs no buffer.
  std::sort(s.pairs.begin(), s.pairs.end());

  // Per-tile ranges (3DGS identifyTileRanges), as offsets.
  const int tile_shift = roofgs.key32 ? frame.key.depth_bits : 32;
  for (uint64_t p = 0; p < pairs; ++p) {
    bins.keys[p] = s.pairs[p].first;
    bins.values[p] = order[s.pairs[p].second];
    const uint64_t tile = tile_shift >= 64 ? 0 : (s.pairs[p].first >> tile_shift);
    ++bins.tile_begin[tile + 1];
  }
  for (uint64_t t = 0; t < num_tiles; ++t) bins.tile_begin[t + 1] += bins.tile_begin[t];
  return Status();
}

/// bin_and_sort() giving kOutOfMemory for any allocation that fails.
Status bin_and_sort_into(const std::vector<ProjectedGaussian>& gaussians, const FrameSetup& frame,
                         const RenderOptions& options, CpuScratch& s) {
  return catch_bad_alloc([&] { return bin_and_sort(gaussians, frame, options, s); }, [&] {
    return "render: out of memory binning " + std::to_string(gaussians.size()) + " Gaussians into tiles";
  });
}

/// blend_cpu() with one TileScratch per worker thread in `workers`.
Status blend(const std::vector<ProjectedGaussian>& gaussians, const TileBins& bins, const FrameSetup& frame,
             const RenderOptions& options, std::vector<TileScratch>& workers, RenderResult* result) {
  const size_t pixels = size_t(frame.width) * frame.height;
  result->width = frame.width;
  result->height = frame.height;
  try {
    result->rgb.assign(pixels * 3, 0.f);
    result->alpha.assign(pixels, 0.f);
    result->depth.assign(pixels, 0.f);
  } catch (const std::bad_alloc&) {
    return Status(StatusCode::kOutOfMemory, "render: out of memory allocating a " + std::to_string(frame.width) +
                                                "x" + std::to_string(frame.height) + " image");
  }
  const bool folded = options.roofgs.folded_coefficients;
  const bool half = folded && options.roofgs.fast_exp && options.roofgs.half_blend;
  // Pairs of Gaussians with more than kChunkLargeTiles (= kSubtileLargeTiles) tiles, for the half blend only:
  // frame_chunk_pairs and the GPU's automatic block culling, whose walk lists the half blend follows.
  static_assert(k::kChunkLargeTiles == k::kSubtileLargeTiles);
  uint64_t large_pairs = 0;
  for (size_t i = 0; half && i < gaussians.size(); ++i) {
    if (gaussians[i].tiles_touched > k::kChunkLargeTiles) large_pairs += gaussians[i].tiles_touched;
  }
  const uint32_t chunk_pairs = k::frame_chunk_pairs(bins.values.size(), large_pairs, options.roofgs.tile_chunk_pairs);
  const bool block_culling =
      k::auto_block_culling(options.roofgs.snugbox_accutile, bins.values.size(), large_pairs);
  const unsigned threads = detail::resolve_thread_count(options.num_threads);
  if (workers.size() < threads) workers.resize(threads);
  Status work = detail::parallel_items(uint64_t(frame.tiles_y), threads, [&](unsigned worker, uint64_t row) {
    TileScratch& tile = workers[worker];
    const int ty = int(row);
    for (int tx = 0; tx < frame.tiles_x; ++tx) {
      const uint64_t id = uint64_t(ty) * uint64_t(frame.tiles_x) + uint64_t(tx);
      const uint64_t begin = bins.tile_begin[id], end = bins.tile_begin[id + 1];
      gather_tile(gaussians, bins.values.data() + begin, end - begin, tx, ty, folded, &tile.list);
      if (half) {
        blend_tile_folded_half(tile, tx, ty, options, chunk_pairs, block_culling, result);
      } else if (folded) {
        blend_tile_folded(tile.list, tx, ty, options, result);
      } else {
        blend_tile_baseline(tile.list, tx, ty, options, result);
      }
    }
  });
  return work.ok() ? work : work.prepend("render: blending");
}

Status render(const format::GaussianCloud& cloud, const Camera& camera, const RenderOptions& options,
              CpuScratch& scratch) {
  RGS_ASSIGN_OR_RETURN(const FrameSetup frame, setup_frame(cloud, camera, options));
  RenderResult& result = scratch.result;
  result.stats = RenderStats{};
  RGS_RETURN_IF_ERROR(preprocess_cpu(cloud, camera, frame, options, &result.stats, &scratch.gaussians));
  RGS_RETURN_IF_ERROR(bin_and_sort_into(scratch.gaussians, frame, options, scratch));
  RGS_RETURN_IF_ERROR(blend(scratch.gaussians, scratch.bins, frame, options, scratch.workers, &result));
  RenderStats& s = result.stats;
  s.pairs = scratch.bins.values.size();
  s.tiles_x = frame.tiles_x;
  s.tiles_y = frame.tiles_y;
  s.key_tile_bits = frame.key.tile_bits;
  s.key_depth_bits = frame.key.depth_bits;
  s.z_near = options.roofgs.key32 ? frame.key.quantizer.z_near : 0.f;
  s.z_far = options.roofgs.key32 && !frame.key.empty_depth_range ? frame.key.quantizer.z_far : 0.f;
  return Status();
}

}  // namespace

Result<TileBins> bin_and_sort_cpu(const std::vector<ProjectedGaussian>& gaussians, const FrameSetup& frame,
                                  const RenderOptions& options) {
  CpuScratch scratch;
  RGS_RETURN_IF_ERROR(bin_and_sort_into(gaussians, frame, options, scratch));
  return std::move(scratch.bins);
}

Status blend_cpu(const std::vector<ProjectedGaussian>& gaussians, const TileBins& bins, const FrameSetup& frame,
                 const RenderOptions& options, RenderResult* result) {
  std::vector<TileScratch> workers;
  return blend(gaussians, bins, frame, options, workers, result);
}

Status render_cpu(const format::GaussianCloud& cloud, const Camera& camera, const RenderOptions& options,
                  CpuScratch* scratch) {
  return catch_bad_alloc([&] { return render(cloud, camera, options, *scratch); }, [&] {
    return "render: out of memory rendering " + std::to_string(cloud.size()) + " Gaussians";
  });
}

Result<RenderResult> render_cpu(const format::GaussianCloud& cloud, const Camera& camera,
                                const RenderOptions& options) {
  CpuScratch scratch;
  RGS_RETURN_IF_ERROR(render_cpu(cloud, camera, options, &scratch));
  return std::move(scratch.result);
}

}  // namespace rgs::runtime
