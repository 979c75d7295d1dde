// SPZ writer: quantizes a float cloud into the SPZ attribute arrays, then wraps them as version 4
// (header, TOC, one zstd stream per array) or as versions 2-3 (one gzip member).
#include "rgs/converter/spz.h"

#include <zlib.h>
#include <zstd.h>

#include <climits>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "../internal_interop.h"
#include "../internal_spz.h"
#include "rgs/format/file_io.h"

namespace rgs::converter {

namespace {

using detail::spz_clamp_byte;

constexpr int kDefaultFractionalBits = 12;
constexpr int32_t kMaxFixed = (1 << 23) - 1;
constexpr double kSqrtHalf = 0.70710678118654752440;

std::string fixed_text(double v, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*g", digits, v);
  return buf;
}

Status check_options(const SpzWriteOptions& o) {
  if (o.version < 2 || o.version > 4) {
    return Status(StatusCode::kInvalidArgument,
                  "SPZ version " + std::to_string(o.version) + " cannot be written (2..4)");
  }
  if (o.sh1_bits < 1 || o.sh1_bits > 8 || o.sh_rest_bits < 1 || o.sh_rest_bits > 8) {
    return Status(StatusCode::kInvalidArgument, "SPZ SH bits " + std::to_string(o.sh1_bits) + "/" +
                                                    std::to_string(o.sh_rest_bits) + " outside 1..8");
  }
  if (o.fractional_bits < -1 || o.fractional_bits > static_cast<int>(detail::kSpzMaxFractionalBits)) {
    return Status(StatusCode::kInvalidArgument, "SPZ fractional bits " + std::to_string(o.fractional_bits) +
                                                    " outside 0..23 (or -1 for automatic)");
  }
  if (o.zstd_level < 1 || o.zstd_level > ZSTD_maxCLevel()) {
    return Status(StatusCode::kInvalidArgument, "zstd level " + std::to_string(o.zstd_level) + " outside 1.." +
                                                    std::to_string(ZSTD_maxCLevel()));
  }
  return Status();
}

/// The SPZ attribute arrays of a cloud.
struct Packed {
  std::vector<uint8_t> arrays[detail::kSpzStreamCount];
};

/// The first 14 header bytes both containers share: magic, version, count, SH degree, fractional bits.
void put_header(uint8_t* h, uint32_t version, const format::GaussianCloud& cloud, int fb) {
  format::store_u32_le(h, detail::kSpzMagic);
  format::store_u32_le(h + 4, version);
  format::store_u32_le(h + 8, static_cast<uint32_t>(cloud.size()));
  h[12] = static_cast<uint8_t>(cloud.sh_degree);
  h[13] = static_cast<uint8_t>(fb);
}

/// Smallest-three rotation code of a unit quaternion (x, y, z, w).
uint32_t encode_smallest_three(const double q_in[4]) {
  int largest = 0;
  for (int i = 1; i < 4; ++i) {
    if (std::fabs(q_in[i]) > std::fabs(q_in[largest])) largest = i;
  }
  const double sign = q_in[largest] < 0 ? -1.0 : 1.0;  // q and −q are the same rotation
  uint32_t comp = static_cast<uint32_t>(largest);
  for (int i = 0; i < 4; ++i) {
    if (i == largest) continue;
    const double v = q_in[i] * sign;
    const double m = std::round(std::fabs(v) / kSqrtHalf * 511.0);
    const uint32_t mag = static_cast<uint32_t>(std::min(m, 511.0));
    comp = (comp << 10) | (static_cast<uint32_t>(v < 0) << 9) | mag;
  }
  return comp;
}

Status pack(const format::GaussianCloud& cloud, const SpzWriteOptions& o, int fb, Packed* p,
            SpzWriteSummary* summary) {
  const size_t n = cloud.size();
  const uint32_t k_count = cloud.sh_coefficients();
  const uint64_t sh_per = detail::spz_sh_bytes(cloud.sh_degree);
  const bool smallest_three = o.version >= 3;
  p->arrays[detail::kSpzPositions].resize(n * 9);
  p->arrays[detail::kSpzAlphas].resize(n);
  p->arrays[detail::kSpzColors].resize(n * 3);
  p->arrays[detail::kSpzScales].resize(n * 3);
  p->arrays[detail::kSpzRotations].resize(n * (smallest_three ? 4 : 3));
  p->arrays[detail::kSpzSh].resize(n * sh_per);
  detail::AxisFlip flip;  // RDF → RUB is the same 180° turn about x as RUB → RDF
  if (o.frame == SpzFrame::kRub) detail::flip_to_rdf("RUB", &flip);
  const float* s = flip.s;
  const double qs[3] = {double{s[1]} * s[2], double{s[0]} * s[2], double{s[0]} * s[1]};
  // SH signs of the flip, as detail::apply_axis_flip computes them.
  format::GaussianCloud probe;
  probe.sh_degree = cloud.sh_degree;
  probe.resize(1);
  for (float& v : probe.sh) v = 1.0f;
  detail::apply_axis_flip(flip, &probe);
  const double scale_fixed = std::ldexp(1.0, fb);
  const uint32_t step1 = 1u << (8 - o.sh1_bits);
  const uint32_t step_rest = 1u << (8 - o.sh_rest_bits);
  uint8_t* pos = p->arrays[detail::kSpzPositions].data();
  uint8_t* alpha = p->arrays[detail::kSpzAlphas].data();
  uint8_t* color = p->arrays[detail::kSpzColors].data();
  uint8_t* scale = p->arrays[detail::kSpzScales].data();
  uint8_t* rot = p->arrays[detail::kSpzRotations].data();
  uint8_t* sh = p->arrays[detail::kSpzSh].data();
  for (size_t i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a) {
      const double v = std::round(static_cast<double>(cloud.means[i * 3 + a]) * s[a] * scale_fixed);
      const int32_t fixed = static_cast<int32_t>(v);  // range checked by the caller
      uint8_t* out = pos + (i * 3 + a) * 3;
      out[0] = static_cast<uint8_t>(fixed & 0xff);
      out[1] = static_cast<uint8_t>((fixed >> 8) & 0xff);
      out[2] = static_cast<uint8_t>((fixed >> 16) & 0xff);
      bool clamped = false;
      const double sc = cloud.scales[i * 3 + a];
      const double log_scale = sc > 0 ? std::log(sc) : -1e30;
      scale[i * 3 + a] = spz_clamp_byte((log_scale + 10.0) * 16.0, &clamped);
      summary->scales_clamped += clamped;
    }
    bool ignored = false;
    alpha[i] = spz_clamp_byte(static_cast<double>(cloud.opacities[i]) * 255.0, &ignored);
    const float* g_sh = cloud.sh.data() + i * k_count * 3;
    for (int c = 0; c < 3; ++c) {
      bool clamped = false;
      color[i * 3 + c] =
          spz_clamp_byte(static_cast<double>(g_sh[c]) * (double{detail::kSpzColorScale} * 255.0) + 127.5, &clamped);
      summary->colors_clamped += clamped;
    }
    for (uint32_t k = 1; k < k_count; ++k) {
      const uint32_t step = k <= 3 ? step1 : step_rest;
      for (int c = 0; c < 3; ++c) {
        const double v = static_cast<double>(g_sh[k * 3 + c]) * probe.sh[k * 3 + c];
        int64_t q = static_cast<int64_t>(std::round(v * 128.0)) + 128;
        if (q < 0 || q > 255) {
          ++summary->sh_clamped;
          q = q < 0 ? 0 : 255;
        }
        q = (q + step / 2) / step * step;  // nearest bucket; 128 (zero) is always one
        sh[i * sh_per + (k - 1) * 3 + c] = static_cast<uint8_t>(q > 255 ? 255 : q);
      }
    }
    // Rotation: normalize in double, flip, reorder (w, x, y, z) → (x, y, z, w).
    const float* g = cloud.rotations.data() + i * 4;
    double n2 = 0;
    for (int a = 0; a < 4; ++a) n2 += static_cast<double>(g[a]) * g[a];
    const double inv = n2 > 0 ? 1.0 / std::sqrt(n2) : 0.0;
    double q[4] = {g[1] * inv * qs[0], g[2] * inv * qs[1], g[3] * inv * qs[2], g[0] * inv};
    if (n2 == 0) q[3] = 1.0;  // a zero quaternion has no rotation to keep; store the identity
    if (smallest_three) {
      format::store_u32_le(rot + i * 4, encode_smallest_three(q));
    } else {
      const double w_sign = q[3] < 0 ? -1.0 : 1.0;  // w is implied non-negative
      for (int a = 0; a < 3; ++a) {
        bool ignored_q = false;
        rot[i * 3 + a] = spz_clamp_byte(q[a] * w_sign * 127.5 + 127.5, &ignored_q);
      }
    }
  }
  return Status();
}

Result<std::vector<uint8_t>> wrap_v4(const SpzWriteOptions& o, const format::GaussianCloud& cloud, int fb,
                                     const Packed& p) {
  std::unique_ptr<ZSTD_CCtx, decltype(&ZSTD_freeCCtx)> cctx(ZSTD_createCCtx(), ZSTD_freeCCtx);
  if (!cctx) return Status(StatusCode::kOutOfMemory, "cannot allocate a zstd compression context");
  std::vector<std::vector<uint8_t>> streams;
  std::vector<uint64_t> raw_sizes;
  for (const auto& a : p.arrays) {
    if (a.empty()) continue;  // zero-size streams are omitted, as the format expects
    ZSTD_CCtx_reset(cctx.get(), ZSTD_reset_session_and_parameters);
    ZSTD_CCtx_setParameter(cctx.get(), ZSTD_c_compressionLevel, o.zstd_level);
    ZSTD_CCtx_setParameter(cctx.get(), ZSTD_c_checksumFlag, 1);
    std::vector<uint8_t> out(ZSTD_compressBound(a.size()));
    const size_t got = ZSTD_compress2(cctx.get(), out.data(), out.size(), a.data(), a.size());
    if (ZSTD_isError(got)) {
      return Status(StatusCode::kOutOfMemory, std::string("zstd compression failed: ") + ZSTD_getErrorName(got));
    }
    out.resize(got);
    streams.push_back(std::move(out));
    raw_sizes.push_back(a.size());
  }
  uint64_t total = detail::kSpzV4HeaderBytes + streams.size() * 16;
  for (const auto& s : streams) total += s.size();
  std::vector<uint8_t> bytes(static_cast<size_t>(total), 0);
  uint8_t* h = bytes.data();
  put_header(h, 4, cloud, fb);
  h[14] = cloud.antialiased ? detail::kSpzFlagAntialiased : 0;  // flags: no extensions
  h[15] = static_cast<uint8_t>(streams.size());
  format::store_u32_le(h + 16, static_cast<uint32_t>(detail::kSpzV4HeaderBytes));
  size_t at = detail::kSpzV4HeaderBytes;
  for (size_t t = 0; t < streams.size(); ++t, at += 16) {
    format::store_u64_le(h + at, streams[t].size());
    format::store_u64_le(h + at + 8, raw_sizes[t]);
  }
  for (const auto& s : streams) {
    std::copy(s.begin(), s.end(), bytes.begin() + static_cast<std::ptrdiff_t>(at));
    at += s.size();
  }
  return bytes;
}

Result<std::vector<uint8_t>> wrap_gzip(const SpzWriteOptions& o, const format::GaussianCloud& cloud, int fb,
                                       const Packed& p) {
  std::vector<uint8_t> plain(detail::kSpzLegacyHeaderBytes, 0);
  put_header(plain.data(), o.version, cloud, fb);
  for (const auto& a : p.arrays) plain.insert(plain.end(), a.begin(), a.end());
  z_stream zs{};
  // windowBits 16 + 15: gzip wrapper; zlib writes no file name and a zero timestamp.
  if (deflateInit2(&zs, 9, Z_DEFLATED, 16 + MAX_WBITS, 9, Z_DEFAULT_STRATEGY) != Z_OK) {
    return Status(StatusCode::kOutOfMemory, "cannot initialize zlib deflate");
  }
  std::vector<uint8_t> out(deflateBound(&zs, static_cast<uLong>(plain.size())) + 64);
  zs.next_in = plain.data();
  zs.avail_in = static_cast<uInt>(plain.size());
  zs.next_out = out.data();
  zs.avail_out = static_cast<uInt>(out.size());
  const int r = deflate(&zs, Z_FINISH);
  const size_t produced = out.size() - zs.avail_out;
  deflateEnd(&zs);
  if (r != Z_STREAM_END)
    return Status(StatusCode::kOutOfMemory, "zlib deflate failed (code " + std::to_string(r) + ")");
  out.resize(produced);
  return out;
}

Result<std::vector<uint8_t>> serialize(const format::GaussianCloud& cloud, const SpzWriteOptions& o,
                                       SpzWriteSummary* summary) {
  RGS_RETURN_IF_ERROR(check_options(o));
  RGS_RETURN_IF_ERROR(detail::check_writable_cloud(cloud));
  if (cloud.size() > static_cast<size_t>(INT32_MAX)) {
    return Status(StatusCode::kInvalidArgument, std::to_string(cloud.size()) +
                                                    " Gaussians exceed the 2^31 − 1 that SPZ readers accept");
  }
  if (o.version < 4 && cloud.size() * 64 > UINT_MAX) {
    return Status(StatusCode::kInvalidArgument, "gzip-wrapped SPZ is limited to 4 GiB of arrays; write version 4");
  }
  double max_abs = 0;
  for (float v : cloud.means) max_abs = std::max(max_abs, std::fabs(static_cast<double>(v)));
  auto fits = [&](int fb) { return std::round(max_abs * std::ldexp(1.0, fb)) <= kMaxFixed; };
  int fb = o.fractional_bits;
  if (fb < 0) {
    fb = kDefaultFractionalBits;
    while (fb > 0 && !fits(fb)) --fb;
  }
  if (!fits(fb)) {
    return Status(StatusCode::kInvalidArgument,
                  "a coordinate of magnitude " + fixed_text(max_abs, 9) + " does not fit SPZ's 24-bit positions at " +
                      std::to_string(fb) + " fractional bits (largest: " +
                      fixed_text(kMaxFixed / std::ldexp(1.0, fb), 9) + ")");
  }
  *summary = SpzWriteSummary{};
  summary->version = o.version;
  summary->sh_degree = cloud.sh_degree;
  summary->fractional_bits = static_cast<uint32_t>(fb);
  summary->position_step = std::ldexp(1.0, -fb);
  Packed packed;
  RGS_RETURN_IF_ERROR(pack(cloud, o, fb, &packed, summary));
  Result<std::vector<uint8_t>> bytes = o.version >= 4 ? wrap_v4(o, cloud, fb, packed) : wrap_gzip(o, cloud, fb, packed);
  if (!bytes.ok()) return bytes;
  summary->bytes = bytes->size();
  auto& l = summary->limitations;
  l.push_back("positions: 24-bit fixed point with " + std::to_string(fb) + " fractional bits, step " +
              fixed_text(summary->position_step, 6) + " (error up to half a step per axis)");
  l.push_back("scales: 8-bit ln(scale) in steps of 1/16 over [-10, 5.94] (relative error up to 3.2 %)");
  l.push_back(o.version >= 3 ? "rotations: smallest three, 9-bit magnitudes (about 0.1 degree)"
                             : "rotations: x, y, z as 8 bits each (about 1 degree)");
  l.push_back("opacity: 8 bits (step 1/255)");
  l.push_back("DC colour: 8 bits over f_dc in [-3.33, 3.33] (step 0.026)");
  if (cloud.sh_degree > 0) {
    l.push_back("SH rest: " + std::to_string(o.sh1_bits) + " bits (degree 1), " + std::to_string(o.sh_rest_bits) +
                " bits (degrees 2-3) over [-1, 1)");
  }
  l.push_back(spz_frame_note(o.frame, /*writing=*/true));
  return bytes;
}

}  // namespace

Result<std::vector<uint8_t>> serialize_spz(const format::GaussianCloud& cloud, const SpzWriteOptions& options,
                                           SpzWriteSummary* summary) {
  return detail::serialize_guarded("encoding SPZ", summary, [&](auto* s) { return serialize(cloud, options, s); });
}

Result<SpzWriteSummary> write_spz(const std::string& path, const format::GaussianCloud& cloud,
                                  const SpzWriteOptions& options, format::FileSink& files) {
  return detail::write_serialized<SpzWriteSummary>(path, "encoding SPZ", files,
                                                   [&](auto* s) { return serialize(cloud, options, s); });
}

}  // namespace rgs::converter
