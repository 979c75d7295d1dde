// Stage 1 of the 3DGS baseline: per-Gaussian projection (3DGS preprocessCUDA). The math is the CPU
// reference's (runtime/src/cpu_renderer.cpp preprocess_cpu), step for step, through kernels/shared/.
#include "launch_util.cuh"
#include "rgs/kernels/baseline_pipeline.h"
#include "rgs/kernels/shared/projection.h"
#include "rgs/kernels/shared/spherical_harmonics.h"

namespace rgs::kernels {
namespace {

__global__ void __launch_bounds__(detail::kBlockSize)
    preprocess_baseline_kernel(Fp32GaussiansView g, FrameParams frame, ProjectedArrays out) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= g.count) return;
  out.radii[i] = 0;
  out.tiles_touched[i] = 0;

  // View transform; cull at the near plane (NaN too).
  const float mean[3] = {g.means[3 * i], g.means[3 * i + 1], g.means[3 * i + 2]};
  float p_cam[3];
  world_to_camera(frame.view_rotation, frame.view_translation, mean, p_cam);
  if (!(p_cam[2] > frame.near_plane)) return;

  // Σ = R·S·Sᵀ·Rᵀ, EWA 2D covariance with the Jacobian clamp and the 0.3 dilation.
  const float scale[3] = {g.scales[3 * i], g.scales[3 * i + 1], g.scales[3 * i + 2]};
  const float q[4] = {g.rotations[4 * i], g.rotations[4 * i + 1], g.rotations[4 * i + 2], g.rotations[4 * i + 3]};
  float cov3d[6];
  covariance_3d(scale, q, cov3d);
  const Cov2 cov = ewa_covariance_2d(cov3d, frame.view_rotation, p_cam, frame.fx, frame.fy, frame.ewa_clamp);

  // Cull only det == 0; conic; radius; pixel mean; tile rectangle.
  const float det = determinant(cov);
  if (det == 0.f) return;
  const Conic conic = conic_from_covariance(cov, det);
  const int radius = screen_radius(cov, det);
  float px, py;
  project_to_pixel(p_cam, frame.fx, frame.fy, frame.cx, frame.cy, &px, &py);
  if (!isfinite(px) || !isfinite(py) || !isfinite(conic.a) || !isfinite(conic.b) || !isfinite(conic.c)) return;
  const TileRect rect = rows_of_pass(tile_rect(px, py, radius, int(frame.tiles_x), int(frame.tiles_y)), frame);
  const int area = tile_area(rect);
  if (area == 0) return;

  // Colour from SH along dir = normalize(mean − camera centre).
  float dir[3] = {mean[0] - frame.camera_centre[0], mean[1] - frame.camera_centre[1],
                  mean[2] - frame.camera_centre[2]};
  const float length = sqrtf(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
  for (float& d : dir) d = d / length;
  const uint64_t sh_stride = uint64_t(sh_coefficients_for(int(g.sh_degree))) * 3;
  float rgb[3];
  sh_to_colour(g.sh + i * sh_stride, int(g.sh_degree), dir[0], dir[1], dir[2], rgb);

  float opacity = g.opacities[i];
  if (frame.antialiased) opacity *= antialias_compensation(cov, det);
  out.depths[i] = p_cam[2];
  out.means2d[2 * i] = px;
  out.means2d[2 * i + 1] = py;
  reinterpret_cast<float4*>(out.conic_opacity)[i] = make_float4(conic.a, conic.b, conic.c, opacity);
  out.rgb[3 * i] = rgb[0];
  out.rgb[3 * i + 1] = rgb[1];
  out.rgb[3 * i + 2] = rgb[2];
  out.radii[i] = radius;
  out.tiles_touched[i] = uint64_t(area);
}

}  // namespace

cudaError_t preprocess_baseline(const Fp32GaussiansView& gaussians, const FrameParams& frame,
                                const ProjectedArrays& out, cudaStream_t stream) {
  if (gaussians.count == 0) return cudaSuccess;
  preprocess_baseline_kernel<<<detail::blocks_for(gaussians.count), detail::kBlockSize, 0, stream>>>(gaussians,
                                                                                                     frame, out);
  return detail::launch_result();
}

}  // namespace rgs::kernels
