// Sample: embed RoofGS. Load a .rgs (or a PLY), build a camera from OpenGL-style matrices, and render one
// frame with the default preset into a buffer this program owns: device memory from cudaMallocPitch on this
// program's own CUDA stream, or host memory with the CPU reference.
//
//   rgs_sample_render_frame scene.rgs [cpu|cuda] [out.ppm]

#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "rgs/api/roofgs.h"

#if RGS_HAS_CUDA
#include <cuda_runtime_api.h>
#endif

namespace {

int fail(const rgs::Status& status) {
  std::fprintf(stderr, "error: %s\n", status.to_string().c_str());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || argc > 4) {
    std::fprintf(stderr, "usage: %s scene.rgs [cpu|cuda] [out.ppm]\n", argv[0]);
    return 2;
  }
  auto device = rgs::api::parse_device(argc > 2 ? argv[2] : "cuda");
  if (!device.ok()) return fail(device.status());

  rgs::api::LoadOptions load_options;
  load_options.device = *device;
  auto scene = rgs::api::load(argv[1], load_options);
  if (!scene.ok()) return fail(scene.status());
  const rgs::api::SceneInfo& info = scene->info();
  std::printf("%llu Gaussians, SH degree %u, %s: %llu bytes (runtime sections %llu bytes)\n",
              static_cast<unsigned long long>(info.gaussians), info.sh_degree, rgs::api::device_name(info.device),
              static_cast<unsigned long long>(info.memory_bytes),
              static_cast<unsigned long long>(info.runtime_section_bytes));

  // An OpenGL view looking at the scene's centre from 2 radii along +z, 60° vertical field of view.
  const uint32_t width = 320, height = 180;
  const rgs::format::SceneBounds& bounds = info.bounds;
  const float* c = bounds.sphere_center;
  const float distance = 2.f * bounds.sphere_radius;
  rgs::api::Mat4ColumnMajor view = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, -c[0], -c[1], -c[2] - distance, 1};
  const float f = 1.f / std::tan(0.5f * 60.f * 3.14159265f / 180.f), aspect = float(width) / float(height);
  const float n = 0.1f, far_plane = 10.f * distance;
  rgs::api::Mat4ColumnMajor projection = {f / aspect, 0, 0, 0, 0, f, 0, 0, 0, 0, -(far_plane + n) / (far_plane - n), -1,
                                          0, 0, -2 * far_plane * n / (far_plane - n), 0};
  auto camera = rgs::api::camera_from_opengl(view, projection, width, height);
  if (!camera.ok()) return fail(camera.status());

  auto renderer = rgs::api::Renderer::create(*device);
  if (!renderer.ok()) return fail(renderer.status());

  // The frame, RGBA8, in this program's memory.
  std::vector<uint8_t> pixels(size_t(width) * height * 4);
  rgs::api::ImageTarget target;
  target.width = width;
  target.height = height;
  target.format = rgs::api::PixelFormat::kRgba8;
  uint64_t pairs = 0;
  if (*device == rgs::api::Device::kCpu) {
    target.color = pixels.data();
    target.color_pitch = size_t(width) * 4;
    auto stats = renderer->render(*scene, *camera, {}, target);
    if (!stats.ok()) return fail(stats.status());
    pairs = stats->pairs;
  } else {
#if RGS_HAS_CUDA
    cudaStream_t stream = nullptr;
    void* d_pixels = nullptr;
    size_t pitch = 0;
    if (cudaStreamCreateWithFlags(&stream, cudaStreamNonBlocking) != cudaSuccess ||
        cudaMallocPitch(&d_pixels, &pitch, size_t(width) * 4, height) != cudaSuccess) {
      std::fprintf(stderr, "error: CUDA allocation failed\n");
      return 1;
    }
    target.color = d_pixels;
    target.color_pitch = pitch;
    auto stats = renderer->render(*scene, *camera, {}, target, stream);
    if (!stats.ok()) return fail(stats.status());
    pairs = stats->pairs;
    // The frame is complete when the stream gets there; copy it back on the same stream.
    cudaMemcpy2DAsync(pixels.data(), size_t(width) * 4, d_pixels, pitch, size_t(width) * 4, height,
                      cudaMemcpyDeviceToHost, stream);
    if (cudaStreamSynchronize(stream) != cudaSuccess) {
      std::fprintf(stderr, "error: CUDA stream failed\n");
      return 1;
    }
    cudaFree(d_pixels);
    cudaStreamDestroy(stream);
#endif
  }

  double mean[3] = {0, 0, 0}, coverage = 0;
  for (size_t p = 0; p < size_t(width) * height; ++p) {
    for (int k = 0; k < 3; ++k) mean[k] += pixels[p * 4 + size_t(k)];
    coverage += pixels[p * 4 + 3];
  }
  const double count = double(width) * height * 255.0;
  std::printf("rendered %ux%u (%s, preset fastest): %llu pairs, mean RGB (%.3f, %.3f, %.3f), coverage %.3f\n", width,
              height, rgs::api::device_name(*device), static_cast<unsigned long long>(pairs), mean[0] / count,
              mean[1] / count, mean[2] / count, coverage / count);
  if (argc > 3) {
    FILE* out = std::fopen(argv[3], "wb");
    if (out == nullptr) {
      std::fprintf(stderr, "error: cannot write %s\n", argv[3]);
      return 1;
    }
    std::fprintf(out, "P6\n%u %u\n255\n", width, height);
    for (size_t p = 0; p < size_t(width) * height; ++p) std::fwrite(&pixels[p * 4], 1, 3, out);
    std::fclose(out);
  }
  return coverage > 0 ? 0 : 1;  // an empty frame means the camera missed the scene
}
