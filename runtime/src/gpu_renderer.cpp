// GpuRenderer: the baseline pipeline's stages (kernels/baseline_pipeline.h) with buffers that grow as
// needed, every CUDA call checked.
#include "rgs/runtime/gpu_renderer.h"

#include <cmath>
#include <string>

#include "rgs/kernels/shared/projection.h"

namespace rgs::runtime {
namespace {

/// Largest image side the renderer accepts (validate_camera's bound as well).
constexpr uint32_t kMaxImageSide = 32768;

kernels::FrameParams make_frame_params(const Camera& camera, const GpuRenderOptions& options) {
  kernels::FrameParams f{};
  for (int i = 0; i < 9; ++i) f.view_rotation[i] = camera.rotation[i];
  for (int i = 0; i < 3; ++i) f.view_translation[i] = camera.translation[i];
  const std::array<float, 3> centre = camera_centre(camera);
  for (int i = 0; i < 3; ++i) f.camera_centre[i] = centre[i];
  f.fx = camera.fx;
  f.fy = camera.fy;
  f.cx = camera.cx;
  f.cy = camera.cy;
  f.near_plane = camera.near_plane;
  f.ewa_clamp = kernels::ewa_clamp_for(camera.fx, camera.fy, camera.cx, camera.cy, static_cast<float>(camera.width),
                                       static_cast<float>(camera.height));
  for (int i = 0; i < 3; ++i) f.background[i] = options.background[i];
  f.width = camera.width;
  f.height = camera.height;
  f.tiles_x = uint32_t(kernels::tile_count_for(int(camera.width)));
  f.tiles_y = uint32_t(kernels::tile_count_for(int(camera.height)));
  return f;
}

/// ceil(log2(n)) for n ≥ 1.
int ceil_log2(uint64_t n) {
  int bits = 0;
  while ((uint64_t{1} << bits) < n) ++bits;
  return bits;
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------
// DeviceImage

Status DeviceImage::resize(uint32_t width, uint32_t height, bool with_depth) {
  RGS_RETURN_ERROR_IF(width == 0 || height == 0 || width > kMaxImageSide || height > kMaxImageSide,
                      StatusCode::kInvalidArgument,
                      "DeviceImage: size " + std::to_string(width) + "x" + std::to_string(height) +
                          " outside [1, " + std::to_string(kMaxImageSide) + "]");
  const size_t pixels = size_t(width) * height;
  RGS_RETURN_IF_ERROR(rgba_.reserve(pixels * 4, "DeviceImage: RGBA plane"));
  if (with_depth) RGS_RETURN_IF_ERROR(depth_.reserve(pixels, "DeviceImage: depth plane"));
  width_ = width;
  height_ = height;
  has_depth_ = with_depth;
  return Status();
}

Result<HostImage> download(const DeviceImage& image, cudaStream_t stream) {
  HostImage host;
  host.width = image.width();
  host.height = image.height();
  const size_t pixels = size_t(host.width) * host.height;
  host.rgba.resize(pixels * 4);
  RGS_RETURN_IF_CUDA_ERROR(cudaMemcpyAsync(host.rgba.data(), image.rgba(), pixels * 4 * sizeof(float),
                                           cudaMemcpyDeviceToHost, stream),
                           "download: RGBA plane");
  if (image.has_depth()) {
    host.depth.resize(pixels);
    RGS_RETURN_IF_CUDA_ERROR(cudaMemcpyAsync(host.depth.data(), image.depth(), pixels * sizeof(float),
                                             cudaMemcpyDeviceToHost, stream),
                             "download: depth plane");
  }
  RGS_RETURN_IF_CUDA_ERROR(cudaStreamSynchronize(stream), "download");
  return host;
}

// ---------------------------------------------------------------------------------------------------------
// GpuRenderer

struct GpuRenderer::Buffers {
  // Per Gaussian.
  DeviceBuffer<float> depths, means2d, conic_opacity, rgb;
  DeviceBuffer<int32_t> radii;
  DeviceBuffer<uint64_t> tiles_touched, offsets;
  DeviceBuffer<uint8_t> scan_temp;
  // Per pair.
  DeviceBuffer<uint64_t> keys, keys_sorted;
  DeviceBuffer<uint32_t> values, values_sorted;
  DeviceBuffer<uint8_t> sort_temp;
  // Per tile: [begin, end) pairs.
  DeviceBuffer<uint64_t> ranges;
  // Pair count read back from the device.
  PinnedBuffer pair_count;
  // Stage boundaries: start, after duplicate, after sort, after ranges, after render.
  cudaEvent_t events[5] = {nullptr, nullptr, nullptr, nullptr, nullptr};

  ~Buffers() {
    for (cudaEvent_t& e : events) {
      if (e != nullptr) cudaEventDestroy(e);
    }
  }

  void release_pairs() {
    keys.release();
    keys_sorted.release();
    values.release();
    values_sorted.release();
    sort_temp.release();
  }

  uint64_t bytes() const {
    return depths.bytes() + means2d.bytes() + conic_opacity.bytes() + rgb.bytes() + radii.bytes() +
           tiles_touched.bytes() + offsets.bytes() + scan_temp.bytes() + keys.bytes() + keys_sorted.bytes() +
           values.bytes() + values_sorted.bytes() + sort_temp.bytes() + ranges.bytes();
  }

  kernels::ProjectedArrays projected() const {
    kernels::ProjectedArrays p;
    p.depths = depths.data();
    p.means2d = means2d.data();
    p.conic_opacity = conic_opacity.data();
    p.rgb = rgb.data();
    p.radii = radii.data();
    p.tiles_touched = tiles_touched.data();
    return p;
  }
};

Result<GpuRenderer> GpuRenderer::create() {
  GpuRenderer renderer;
  renderer.buffers_ = std::make_unique<Buffers>();
  RGS_RETURN_IF_ERROR(renderer.buffers_->pair_count.reserve(sizeof(uint64_t), "GpuRenderer: pair count"));
  for (cudaEvent_t& e : renderer.buffers_->events) {
    RGS_RETURN_IF_CUDA_ERROR(cudaEventCreate(&e), "GpuRenderer: cudaEventCreate");
  }
  return renderer;
}

GpuRenderer::GpuRenderer(GpuRenderer&&) noexcept = default;
GpuRenderer& GpuRenderer::operator=(GpuRenderer&&) noexcept = default;
GpuRenderer::~GpuRenderer() = default;

uint64_t GpuRenderer::scratch_bytes() const { return buffers_ ? buffers_->bytes() : 0; }

Result<GpuRenderStats> GpuRenderer::render(const GpuScene& scene, const Camera& camera,
                                           const GpuRenderOptions& options, DeviceImage* image,
                                           cudaStream_t stream) {
  RGS_RETURN_ERROR_IF(buffers_ == nullptr, StatusCode::kInvalidArgument, "GpuRenderer: used after move");
  RGS_RETURN_ERROR_IF(image == nullptr, StatusCode::kInvalidArgument, "GpuRenderer: no output image");
  RGS_RETURN_IF_ERROR(validate_camera(camera));
  for (float c : options.background) {
    RGS_RETURN_ERROR_IF(!std::isfinite(c), StatusCode::kInvalidArgument, "GpuRenderer: background is not finite");
  }
  RGS_RETURN_IF_ERROR(image->resize(camera.width, camera.height, image->has_depth()));

  Buffers& b = *buffers_;
  const kernels::FrameParams frame = make_frame_params(camera, options);
  const uint32_t n = scene.size();
  const uint32_t num_tiles = frame.tiles_x * frame.tiles_y;
  cudaEvent_t* ev = b.events;
  const bool timed = options.time_stages;

  GpuRenderStats stats;
  stats.gaussians = n;
  stats.tiles_x = frame.tiles_x;
  stats.tiles_y = frame.tiles_y;
  stats.sort_bits = 32 + ceil_log2(num_tiles);

  if (timed) RGS_RETURN_IF_CUDA_ERROR(cudaEventRecord(ev[0], stream), "GpuRenderer: cudaEventRecord");

  // 1. Preprocess and 2. offsets, pair count, duplication.
  uint64_t pairs = 0;
  if (n > 0) {
    RGS_RETURN_IF_ERROR(b.depths.reserve(n, "GpuRenderer: depths"));
    RGS_RETURN_IF_ERROR(b.means2d.reserve(size_t(n) * 2, "GpuRenderer: 2D means"));
    RGS_RETURN_IF_ERROR(b.conic_opacity.reserve(size_t(n) * 4, "GpuRenderer: conics"));
    RGS_RETURN_IF_ERROR(b.rgb.reserve(size_t(n) * 3, "GpuRenderer: colours"));
    RGS_RETURN_IF_ERROR(b.radii.reserve(n, "GpuRenderer: radii"));
    RGS_RETURN_IF_ERROR(b.tiles_touched.reserve(n, "GpuRenderer: tiles touched"));
    RGS_RETURN_IF_ERROR(b.offsets.reserve(n, "GpuRenderer: pair offsets"));
    const kernels::ProjectedArrays projected = b.projected();
    RGS_RETURN_IF_CUDA_ERROR(kernels::preprocess_baseline(scene.fp32(), frame, projected, stream),
                             "GpuRenderer: preprocess kernel");
    size_t scan_bytes = 0;
    RGS_RETURN_IF_CUDA_ERROR(kernels::inclusive_scan(nullptr, &scan_bytes, b.tiles_touched.data(),
                                                     b.offsets.data(), n, stream),
                             "GpuRenderer: scan size query");
    RGS_RETURN_IF_ERROR(b.scan_temp.reserve(scan_bytes, "GpuRenderer: scan scratch"));
    scan_bytes = b.scan_temp.bytes();
    RGS_RETURN_IF_CUDA_ERROR(kernels::inclusive_scan(b.scan_temp.data(), &scan_bytes, b.tiles_touched.data(),
                                                     b.offsets.data(), n, stream),
                             "GpuRenderer: offset scan");
    RGS_RETURN_IF_CUDA_ERROR(cudaMemcpyAsync(b.pair_count.data(), b.offsets.data() + (n - 1), sizeof(uint64_t),
                                             cudaMemcpyDeviceToHost, stream),
                             "GpuRenderer: pair count read-back");
    RGS_RETURN_IF_CUDA_ERROR(cudaStreamSynchronize(stream), "GpuRenderer: preprocess");
    pairs = *static_cast<const uint64_t*>(b.pair_count.data());
  }
  stats.pairs = pairs;

  if (pairs > 0) {
    // Pair buffers; on failure drop them all so the renderer stays usable for smaller frames.
    Status grown = b.keys.reserve(pairs, "GpuRenderer: keys of " + std::to_string(pairs) + " pairs");
    if (grown.ok()) grown = b.keys_sorted.reserve(pairs, "GpuRenderer: sorted keys of " + std::to_string(pairs) + " pairs");
    if (grown.ok()) grown = b.values.reserve(pairs, "GpuRenderer: values of " + std::to_string(pairs) + " pairs");
    if (grown.ok()) {
      grown = b.values_sorted.reserve(pairs, "GpuRenderer: sorted values of " + std::to_string(pairs) + " pairs");
    }
    size_t sort_bytes = 0;
    if (grown.ok()) {
      grown = cuda_status(kernels::sort_pairs(nullptr, &sort_bytes, b.keys.data(), b.keys_sorted.data(),
                                              b.values.data(), b.values_sorted.data(), pairs, stats.sort_bits,
                                              stream),
                          "GpuRenderer: sort size query");
    }
    if (grown.ok()) grown = b.sort_temp.reserve(sort_bytes, "GpuRenderer: sort scratch");
    if (!grown.ok()) {
      b.release_pairs();
      return grown;
    }
    RGS_RETURN_IF_CUDA_ERROR(kernels::duplicate_baseline(b.projected(), b.offsets.data(), n, frame, b.keys.data(),
                                                         b.values.data(), stream),
                             "GpuRenderer: duplicate kernel");
    if (timed) RGS_RETURN_IF_CUDA_ERROR(cudaEventRecord(ev[1], stream), "GpuRenderer: cudaEventRecord");
    // 3. Stable radix sort over 32 + ceil(log2(tiles)) bits.
    sort_bytes = b.sort_temp.bytes();
    RGS_RETURN_IF_CUDA_ERROR(kernels::sort_pairs(b.sort_temp.data(), &sort_bytes, b.keys.data(), b.keys_sorted.data(),
                                                 b.values.data(), b.values_sorted.data(), pairs, stats.sort_bits,
                                                 stream),
                             "GpuRenderer: radix sort");
  } else if (timed) {
    RGS_RETURN_IF_CUDA_ERROR(cudaEventRecord(ev[1], stream), "GpuRenderer: cudaEventRecord");
  }
  if (timed) RGS_RETURN_IF_CUDA_ERROR(cudaEventRecord(ev[2], stream), "GpuRenderer: cudaEventRecord");

  // 4. Per-tile ranges.
  RGS_RETURN_IF_ERROR(b.ranges.reserve(size_t(num_tiles) * 2, "GpuRenderer: tile ranges"));
  RGS_RETURN_IF_CUDA_ERROR(kernels::tile_ranges(b.keys_sorted.data(), pairs, 32, num_tiles, b.ranges.data(), stream),
                           "GpuRenderer: tile ranges kernel");
  if (timed) RGS_RETURN_IF_CUDA_ERROR(cudaEventRecord(ev[3], stream), "GpuRenderer: cudaEventRecord");

  // 5. Blend.
  RGS_RETURN_IF_CUDA_ERROR(kernels::render_baseline(b.ranges.data(), b.values_sorted.data(), b.projected(), frame,
                                                    image->view(), stream),
                           "GpuRenderer: render kernel");
  if (timed) {
    RGS_RETURN_IF_CUDA_ERROR(cudaEventRecord(ev[4], stream), "GpuRenderer: cudaEventRecord");
    RGS_RETURN_IF_CUDA_ERROR(cudaEventSynchronize(ev[4]), "GpuRenderer: frame");
    float* fields[4] = {&stats.times.preprocess_ms, &stats.times.sort_ms, &stats.times.ranges_ms,
                        &stats.times.render_ms};
    for (int s = 0; s < 4; ++s) {
      RGS_RETURN_IF_CUDA_ERROR(cudaEventElapsedTime(fields[s], ev[s], ev[s + 1]), "GpuRenderer: cudaEventElapsedTime");
    }
    RGS_RETURN_IF_CUDA_ERROR(cudaEventElapsedTime(&stats.times.total_ms, ev[0], ev[4]),
                             "GpuRenderer: cudaEventElapsedTime");
    stats.timed = true;
  }
  return stats;
}

}  // namespace rgs::runtime
