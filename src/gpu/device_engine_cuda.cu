// The GPU engine on a CUDA device: the kernels of gpu/kernels.hpp launched through Thrust's CUDA
// system. Compiled only when CMake finds a CUDA compiler (BIODEM_WITH_CUDA).
#include <cuda_runtime.h>
#include <thrust/for_each.h>
#include <thrust/iterator/counting_iterator.h>
#include <thrust/system/cuda/execution_policy.h>
#include <thrust/system/cuda/vector.h>

#include <cstdint>
#include <memory>
#include <string>

#include "core/error.hpp"

#define BIODEM_GPU_NS cuda_device
namespace biodem::gpu::cuda_device {
struct System {
  template <class T>
  using vector = thrust::cuda::vector<T>;
  static auto exec() { return thrust::cuda::par; }
  template <class F>
  static void launch(std::uint32_t n, const F& f) {  // does not wait for the GPU
    thrust::for_each_n(thrust::cuda::par_nosync, thrust::counting_iterator<std::uint32_t>(0), n, f);
  }
};
}  // namespace biodem::gpu::cuda_device
#include "gpu/engine_impl.hpp"

namespace biodem::gpu::cuda_device {
std::unique_ptr<DeviceEngine> make_engine(sim::Simulation& host) {
  int count = 0;
  const cudaError_t err = cudaGetDeviceCount(&count);
  if (err != cudaSuccess || count == 0)
    throw Error(std::string("--device gpu: no CUDA-capable GPU found (") +
                (err != cudaSuccess ? cudaGetErrorString(err) : "no device") + ")");
  int dev = 0;
  cudaDeviceProp prop{};
  if (cudaGetDevice(&dev) != cudaSuccess || cudaGetDeviceProperties(&prop, dev) != cudaSuccess)
    throw Error("--device gpu: cannot query the CUDA device");
  const std::string name = std::string(prop.name) + " (sm_" + std::to_string(prop.major) +
                           std::to_string(prop.minor) + ", " + std::to_string(prop.multiProcessorCount) +
                           " SMs, CUDA)";
  return std::make_unique<Engine>(host, name);
}
}  // namespace biodem::gpu::cuda_device
