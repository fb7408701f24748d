// The GPU engine on CPU threads: the kernels of gpu/kernels.hpp launched through Thrust's OpenMP
// system. Slow next to the CPU engine (full neighbour list, every contact evaluated twice); it
// exists so that the GPU engine's physics runs in the tests on machines without a GPU.
#include <thrust/system/omp/execution_policy.h>
#include <thrust/system/omp/vector.h>

#include <memory>

#define BIODEM_GPU_NS host_threads
namespace biodem::gpu::host_threads {
struct System {
  template <class T>
  using vector = thrust::omp::vector<T>;
  static auto exec() { return thrust::omp::par; }
  static auto exec_async() { return thrust::omp::par; }
};
}  // namespace biodem::gpu::host_threads
#include "gpu/engine_impl.hpp"

namespace biodem::gpu::host_threads {
std::unique_ptr<DeviceEngine> make_engine(sim::Simulation& host) {
  return std::make_unique<Engine>(host, "CPU threads (the GPU engine's kernels through Thrust's OpenMP system)");
}
}  // namespace biodem::gpu::host_threads
