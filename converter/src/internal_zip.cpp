// ZIP archives read through libzip: the end record, central directory and local headers are libzip's; what
// is ours is the hostile-file policy (sizes the archive's bytes cannot produce are refused before allocating)
// and the errors' codes.
#include "internal_zip.h"

#include <unistd.h>
#include <zip.h>

#include <new>

#include "internal_input_file.h"
#include "internal_interop.h"

namespace rgs::converter::detail {

namespace {

/// `error` as a Status naming `where`.
Status zip_status(zip_error_t* error, const std::string& where) {
  StatusCode code = StatusCode::kCorruptData;
  switch (zip_error_code_zip(error)) {
    case ZIP_ER_MEMORY: code = StatusCode::kOutOfMemory; break;
    case ZIP_ER_CRC: code = StatusCode::kChecksumMismatch; break;
    case ZIP_ER_MULTIDISK:
    case ZIP_ER_COMPNOTSUPP:
    case ZIP_ER_ENCRNOTSUPP: code = StatusCode::kUnsupportedFeature; break;
    case ZIP_ER_OPEN:
    case ZIP_ER_READ:
    case ZIP_ER_SEEK: code = StatusCode::kIoError; break;
    default: break;
  }
  if (zip_error_code_zip(error) == ZIP_ER_NOZIP) {
    return Status(code, where + ": no ZIP end-of-central-directory record (truncated archive?)");
  }
  const char* what = code == StatusCode::kCorruptData ? "damaged ZIP data" : "cannot read the ZIP data";
  return Status(code, where + ": " + what + " (libzip: " + zip_error_strerror(error) + ")");
}

Status zip_status(int code, const std::string& where) {
  zip_error_t error;
  zip_error_init_with_code(&error, code);
  Status s = zip_status(&error, where);
  zip_error_fini(&error);
  return s;
}

}  // namespace

bool has_zip_magic(const uint8_t* data, size_t size) {
  if (size < 4) return false;
  const uint32_t sig = format::load_u32_le(data);
  return sig == 0x04034b50 || sig == 0x06054b50;
}

Result<ZipArchive> ZipArchive::open(const uint8_t* data, size_t size, const std::string& name) {
  ZipArchive archive;
  archive.size_ = size;
  archive.name_ = name;
  zip_error_t error;
  zip_error_init(&error);
  zip_source_t* src = zip_source_buffer_create(data, size, 0, &error);
  zip_t* z = src == nullptr ? nullptr : zip_open_from_source(src, ZIP_RDONLY, &error);
  if (z == nullptr) {
    zip_source_free(src);
    Status s = zip_status(&error, name);
    zip_error_fini(&error);
    return s;
  }
  archive.zip_.reset(z, zip_discard);
  const zip_int64_t n = zip_get_num_entries(z, 0);
  for (zip_int64_t i = 0; i < n; ++i) {
    zip_stat_t st;
    if (zip_stat_index(z, static_cast<zip_uint64_t>(i), ZIP_FL_ENC_RAW, &st) != 0) {
      return zip_status(zip_get_error(z), name + ": ZIP entry " + std::to_string(i));
    }
    archive.entries_.push_back({st.name != nullptr ? st.name : "", static_cast<uint64_t>(i), st.comp_method,
                                st.encryption_method != ZIP_EM_NONE, st.comp_size, st.size});
  }
  return archive;
}

Result<std::vector<std::string>> ZipArchive::list(const std::string& path) {
  int fd = -1;
  uint64_t size = 0;
  RGS_RETURN_IF_ERROR(open_regular(path, &fd, &size));
  int code = ZIP_ER_OK;
  zip_t* z = zip_fdopen(fd, ZIP_RDONLY, &code);  // owns fd once it succeeds
  if (z == nullptr) {
    ::close(fd);
    return zip_status(code, path);
  }
  std::vector<std::string> names;
  const zip_int64_t n = zip_get_num_entries(z, 0);
  for (zip_int64_t i = 0; i < n; ++i) {
    const char* name = zip_get_name(z, static_cast<zip_uint64_t>(i), ZIP_FL_ENC_RAW);
    names.emplace_back(name != nullptr ? name : "");
  }
  zip_discard(z);
  return names;
}

const ZipEntry* ZipArchive::find(const std::string& name) const {
  for (const ZipEntry& e : entries_) {
    if (e.name == name) return &e;
  }
  return nullptr;
}

Status ZipArchive::extract(const ZipEntry& entry, uint64_t max_bytes, std::vector<uint8_t>* out) const {
  const std::string where = name_ + ": ZIP entry '" + entry.name + "'";
  if (entry.encrypted) return Status(StatusCode::kUnsupportedFeature, where + " is encrypted");
  if (entry.method != ZIP_CM_STORE && entry.method != ZIP_CM_DEFLATE) {
    return Status(StatusCode::kUnsupportedFeature, where + " uses compression method " + std::to_string(entry.method) +
                                                       " (supported: 0 stored, 8 deflate)");
  }
  RGS_RETURN_IF_ERROR(check_limit(where + " is ", entry.uncompressed_size, "bytes", max_bytes));
  // A stored entry is its bytes, and deflate expands at most 1032:1 (RFC 1951: a 258-byte match costs at
  // least 2 bits); neither holds more bytes than the archive.
  if (entry.compressed_size > size_ || (entry.method == ZIP_CM_STORE && entry.compressed_size != entry.uncompressed_size) ||
      entry.uncompressed_size / 1032 > entry.compressed_size) {
    return Status(StatusCode::kCorruptData, where + " claims " + std::to_string(entry.uncompressed_size) +
                                                " bytes from " + std::to_string(entry.compressed_size) +
                                                (entry.method == ZIP_CM_STORE ? " stored" : " deflated") +
                                                " bytes of a " + std::to_string(size_) + "-byte archive");
  }
  const uint64_t bytes = entry.uncompressed_size;
  RGS_RETURN_IF_ERROR(catch_bad_alloc([&] { out->resize(static_cast<size_t>(bytes)); return Status(); },
                                      [&] { return where + ": cannot allocate " + std::to_string(bytes) + " bytes"; }));
  zip_file_t* file = zip_fopen_index(zip_.get(), entry.index, 0);
  if (file == nullptr) return zip_status(zip_get_error(zip_.get()), where);
  // Reading past the declared size ends the stream, where libzip checks the CRC-32 and the size (or reports
  // the error that cut a short read).
  const zip_int64_t got = zip_fread(file, out->data(), out->size());
  uint8_t more = 0;
  const zip_int64_t extra = got < 0 ? 0 : zip_fread(file, &more, 1);
  Status s;
  if (got < 0 || extra < 0 || zip_error_code_zip(zip_file_get_error(file)) != ZIP_ER_OK) {
    s = zip_status(zip_file_get_error(file), where);
  } else if (got != static_cast<zip_int64_t>(out->size()) || extra != 0) {
    s = Status(StatusCode::kCorruptData, where + " does not hold the declared " +
                                             std::to_string(entry.uncompressed_size) + " bytes");
  }
  zip_fclose(file);
  return s;
}

}  // namespace rgs::converter::detail
