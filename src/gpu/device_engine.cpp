#include "gpu/device_engine.hpp"

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

std::unique_ptr<DeviceEngine> make_device_engine(Backend backend, sim::Simulation& host) {
  // What the GPU engine does not do yet stops the run before anything is computed.
  for (std::size_t w = 0; w < host.walls().size(); ++w)
    if (host.walls()[w].translates())
      throw Error("--device gpu: wall " + std::to_string(w + 1) +
                  " translates; the GPU engine runs rotating and fixed walls only (use --device cpu)");
  if (!host.sinks().empty())
    throw Error("--device gpu: the case has [[sink]] regions; the GPU engine does not remove bodies yet (use --device cpu)");
  if (backend == Backend::HostThreads) return host_threads::make_engine(host);
#ifdef BIODEM_WITH_CUDA
  return cuda_device::make_engine(host);
#else
  throw Error("--device gpu: this biodem was built without the CUDA engine (no CUDA compiler at configure time; see docs/gpu.md)");
#endif
}

}  // namespace biodem::gpu
