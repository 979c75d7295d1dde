// Replays fuzz inputs through a target's LLVMFuzzerTestOneInput without libFuzzer, so the corpus runs in
// CTest with any compiler (and under ASan/UBSan with RGS_SANITIZE=ON).
//
//   fuzz_replay_<target> FILE_OR_DIR...
//
// For each file it also replays every prefix length at a stride and a handful of byte flips, which is
// where parsers of untrusted files usually break.
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

namespace {

void replay_file(const std::filesystem::path& path, size_t* runs) {
  std::ifstream in(path, std::ios::binary);
  std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  LLVMFuzzerTestOneInput(bytes.data(), bytes.size());
  ++*runs;
  const size_t stride = bytes.size() / 64 + 1;
  for (size_t n = 0; n < bytes.size(); n += stride) {  // truncations, in a fresh buffer for ASan
    std::vector<uint8_t> prefix(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(n));
    LLVMFuzzerTestOneInput(prefix.data(), prefix.size());
    ++*runs;
  }
  uint32_t state = 0x9e3779b9u;  // fixed seed: deterministic replays
  for (int flip = 0; flip < 64 && !bytes.empty(); ++flip) {
    state = state * 1664525u + 1013904223u;
    std::vector<uint8_t> mutated = bytes;
    mutated[state % mutated.size()] ^= static_cast<uint8_t>(1u << (state >> 29));
    LLVMFuzzerTestOneInput(mutated.data(), mutated.size());
    ++*runs;
  }
}

}  // namespace

int main(int argc, char** argv) {
  size_t runs = 0;
  for (int i = 1; i < argc; ++i) {
    const std::filesystem::path arg(argv[i]);
    if (std::filesystem::is_directory(arg)) {
      for (const auto& entry : std::filesystem::recursive_directory_iterator(arg)) {
        if (entry.is_regular_file()) replay_file(entry.path(), &runs);
      }
    } else {
      replay_file(arg, &runs);
    }
  }
  std::printf("replayed %zu inputs\n", runs);
  return runs > 0 ? 0 : 1;
}
