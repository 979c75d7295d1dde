# Third-party dependencies, all Debian packages (see README "Dependencies").
find_package(PkgConfig REQUIRED)

# zstd: the Debian CMake config exports libzstd_shared / libzstd_static. The shared library first: Debian's
# static archive is built without zstd's worker threads, which compress a large frame's jobs in parallel
# (format/SPEC.md 7).
find_package(zstd CONFIG QUIET)
if(TARGET zstd::libzstd_shared)
  set(RGS_ZSTD_TARGET zstd::libzstd_shared)
elseif(TARGET zstd::libzstd_static)
  set(RGS_ZSTD_TARGET zstd::libzstd_static)
else()
  pkg_check_modules(RGS_ZSTD REQUIRED IMPORTED_TARGET libzstd)
  set(RGS_ZSTD_TARGET PkgConfig::RGS_ZSTD)
endif()

# liblzma (Debian liblzma-dev): the .xz streams of the archive's quantized codes (format/SPEC.md 3.3.2), shared
# like zstd (Debian's static archive is not position-independent).
find_package(LibLZMA REQUIRED)

# xxHash has no CMake config on Debian 12; link the static archive so GPU binaries stay self-contained.
find_path(RGS_XXHASH_INCLUDE_DIR xxhash.h REQUIRED)
find_library(RGS_XXHASH_LIBRARY NAMES libxxhash.a xxhash REQUIRED)
add_library(rgs_xxhash INTERFACE)
target_include_directories(rgs_xxhash INTERFACE "$<BUILD_INTERFACE:${RGS_XXHASH_INCLUDE_DIR}>")
target_link_libraries(rgs_xxhash INTERFACE "$<BUILD_INTERFACE:${RGS_XXHASH_LIBRARY}>")

# Draco (Debian libdraco-dev) codes the means of the archive profile (format/SPEC.md 3.3.1). Linked from its
# static archive so GPU binaries need no libdraco shared library.
find_path(RGS_DRACO_INCLUDE_DIR draco/compression/decode.h REQUIRED)
find_library(RGS_DRACO_LIBRARY NAMES libdraco.a draco REQUIRED)
add_library(rgs_draco INTERFACE)
target_include_directories(rgs_draco SYSTEM INTERFACE "$<BUILD_INTERFACE:${RGS_DRACO_INCLUDE_DIR}>")
target_link_libraries(rgs_draco INTERFACE "$<BUILD_INTERFACE:${RGS_DRACO_LIBRARY}>")

# zlib: gzip-wrapped SPZ versions 2 and 3 and the bundled .sog writer's CRC-32 (rgs_converter; the converter tests
# also make gzip inputs with it).
find_package(ZLIB REQUIRED)
# libzip (Debian libzip-dev) reads the bundled .sog archives. Debian ships only its shared library: binaries need
# libzip.so.4, which scripts/stage_gpu.sh puts beside them for the GPU host. Its CMake config names tools of
# another package (zipcmp), so it is found by its files.
find_path(RGS_LIBZIP_INCLUDE_DIR zip.h REQUIRED)
find_library(RGS_LIBZIP_LIBRARY NAMES zip REQUIRED)
# nlohmann-json (header only): the converter reads SOG meta.json / lod-meta.json and glTF; the tools write JSON.
find_package(nlohmann_json CONFIG REQUIRED)
if(RGS_BUILD_TOOLS)
  find_package(CLI11 CONFIG REQUIRED)
endif()

# libwebp decodes the SOG images and zlib inflates gzip-wrapped SPZ (Debian libwebp-dev, zlib1g-dev). Both are
# linked from their static archives when those exist, so binaries that run on the GPU host need no shared
# libraries beyond libc/libstdc++ (and libzip); installed consumers link them by name.
find_path(RGS_WEBP_INCLUDE_DIR webp/decode.h REQUIRED)
find_library(RGS_WEBP_LIBRARY NAMES libwebp.a webp REQUIRED)
find_path(RGS_ZLIB_INCLUDE_DIR zlib.h REQUIRED)
find_library(RGS_ZLIB_LIBRARY NAMES libz.a z REQUIRED)
find_package(Threads REQUIRED)

# The viewer (rgs-view, view/): Boost.Beast and Asio (header-only, Debian libboost-dev) and libturbojpeg (Debian
# libturbojpeg0-dev; its static archive, so that the GPU host needs no libturbojpeg). RGS_BUILD_VIEWER defaults
# to whether both are found.
find_package(Boost 1.74 QUIET)
find_path(RGS_TURBOJPEG_INCLUDE_DIR turbojpeg.h)
find_library(RGS_TURBOJPEG_LIBRARY NAMES libturbojpeg.a turbojpeg)
if(Boost_FOUND AND RGS_TURBOJPEG_INCLUDE_DIR AND RGS_TURBOJPEG_LIBRARY)
  set(RGS_VIEWER_DEPENDENCIES_FOUND ON)
else()
  set(RGS_VIEWER_DEPENDENCIES_FOUND OFF)
endif()

if(RGS_BUILD_TESTS)
  find_package(doctest CONFIG REQUIRED)
  include(doctest)  # doctest_discover_tests()
endif()
