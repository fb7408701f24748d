// The GPU engine on a CUDA device: the kernels of gpu/kernels.hpp launched as plain CUDA kernels
// (one index per thread), Thrust's CUDA system for sorts, scans and reductions. Compiled only
// when CMake finds a CUDA compiler (BIODEM_WITH_CUDA), with -fmad=false (docs/gpu.md: both
// threads of a pair must compute identical bits, which contraction into FMA does not guarantee).
#include <cuda_runtime.h>
#include <thrust/system/cuda/execution_policy.h>
#include <thrust/system/cuda/vector.h>

#include <cstddef>
#include <cstdint>
#include <iostream>
#include <map>
#include <memory>
#include <string>

#include "core/error.hpp"

namespace biodem::gpu::cuda_device {

template <class F>
__global__ void for_each_index(std::uint32_t n, F f) {
  const std::uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) f(i);
}

/// Temporary storage of Thrust's sorts and reductions, kept between calls: a plain
/// thrust::cuda::par allocates and frees (a device-wide synchronisation) at every reduction,
/// and the engine reduces every few steps.
class CachedAllocator {
 public:
  using value_type = char;
  char* allocate(std::ptrdiff_t n) {
    auto it = free_.lower_bound(n);
    if (it != free_.end()) {
      char* p = it->second;
      used_[p] = it->first;
      free_.erase(it);
      return p;
    }
    void* p = nullptr;
    if (cudaMalloc(&p, static_cast<std::size_t>(n)) != cudaSuccess)
      throw Error("GPU engine: out of device memory (" + std::to_string(n) + " bytes of temporary storage)");
    used_[static_cast<char*>(p)] = n;
    return static_cast<char*>(p);
  }
  void deallocate(char* p, std::size_t) {
    auto it = used_.find(p);
    if (it == used_.end()) return;
    free_.emplace(it->second, p);
    used_.erase(it);
  }
  ~CachedAllocator() {
    for (auto& [n, p] : free_) cudaFree(p);  // errors ignored: the context may be gone at exit
    for (auto& [p, n] : used_) cudaFree(p);
  }

 private:
  std::multimap<std::ptrdiff_t, char*> free_;
  std::map<char*, std::ptrdiff_t> used_;
};

inline CachedAllocator& temporary_storage() {
  static CachedAllocator a;
  return a;
}

/// A CUDA error as biodem::Error (one line), after the last launch.
inline void check_cuda(const char* where) {
  const cudaError_t e = cudaGetLastError();
  if (e != cudaSuccess) throw Error(std::string("GPU engine: CUDA error after ") + where + ": " + cudaGetErrorString(e));
}

struct System {
  template <class T>
  using vector = thrust::cuda::vector<T>;
  static auto exec() { return thrust::cuda::par(temporary_storage()); }
  /// One thread per index, 128 per block (the force kernel uses ~96 registers); no host wait.
  template <class F>
  static void launch(std::uint32_t n, const F& f) {
    constexpr std::uint32_t kBlock = 128;
    for_each_index<<<(n + kBlock - 1) / kBlock, kBlock>>>(n, f);
    check_cuda("a kernel launch");
  }
};

}  // namespace biodem::gpu::cuda_device

#define BIODEM_GPU_NS cuda_device
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
  if (prop.major < 8)
    throw Error(std::string("--device gpu: ") + prop.name + " has compute capability " + std::to_string(prop.major) +
                "." + std::to_string(prop.minor) + "; this build has kernels for 8.0 and 9.0 (set CMAKE_CUDA_ARCHITECTURES)");
  const std::string name = std::string(prop.name) + " (sm_" + std::to_string(prop.major) +
                           std::to_string(prop.minor) + ", " + std::to_string(prop.multiProcessorCount) +
                           " SMs, CUDA)";
  return std::make_unique<Engine>(host, name);
}
}  // namespace biodem::gpu::cuda_device
