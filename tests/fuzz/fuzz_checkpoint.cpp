// libFuzzer harness for the checkpoint reader (issue 10, item 8). A checkpoint carries a 64-bit
// checksum, so random bytes almost never get past it; inputs whose first byte is odd are
// therefore wrapped into a well-formed file (magic, version, size, checksum) around the rest of
// the bytes, which puts the fuzzer on the payload decoder. A loaded checkpoint is then stepped,
// as a resumed run would be. Every rejected input must be a biodem::Error with a one-line message.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "core/error.hpp"
#include "fuzz_scene.hpp"
#include "checkpoint/checkpoint.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::vector<char> bytes;
  if (size > 0 && (data[0] & 1)) {
    static const char magic[8] = {'B', 'I', 'O', 'D', 'E', 'M', 'C', 'K'};
    const std::uint32_t version = biodem::checkpoint::kCheckpointVersion;
    const std::uint64_t n = size - 1;
    const std::uint64_t sum = biodem::checkpoint::fnv1a(data + 1, n);
    bytes.insert(bytes.end(), magic, magic + 8);
    bytes.insert(bytes.end(), reinterpret_cast<const char*>(&version), reinterpret_cast<const char*>(&version) + 4);
    bytes.insert(bytes.end(), reinterpret_cast<const char*>(&n), reinterpret_cast<const char*>(&n) + 8);
    bytes.insert(bytes.end(), reinterpret_cast<const char*>(data + 1), reinterpret_cast<const char*>(data + size));
    bytes.insert(bytes.end(), reinterpret_cast<const char*>(&sum), reinterpret_cast<const char*>(&sum) + 8);
  } else {
    bytes.assign(reinterpret_cast<const char*>(data), reinterpret_cast<const char*>(data) + size);
  }
  biodem::sim::Simulation sim = biodem::fuzz::make_scene();
  try {
    (void)biodem::checkpoint::load_checkpoint_bytes(bytes, "fuzz.ckpt", sim);
    for (int k = 0; k < 3; ++k) sim.step();  // a resumed run goes on stepping
  } catch (const biodem::Error& e) {
    const char* m = e.what();
    if (std::strchr(m, '\n') != nullptr || m[0] == '\0') {
      std::fprintf(stderr, "error message is not one line: [%s]\n", m);
      std::abort();
    }
  }
  return 0;
}
