// Replays fuzz corpora through a harness without libFuzzer (for the sanitizer build registered
// with CTest): `fuzz_replay_X FILE_OR_DIR...` runs LLVMFuzzerTestOneInput on every file, in
// sorted order. `--make-checkpoint-seed PATH` writes the checkpoint harness's seed file.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#ifdef BIODEM_REPLAY_CHECKPOINT
#include "fuzz_scene.hpp"
#endif

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

int main(int argc, char** argv) {
  namespace fs = std::filesystem;
#ifdef BIODEM_REPLAY_CHECKPOINT
  if (argc == 3 && std::string(argv[1]) == "--make-checkpoint-seed") {
    biodem::fuzz::make_seed_checkpoint(argv[2]);
    return 0;
  }
#endif
  std::vector<fs::path> files;
  for (int a = 1; a < argc; ++a) {
    if (fs::is_directory(argv[a])) {
      for (const auto& e : fs::directory_iterator(argv[a]))
        if (e.is_regular_file()) files.push_back(e.path());
    } else {
      files.emplace_back(argv[a]);
    }
  }
  std::sort(files.begin(), files.end());
  for (const auto& f : files) {
    std::ifstream in(f, std::ios::binary);
    if (!in) {
      std::fprintf(stderr, "%s: cannot read\n", f.c_str());
      return 2;
    }
    const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
  }
  std::printf("replayed %zu inputs without a finding\n", files.size());
  return files.empty() ? 2 : 0;
}
