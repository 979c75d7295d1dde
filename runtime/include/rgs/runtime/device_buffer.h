// RAII owners of device and pinned host memory for the GPU runtime.
#pragma once

#include <cuda_runtime_api.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>

#include "rgs/format/status.h"
#include "rgs/runtime/cuda_device.h"

namespace rgs::runtime {

/// A typed device allocation (cudaMalloc) of size() elements, freed on destruction. Move-only. Contents are
/// uninitialized after allocation. Growing never preserves contents (the renderer's scratch buffers do not
/// need it).
template <typename T>
class DeviceBuffer {
 public:
  DeviceBuffer() = default;
  ~DeviceBuffer() { release(); }
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;
  DeviceBuffer(DeviceBuffer&& other) noexcept
      : data_(std::exchange(other.data_, nullptr)), size_(std::exchange(other.size_, 0)) {}
  DeviceBuffer& operator=(DeviceBuffer&& other) noexcept {
    if (this != &other) {
      release();
      data_ = std::exchange(other.data_, nullptr);
      size_ = std::exchange(other.size_, 0);
    }
    return *this;
  }

  /// Makes the buffer hold at least `count` elements. When it must grow, the old memory is freed first and
  /// `count + count / 4` elements are allocated (headroom against reallocating every frame), but no more than
  /// max(count, `at_most`). `what` names the buffer in errors: kOutOfMemory "<what>: cannot allocate N bytes
  /// on the GPU (...)", after which the buffer is empty and stays usable; kLimitExceeded when count·sizeof(T)
  /// overflows.
  Status reserve(size_t count, const std::string& what, size_t at_most = SIZE_MAX) {
    if (count <= size_) return Status();
    release();
    const size_t headroom = count / 4;
    const size_t grown = count <= SIZE_MAX / sizeof(T) - headroom ? count + headroom : count;
    return allocate_exactly(std::max(count, std::min(grown, at_most)), what);
  }

  /// As reserve(), without the headroom: for arrays sized by the scene (one entry per Gaussian), which do not
  /// change from frame to frame.
  Status reserve_exact(size_t count, const std::string& what) {
    return count <= size_ ? Status() : allocate_exactly(count, what);
  }

  /// Frees any memory and allocates exactly `count` elements (0 frees only). Errors as reserve().
  Status allocate_exactly(size_t count, const std::string& what) {
    release();
    if (count == 0) return Status();
    if (count > SIZE_MAX / sizeof(T)) {
      return Status(StatusCode::kLimitExceeded, what + ": " + std::to_string(count) + " elements overflow size_t");
    }
    void* p = nullptr;
    const cudaError_t result = cudaMalloc(&p, count * sizeof(T));
    if (result != cudaSuccess) {
      return cuda_status(result, what + ": cannot allocate " + std::to_string(count * sizeof(T)) +
                                     " bytes on the GPU");
    }
    data_ = static_cast<T*>(p);
    size_ = count;
    return Status();
  }

  void release() noexcept {
    if (data_ != nullptr) cudaFree(data_);  // errors ignored: nothing useful to do in a destructor
    data_ = nullptr;
    size_ = 0;
  }

  T* data() const { return data_; }
  size_t size() const { return size_; }
  size_t bytes() const { return size_ * sizeof(T); }

 private:
  T* data_ = nullptr;
  size_t size_ = 0;
};

/// Page-locked host memory (cudaHostAlloc) for asynchronous transfers, freed on destruction. Move-only.
class PinnedBuffer {
 public:
  PinnedBuffer() = default;
  ~PinnedBuffer() { release(); }
  PinnedBuffer(const PinnedBuffer&) = delete;
  PinnedBuffer& operator=(const PinnedBuffer&) = delete;
  PinnedBuffer(PinnedBuffer&& other) noexcept
      : data_(std::exchange(other.data_, nullptr)), bytes_(std::exchange(other.bytes_, 0)) {}
  PinnedBuffer& operator=(PinnedBuffer&& other) noexcept {
    if (this != &other) {
      release();
      data_ = std::exchange(other.data_, nullptr);
      bytes_ = std::exchange(other.bytes_, 0);
    }
    return *this;
  }

  /// Makes the buffer hold at least `bytes` bytes (contents not preserved), allocated with cudaHostAlloc's
  /// `flags` (cudaHostAllocMapped: kernels may also read and write it, at device_pointer()). Errors:
  /// kOutOfMemory, kCudaError.
  Status reserve(size_t bytes, const std::string& what, unsigned flags = cudaHostAllocDefault) {
    if (bytes <= bytes_) return Status();
    release();
    void* p = nullptr;
    const cudaError_t result = cudaHostAlloc(&p, bytes, flags);
    if (result != cudaSuccess) {
      return cuda_status(result, what + ": cannot allocate " + std::to_string(bytes) + " bytes of pinned memory");
    }
    data_ = p;
    bytes_ = bytes;
    return Status();
  }

  void release() noexcept {
    if (data_ != nullptr) cudaFreeHost(data_);
    data_ = nullptr;
    bytes_ = 0;
  }

  void* data() const { return data_; }
  size_t bytes() const { return bytes_; }

  /// The address kernels use for a buffer reserved with cudaHostAllocMapped (cudaHostGetDevicePointer).
  Result<void*> device_pointer() const {
    void* p = nullptr;
    const cudaError_t result = cudaHostGetDevicePointer(&p, data_, 0);
    if (result != cudaSuccess) return cuda_status(result, "pinned host memory: no device address");
    return p;
  }

 private:
  void* data_ = nullptr;
  size_t bytes_ = 0;
};

}  // namespace rgs::runtime
