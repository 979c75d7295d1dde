// k-means for the SOG writer's codebooks and SH palette (private to rgs_converter). Deterministic: the
// result depends only on the values and the parameters, never on the thread count.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "rgs/format/status.h"

namespace rgs::converter::detail {

/// A 1-D codebook of `k` ascending entries for `values[0, n)` (finite): Lloyd's iterations on a 65,536-bin
/// histogram of the values (bin members stand at their bin's mean), started from the histogram's quantiles.
/// Entries of empty clusters keep their place, so the codebook always has `k` entries.
std::vector<float> kmeans_codebook(const float* values, size_t n, uint32_t k, uint32_t iterations);

/// Index of the entry of `codebook` (ascending) nearest to `v` (ties to the lower one).
uint8_t nearest_code(const std::vector<float>& codebook, float v);

/// A palette of at most `k` vectors of `dim` floats for the vectors `data[i·stride + d]`, i < n <= 2^32 - 1,
/// d < dim, and each vector's palette index in `labels` (size n). Equal vectors count as one, weighted by how
/// many hold it; when k covers the distinct vectors they are the palette (exact). Else tree-structured: ceil(√k)
/// coarse clusters, each split into fine clusters in proportion to the vectors it holds (at most its distinct
/// ones); both levels are trained by Lloyd's iterations on evenly spaced samples of the distinct vectors, then
/// every vector takes the nearest coarse, then the nearest fine centroid in it.
/// `palette` is [entries, dim] float32, entries <= k. Errors: kOutOfMemory.
Status kmeans_palette(const float* data, size_t n, size_t stride, uint32_t dim, uint32_t k, uint32_t iterations,
                      std::vector<float>* palette, std::vector<uint32_t>* labels);

}  // namespace rgs::converter::detail
