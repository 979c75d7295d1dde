// Large arrays backed by transparent huge pages where the kernel offers them (private to rgs_converter).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "rgs/format/encoded_scene.h"
#include "rgs/format/gaussian_cloud.h"

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace rgs::converter::detail {

/// Resizes `v` to `n` zero-initialized elements, asking the kernel (madvise MADV_HUGEPAGE, Linux) to back
/// a fresh allocation with 2 MiB pages before it is first touched: a 100 MB cloud then takes about 50 page
/// faults instead of 25,000, which is most of the cost of allocating it. Only a hint: the contents and
/// the result are the same without it. Throws std::bad_alloc like resize().
template <typename T>
void resize_huge(std::vector<T>& v, size_t n) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr uintptr_t kHugePage = uintptr_t{2} << 20;
  if (v.empty() && n * sizeof(T) >= 2 * kHugePage) {
    v.reserve(n);  // allocates (mmap) without touching the pages
    const uintptr_t begin = reinterpret_cast<uintptr_t>(v.data());
    const uintptr_t end = begin + n * sizeof(T);
    const uintptr_t aligned = (begin + kHugePage - 1) & ~(kHugePage - 1);
    if (end > aligned) (void)::madvise(reinterpret_cast<void*>(aligned), end - aligned, MADV_HUGEPAGE);
  }
#endif
  v.resize(n);
}

/// Sizes every array of `cloud` for `n` Gaussians at its sh_degree through resize_huge (a fresh cloud).
inline void resize_cloud_huge(format::GaussianCloud* cloud, size_t n) {
  resize_huge(cloud->means, n * 3);
  resize_huge(cloud->rotations, n * 4);
  resize_huge(cloud->scales, n * 3);
  resize_huge(cloud->opacities, n);
  resize_huge(cloud->sh, n * cloud->sh_coefficients() * 3);
}

/// `scene`'s count and arrays sized for n Gaussians with `sh_values` SH values each (and the DC residual when
/// `residual`) through resize_huge.
inline void size_sections(format::EncodedScene* scene, uint64_t n, uint64_t sh_values, bool residual) {
  scene->count = n;
  resize_huge(scene->means, n * 3);
  resize_huge(scene->rotations, n * 4);
  resize_huge(scene->scales, n * 3);
  resize_huge(scene->opacities, n);
  resize_huge(scene->sh, n * sh_values);
  resize_huge(scene->sh_dc_residual, residual ? n * 3 : 0);
}

}  // namespace rgs::converter::detail
