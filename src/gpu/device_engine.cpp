#include "gpu/device_engine.hpp"

#include <cstdlib>
#include <string>

#include "core/error.hpp"

namespace biodem::gpu {

namespace host_threads {
std::unique_ptr<DeviceEngine> make_engine(sim::Simulation& host);
}
#ifdef BIODEM_WITH_CUDA
namespace cuda_device {
std::unique_ptr<DeviceEngine> make_engine(sim::Simulation& host);
}
#endif

bool cuda_built() {
#ifdef BIODEM_WITH_CUDA
  return true;
#else
  return false;
#endif
}

LaunchSwitches launch_switches() {
  LaunchSwitches sw;
  if (const char* b = std::getenv("BIODEM_GPU_BLOCK"); b && *b) {
    const std::string v(b);
    if (v != "32" && v != "64" && v != "128" && v != "256" && v != "512")
      throw Error("BIODEM_GPU_BLOCK = '" + v + "': expected 32, 64, 128, 256 or 512 threads per block");
    sw.block = static_cast<std::uint32_t>(std::stoul(v));
  }
  if (const char* l = std::getenv("BIODEM_GPU_ROW_LANES"); l && *l) {
    const std::string v(l);
    const char* const allowed[] = {"1", "2", "4", "8", "16", "32"};
    std::uint32_t log2 = 0;
    while (log2 < 6 && v != allowed[log2]) ++log2;
    if (log2 == 6) throw Error("BIODEM_GPU_ROW_LANES = '" + v + "': expected 1, 2, 4, 8, 16 or 32 lanes per row walk");
    sw.row_lanes_log2 = log2;
  }
  if (const char* p = std::getenv("BIODEM_GPU_PDL"); p && *p) {
    const std::string v(p);
    if (v != "0" && v != "1") throw Error("BIODEM_GPU_PDL = '" + v + "': expected 0 or 1");
    sw.pdl = v == "1";
  }
  if (const char* l = std::getenv("BIODEM_GPU_BUILD_LANES"); l && *l) {
    const std::string v(l);
    const char* const allowed[] = {"1", "2", "4", "8", "16", "32"};
    std::uint32_t log2 = 0;
    while (log2 < 6 && v != allowed[log2]) ++log2;
    if (log2 == 6)
      throw Error("BIODEM_GPU_BUILD_LANES = '" + v + "': expected 1, 2, 4, 8, 16 or 32 lanes per row of a list build");
    sw.build_lanes_log2 = log2;
  }
  return sw;
}

std::unique_ptr<DeviceEngine> make_device_engine(Backend backend, sim::Simulation& host) {
  (void)launch_switches();  // checked for both backends (the CUDA engine applies them)
  // What the GPU engine does not do yet stops the run before anything is computed.
  if (host.walls().size() > kMaxDeviceWalls)
    throw Error("--device gpu: the scene has " + std::to_string(host.walls().size()) +
                " walls; the GPU engine tests every wall for every sphere and takes at most " +
                std::to_string(kMaxDeviceWalls) + " (use --device cpu)");
  if (backend == Backend::HostThreads) return host_threads::make_engine(host);
#ifdef BIODEM_WITH_CUDA
  return cuda_device::make_engine(host);
#else
  throw Error("--device gpu: this biodem was built without the CUDA engine (no CUDA compiler at configure time; see docs/gpu.md)");
#endif
}

}  // namespace biodem::gpu
