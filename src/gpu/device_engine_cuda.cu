// The GPU engine on a CUDA device: the kernels of gpu/kernels.hpp launched as plain CUDA kernels
// (one index per thread), Thrust's CUDA system for sorts, scans and reductions. Compiled only
// when CMake finds a CUDA compiler (BIODEM_WITH_CUDA), with -fmad=false (docs/gpu.md: both
// threads of a pair must compute identical bits, which contraction into FMA does not guarantee).
#include <cuda_runtime.h>
#include <thrust/iterator/counting_iterator.h>
#include <thrust/iterator/transform_iterator.h>
#include <thrust/system/cuda/execution_policy.h>
#include <cub/device/device_reduce.cuh>
#include <thrust/mr/allocator.h>
#include <thrust/system/cuda/memory_resource.h>
#include <thrust/system/cuda/vector.h>
#include <thrust/system/cuda/error.h>
#include <thrust/system_error.h>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <iostream>
#include <map>
#include <memory>
#include <new>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "gpu/device_engine.hpp"

namespace biodem::gpu::cuda_device {

/// The largest block of the one-index kernels (BIODEM_GPU_BLOCK's largest value): the compiler
/// keeps every kernel within the registers that allow it (without the bound the per-sphere sums
/// took ~140 registers on sm_90, and a block of 512 could not launch).
inline constexpr int kMostThreadsPerBlock = 512;
/// Shared memory of a block of the grouped list build (the default limit without opting in).
inline constexpr std::uint32_t kRowBuildSharedBytes = 48 * 1024;

/// Programmatic dependent launch (sm_90; System::launch with pdl_launch()): a kernel launched
/// with it may be scheduled while the kernel before it on the stream still runs. Every kernel of
/// the engine's step first waits here until the kernels before it have completed and their
/// memory is visible (griddepcontrol.wait; it returns at once for a kernel launched without the
/// attribute), and only then lets the kernel after it be scheduled (launch_dependents), which in
/// turn waits for this one's completion. So every load and store of a kernel still comes after
/// all of the kernel before it: the same order of memory effects as plain launches, the same
/// bits; what overlaps is the next kernel's launch and block scheduling.
__device__ __forceinline__ void after_previous_kernel() {
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 900
  asm volatile("griddepcontrol.wait;" ::: "memory");
  asm volatile("griddepcontrol.launch_dependents;" ::: "memory");
#endif
}

template <class F>
__global__ void __launch_bounds__(kMostThreadsPerBlock) for_each_index(std::uint32_t n, F f) {
  after_previous_kernel();
  const std::uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) f(i);
}

inline cudaStream_t engine_stream();

/// The errors that leave the CUDA context unusable (a kernel faulted): every later call fails.
inline bool context_lost(cudaError_t e) {
  switch (e) {
    case cudaErrorIllegalAddress:
    case cudaErrorLaunchFailure:
    case cudaErrorIllegalInstruction:
    case cudaErrorMisalignedAddress:
    case cudaErrorInvalidAddressSpace:
    case cudaErrorInvalidPc:
    case cudaErrorHardwareStackError:
    case cudaErrorAssert:
    case cudaErrorLaunchTimeout:
    case cudaErrorECCUncorrectable:
    case cudaErrorContextIsDestroyed:
      return true;
    default:
      return false;
  }
}

/// Throws CUDA error e, met in `where`, as one line: a DeviceFault when e, or what a wait for the
/// device then returns, says the context is lost (a kernel faulted), else an Error. Inside a
/// graph capture nothing waits (that would end the capture): errors there are the capture's own,
/// and a lost context would have failed the capture's start.
[[noreturn]] inline void throw_cuda(cudaError_t e, const std::string& where) {
  const std::string what = where + ": " + cudaGetErrorString(e);
  cudaStreamCaptureStatus capturing = cudaStreamCaptureStatusNone;
  const bool in_capture = engine_stream() && cudaStreamIsCapturing(engine_stream(), &capturing) == cudaSuccess &&
                          capturing != cudaStreamCaptureStatusNone;
  const cudaError_t later = context_lost(e) || in_capture ? cudaSuccess : cudaDeviceSynchronize();
  if (context_lost(e) || context_lost(later))
    throw DeviceFault("GPU engine: a kernel faulted on the device (CUDA error in " + what +
                      (context_lost(e) ? std::string() : std::string(", then ") + cudaGetErrorString(later)) +
                      "); the device cannot go on in this run: --resume continues from the last checkpoint");
  throw Error("GPU engine: CUDA error in " + what);
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
    cudaError_t e = cudaMalloc(&p, static_cast<std::size_t>(n));
    if (e == cudaErrorMemoryAllocation && !free_.empty()) {
      // The cache holds blocks too small for this request: given back (cudaFree waits for the
      // device, so no queued work still uses them), then one more try.
      (void)cudaGetLastError();
      for (auto& [bytes, q] : free_) (void)cudaFree(q);
      free_.clear();
      e = cudaMalloc(&p, static_cast<std::size_t>(n));
    }
    if (e != cudaSuccess) {
      (void)cudaGetLastError();
      if (e != cudaErrorMemoryAllocation) throw_cuda(e, "an allocation of temporary storage");
      throw Error("GPU engine: out of device memory (" + std::to_string(n) + " bytes of temporary storage)");
    }
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

/// cudaFree for the engine's buffers, its error ignored. Thrust's own device memory resource
/// throws when a free fails, and a free fails only once a fault has broken the CUDA context
/// (every later call then fails): that fault is being reported by the exception that unwinds the
/// engine, and a second exception thrown from a buffer's destructor during that unwinding would
/// end the process in std::terminate instead of the one-line error. The cudaGetLastError()
/// leaves no sticky launch error for the next check to misname.
inline cudaError_t CUDARTAPI free_quietly(void* p) {
  if (cudaFree(p) != cudaSuccess) (void)cudaGetLastError();
  return cudaSuccess;
}
/// The memory resource of the engine's buffers: cudaMalloc (a failure throws
/// thrust::system::detail::bad_alloc, as Thrust's), free_quietly.
using QuietFreeResource =
    thrust::system::cuda::detail::cuda_memory_resource<cudaMalloc, free_quietly, thrust::cuda::pointer<void>>;
template <class T>
using QuietFreeAllocator = thrust::mr::stateless_resource_allocator<T, QuietFreeResource>;

/// A CUDA error as biodem::Error (one line), after the last launch.
inline void check_cuda(const char* where) {
  const cudaError_t e = cudaGetLastError();
  if (e != cudaSuccess) throw_cuda(e, std::string("the launch of ") + where);
}

/// The stream of every kernel, Thrust algorithm and graph of the engine: created once, blocking
/// (cudaStreamDefault), so the copies, fills, resizes and frees that Thrust's vectors make on the
/// legacy default stream stay ordered with it; a non-default stream because CUDA graphs cannot be
/// captured on the legacy one. If it cannot be created, the legacy stream (graphs then fail to
/// capture and the engine launches plainly). The list build queues its sorts, scans and copies
/// without a wait (System::queue): that is safe only because of this ordering, so a build with
/// per-thread default streams, where the legacy stream's ordering does not hold, is refused.
#ifdef CUDA_API_PER_THREAD_DEFAULT_STREAM
#error "the GPU engine relies on the legacy default stream's ordering (see engine_stream)"
#endif
inline cudaStream_t engine_stream() {
  static const cudaStream_t s = [] {
    cudaStream_t x = nullptr;
    if (cudaStreamCreateWithFlags(&x, cudaStreamDefault) != cudaSuccess) {
      (void)cudaGetLastError();
      x = nullptr;
    }
    return x;
  }();
  return s;
}

/// Block sums of a fixed-shape tree (deterministic: the order depends only on n).
inline constexpr std::uint32_t kSumBlock = 256;

template <class F, class H>
__global__ void block_sums(std::uint32_t n, F f, double* partial, H halt) {
  __shared__ double buf[kSumBlock];
  if (halted(halt)) return;  // the same for every thread of the block (and of the launch)
  const std::uint32_t i = blockIdx.x * kSumBlock + threadIdx.x;
  buf[threadIdx.x] = i < n ? f(i) : 0.0;
  __syncthreads();
  for (std::uint32_t w = kSumBlock / 2; w > 0; w >>= 1) {
    if (threadIdx.x < w) buf[threadIdx.x] = buf[threadIdx.x] + buf[threadIdx.x + w];
    __syncthreads();
  }
  if (threadIdx.x == 0) partial[blockIdx.x] = buf[0];
}

/// The block sums in block order, by one thread, into out[0].
template <class H>
__global__ void sum_blocks(std::uint32_t blocks, const double* partial, double* out, H halt) {
  if (halted(halt)) return;
  double r = 0.0;
  for (std::uint32_t b = 0; b < blocks; ++b) r = r + partial[b];
  out[0] = r;
}

/// CUDA graphs of the launches between two list checks (Engine::run_units), one per key, built
/// at first use by stream capture and replayed with one cudaGraphLaunch. The engine forgets them
/// (clear) whenever a kernel argument changes. BIODEM_GPU_GRAPH=0 turns them off; a capture or
/// instantiation that fails turns them off for the rest of the run, with one line on stderr, and
/// the launches then go plainly (the same kernels in the same order, so the same results).
class Graphs {
 public:
  Graphs() {
    const char* v = std::getenv("BIODEM_GPU_GRAPH");
    enabled_ = !(v && std::string(v) == "0");
  }
  Graphs(const Graphs&) = delete;
  Graphs& operator=(const Graphs&) = delete;
  ~Graphs() { clear(); }
  void clear() {
    for (auto& [key, exec] : cache_) (void)cudaGraphExecDestroy(exec);  // errors ignored: the context may be gone
    cache_.clear();
  }
  /// Captures the graph of `key` from `record` (which only launches kernels and queues copies
  /// and event records on engine_stream()) unless it is cached. False when graphs are off or
  /// the capture failed: the caller launches plainly.
  template <class R>
  bool prepare(std::uint64_t key, R& record) {
    if (!enabled_) return false;
    if (cache_.count(key)) return true;
    if (cache_.size() >= 64) clear();
    cudaGraphExec_t exec = capture(record);
    if (!exec) return false;
    cache_.emplace(key, exec);
    return true;
  }
  /// Replays the graph of `key`, capturing it first if needed (prepare). False when graphs are
  /// off: the caller launches plainly.
  template <class R>
  bool run(std::uint64_t key, R& record) {
    if (!prepare(key, record)) return false;
    const auto it = cache_.find(key);
    const cudaError_t e = cudaGraphLaunch(it->second, engine_stream());
    if (e != cudaSuccess) throw_cuda(e, "a graph launch");
    return true;
  }

 private:
  template <class R>
  cudaGraphExec_t capture(R& record) {
    const cudaStream_t s = engine_stream();
    std::string why;
    cudaGraph_t graph = nullptr;
    cudaGraphExec_t exec = nullptr;
    cudaError_t e = s ? cudaStreamBeginCapture(s, cudaStreamCaptureModeThreadLocal) : cudaErrorInvalidResourceHandle;
    if (e == cudaSuccess) {
      try {
        record();
      } catch (const std::exception& x) {
        why = x.what();
      }
      e = cudaStreamEndCapture(s, &graph);  // ends the capture whatever happened inside it
    }
    if (e == cudaSuccess && why.empty()) e = cudaGraphInstantiate(&exec, graph, 0);
    // Uploaded now, so that its first launch (a timed trial's, Tuning) costs no upload.
    if (e == cudaSuccess && why.empty() && exec) e = cudaGraphUpload(exec, s);
    if (graph) (void)cudaGraphDestroy(graph);
    if (e != cudaSuccess || !why.empty() || !exec) {
      if (why.empty()) why = cudaGetErrorString(e);
      (void)cudaGetLastError();  // capture errors are not sticky: clear it and go on plainly
      if (exec) (void)cudaGraphExecDestroy(exec);
      exec = nullptr;
      if (const cudaError_t later = cudaDeviceSynchronize(); context_lost(later))  // a kernel faulted before: stop
        throw DeviceFault("GPU engine: a kernel faulted on the device (CUDA graph capture failed: " + why + ", then " +
                          cudaGetErrorString(later) +
                          "); the device cannot go on in this run: --resume continues from the last checkpoint");
      (void)cudaGetLastError();
      enabled_ = false;
      std::cerr << "biodem: GPU engine: CUDA graph capture failed (" << why
                << "); launching the kernels plainly for the rest of the run\n";
      return nullptr;
    }
    return exec;
  }

  bool enabled_ = true;
  std::map<std::uint64_t, cudaGraphExec_t> cache_;
};

/// download()'s copies as one batch: asynchronous copies on the engine's stream into one pinned
/// (page-locked) host buffer, kept between downloads and enlarged when needed, then one wait;
/// the engine takes the arrays from it. If pinned memory cannot be had, a pageable buffer (the
/// copies are then staged by the driver, as plain copies are).
class Staging {
 public:
  Staging() = default;
  Staging(const Staging&) = delete;
  Staging& operator=(const Staging&) = delete;
  ~Staging() { release(); }
  std::size_t add(const void* src, std::size_t bytes) {
    items_.push_back({src, bytes, used_});
    used_ += (bytes + 255) / 256 * 256;
    return items_.size() - 1;
  }
  void run() {
    if (used_ > capacity_) {
      release();
      const std::size_t want = used_ + used_ / 4;
      void* p = nullptr;
      if (cudaHostAlloc(&p, want, cudaHostAllocDefault) == cudaSuccess) {
        pinned_ = static_cast<char*>(p);
      } else {
        (void)cudaGetLastError();
        pageable_.resize(want);
      }
      capacity_ = want;
    }
    char* base = pinned_ ? pinned_ : pageable_.data();
    for (const Item& it : items_)
      if (it.bytes) {
        const cudaError_t e = cudaMemcpyAsync(base + it.offset, it.src, it.bytes, cudaMemcpyDeviceToHost, engine_stream());
        if (e != cudaSuccess) throw_cuda(e, "a download");
      }
    const cudaError_t e = cudaStreamSynchronize(engine_stream());
    if (e != cudaSuccess) throw_cuda(e, "a download");
  }
  const void* host(std::size_t item) const { return (pinned_ ? pinned_ : pageable_.data()) + items_[item].offset; }
  void clear() {
    items_.clear();
    used_ = 0;
  }

 private:
  struct Item {
    const void* src;
    std::size_t bytes, offset;
  };
  void release() {
    if (pinned_) (void)cudaFreeHost(pinned_);  // errors ignored: the context may be gone
    pinned_ = nullptr;
    pageable_.clear();
    pageable_.shrink_to_fit();
    capacity_ = 0;
  }
  std::vector<Item> items_;
  std::size_t used_ = 0, capacity_ = 0;
  char* pinned_ = nullptr;
  std::vector<char> pageable_;
};

/// A copy of one small device value into pinned host memory behind an event, queued on the
/// engine's stream (inside a CUDA graph when captured): read later without waiting if the device
/// has got there (the settle criterion's state, and Pending's result). prepare() makes the pinned
/// slot and the event outside any graph capture.
template <class T>
class PendingCopy {
 public:
  explicit PendingCopy(const char* what) : what_(what) {}
  PendingCopy(const PendingCopy&) = delete;
  PendingCopy& operator=(const PendingCopy&) = delete;
  ~PendingCopy() {  // errors ignored: the context may be gone
    if (event_) (void)cudaEventDestroy(event_);
    if (host_) (void)cudaFreeHost(host_);
  }
  /// True when it allocated (graphs that enqueue it hold the addresses).
  bool prepare() {
    if (host_) return false;
    check(cudaHostAlloc(reinterpret_cast<void**>(&host_), sizeof(T), cudaHostAllocDefault));
    check(cudaEventCreateWithFlags(&event_, cudaEventDisableTiming));
    return true;
  }
  void enqueue(const T* src) {
    check(cudaMemcpyAsync(host_, src, sizeof(T), cudaMemcpyDeviceToHost, engine_stream()));
    // Inside a graph capture a plain event record only orders streams; recorded as "external",
    // it becomes a node of the graph that records the event at each replay.
    cudaStreamCaptureStatus capturing = cudaStreamCaptureStatusNone;
    check(cudaStreamIsCapturing(engine_stream(), &capturing));
    check(cudaEventRecordWithFlags(event_, engine_stream(),
                                   capturing == cudaStreamCaptureStatusActive ? cudaEventRecordExternal
                                                                                : cudaEventRecordDefault));
  }
  /// The value of the last enqueue (waits for it if it is not done).
  T get() {
    check(cudaEventSynchronize(event_));
    return *host_;
  }
  /// The slot as it is now, without waiting (Pending's check of its own reads).
  T slot() const { return *host_; }
  void check(cudaError_t e) const {
    if (e != cudaSuccess) throw_cuda(e, what_);
  }

 private:
  const char* what_;
  T* host_ = nullptr;
  cudaEvent_t event_ = nullptr;
};

/// A reduction over n indices queued on the engine's stream, its result then copied like a
/// PendingCopy: the steps between two list checks queue it before their last step (inside the
/// CUDA graph), and the check reads it, usually complete by then, so that the host does not wait
/// for the device between the steps (Engine::check_list). prepare() makes the device buffer and
/// the reduction's temporary storage (and the copy's slot) outside any graph capture; enqueue()
/// then only launches, copies and records (all capturable).
template <class T>
class Pending {
 public:
  Pending() = default;
  Pending(const Pending&) = delete;
  Pending& operator=(const Pending&) = delete;
  ~Pending() {  // errors ignored: the context may be gone
    if (dev_) (void)cudaFree(dev_);
    if (temp_) (void)cudaFree(temp_);
  }
  /// True when it (re)allocated (the graphs that enqueue it then hold stale addresses).
  template <class F, class Op>
  bool prepare(std::uint32_t n, const F& f, const Op& op, const T& init) {
    std::size_t bytes = 0;
    copy_.check(cub::DeviceReduce::Reduce(nullptr, bytes, input(f), static_cast<T*>(nullptr), n, op, init,
                                          engine_stream()));
    bool made = copy_.prepare();
    if (!dev_) {
      copy_.check(cudaMalloc(reinterpret_cast<void**>(&dev_), sizeof(T)));
      made = true;
    }
    if (bytes > temp_bytes_) {
      if (temp_) copy_.check(cudaFree(temp_));
      temp_ = nullptr;
      copy_.check(cudaMalloc(&temp_, bytes));
      temp_bytes_ = bytes;
      made = true;
    }
    return made;
  }
  template <class F, class Op>
  void enqueue(std::uint32_t n, const F& f, const Op& op, const T& init) {
    std::size_t bytes = temp_bytes_;
    copy_.check(cub::DeviceReduce::Reduce(temp_, bytes, input(f), dev_, n, op, init, engine_stream()));
    copy_.enqueue(dev_);
  }
  /// The result of the last enqueue (waits for it if it is not done). With
  /// BIODEM_GPU_VERIFY_QUEUED=1 (a check of gpu_check.sh), the stream is then waited for and the
  /// slot read again: a value read before the device wrote it (the event recorded inside a CUDA
  /// graph not waited for) differs and stops the run. Valid where nothing is enqueued after the
  /// read's enqueue before get(), as for the list check.
  T get() {
    const T v = copy_.get();
    if (verify_) {
      copy_.check(cudaStreamSynchronize(engine_stream()));
      const T again = copy_.slot();
      if (std::memcmp(&v, &again, sizeof(T)) != 0)
        // (a DeviceFault: check_list's fallback to waiting checks would hide it)
        throw DeviceFault("GPU engine: the list check read its queued reduction before the device had written it "
                          "(BIODEM_GPU_VERIFY_QUEUED=1)");
    }
    return v;
  }

 private:
  template <class F>
  static auto input(const F& f) {
    return thrust::make_transform_iterator(thrust::counting_iterator<std::uint32_t>(0), f);
  }
  PendingCopy<T> copy_{"the list check"};
  bool verify_ = [] {
    const char* v = std::getenv("BIODEM_GPU_VERIFY_QUEUED");
    return v && std::string(v) == "1";
  }();
  T* dev_ = nullptr;
  void* temp_ = nullptr;
  std::size_t temp_bytes_ = 0;
};

/// Device time of the launches between start() and stop() on the engine's stream (CUDA events;
/// stop() waits for them). If events cannot be created, the host's clock after a wait.
class Timer {
 public:
  Timer() {
    if (cudaEventCreate(&a_) != cudaSuccess || cudaEventCreate(&b_) != cudaSuccess) {
      (void)cudaGetLastError();
      a_ = b_ = nullptr;
    }
  }
  Timer(const Timer&) = delete;
  Timer& operator=(const Timer&) = delete;
  ~Timer() {
    if (a_) (void)cudaEventDestroy(a_);  // errors ignored: the context may be gone
    if (b_) (void)cudaEventDestroy(b_);
  }
  void start() {
    if (a_ && cudaEventRecord(a_, engine_stream()) == cudaSuccess) return;
    (void)cudaGetLastError();  // (not left for the next launch's check to name)
    if (a_) (void)cudaStreamSynchronize(engine_stream());
    a_failed_ = a_ != nullptr;
    t0_ = std::chrono::steady_clock::now();
  }
  double stop() {
    if (!a_ || a_failed_) {
      a_failed_ = false;
      (void)cudaStreamSynchronize(engine_stream());
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
    }
    float ms = 0.0f;
    cudaError_t e = cudaEventRecord(b_, engine_stream());
    if (e == cudaSuccess) e = cudaEventSynchronize(b_);
    if (e == cudaSuccess) e = cudaEventElapsedTime(&ms, a_, b_);
    if (e != cudaSuccess) throw_cuda(e, "the timing of the contact kernels");
    return 1e-3 * static_cast<double>(ms);
  }

 private:
  cudaEvent_t a_ = nullptr, b_ = nullptr;
  bool a_failed_ = false;  // this start fell back to the host's clock
  std::chrono::steady_clock::time_point t0_;
};

/// BIODEM_TEST_GPU_FAULT_AT_STEP (System::inject_fault).
__global__ void trap_kernel() { __trap(); }

/// Threads per block of the one-index-per-thread kernels (System::launch): 64 unless
/// BIODEM_GPU_BLOCK says 32, 64, 128, 256 or 512 (make_engine reads it; docs/gpu.md section 4).
inline std::uint32_t& launch_block() {
  static std::uint32_t b = 64;
  return b;
}

/// Programmatic dependent launch of the one-index kernels and row walks (after_previous_kernel):
/// on unless BIODEM_GPU_PDL=0; only on devices of compute capability 9.0 and later.
inline bool& pdl_launch() {
  static bool on = false;
  return on;
}

/// The threads one wave of the device holds at 128 registers per thread (the step kernels'
/// budget): 512 per SM (make_engine sets it from the device's SM count).
inline std::uint32_t& one_wave_threads() {
  static std::uint32_t t = 132u * 512u;
  return t;
}

/// Launches kernel<<<blocks, block, 0, engine_stream()>>>(args...), with programmatic dependent
/// launch when pdl_launch().
template <class... Params, class... Args>
inline void launch_kernel_shared(void (*kernel)(Params...), std::uint32_t blocks, std::uint32_t block,
                                 std::uint32_t shared_bytes, Args&&... args) {
  if (!pdl_launch()) {
    kernel<<<blocks, block, shared_bytes, engine_stream()>>>(std::forward<Args>(args)...);
    return;
  }
  cudaLaunchConfig_t cfg{};
  cfg.gridDim = dim3(blocks);
  cfg.blockDim = dim3(block);
  cfg.dynamicSmemBytes = shared_bytes;
  cfg.stream = engine_stream();
  cudaLaunchAttribute attr[1];
  attr[0].id = cudaLaunchAttributeProgrammaticStreamSerialization;
  attr[0].val.programmaticStreamSerializationAllowed = 1;
  cfg.attrs = attr;
  cfg.numAttrs = 1;
  (void)cudaLaunchKernelEx(&cfg, kernel, std::forward<Args>(args)...);  // (errors: check_cuda after)
}
/// launch_kernel_shared without dynamic shared memory.
template <class... Params, class... Args>
inline void launch_kernel(void (*kernel)(Params...), std::uint32_t blocks, std::uint32_t block, Args&&... args) {
  launch_kernel_shared(kernel, blocks, block, 0u, std::forward<Args>(args)...);
}

/// Lanes per row walk (System::launch_walks): 4 unless BIODEM_GPU_ROW_LANES says 1 (one
/// thread walks the whole row), 2, 8, 16 or 32; log2 of it. (H100, 2026-11-26: 4 lanes faster
/// than 16 on every bench drum, for the row walk and for the entry sums by the row lanes.)
inline std::uint32_t& row_lanes_log2() {
  static std::uint32_t l = 2;
  return l;
}

/// Row walks with a group of lanes per item (defined after the kernels, below).
template <class W>
__global__ void __launch_bounds__(kMostThreadsPerBlock) for_each_walk(std::uint32_t n, W w, std::uint32_t lanes_log2);

/// Row walks with the touching contacts shared by a warp's lanes (walk_packed; defined after the
/// kernels, below): launched when W is such a walker (kernels.hpp, WalksPacked); false if not.
template <class W>
bool launch_packed_walks(std::uint32_t n, const W& w, std::uint32_t split_log2);

/// Groups of lanes per item whose row walks share a warp's touching contacts
/// (WalkKickGroups::run_packed; defined after the kernels, below).
template <class F>
void launch_packed_groups(std::uint32_t n, const F& f, std::uint32_t lanes_log2);

/// Items with a group of lanes each (defined after the kernels, below): f.run(item, group).
template <class F>
__global__ void __launch_bounds__(kMostThreadsPerBlock) for_each_group(std::uint32_t n, F f, std::uint32_t lanes_log2);

/// Lanes per row of a list build (System::launch_row_builds): 16 unless BIODEM_GPU_BUILD_LANES
/// says 2, 4, 8 or 32 (1: the engine builds with BuildRows instead); log2 of it.
inline std::uint32_t& build_lanes_log2() {
  static std::uint32_t l = 4;
  return l;
}

/// Row builds with a group of lanes per sphere (defined after the kernels, below).
template <class B>
__global__ void __launch_bounds__(kMostThreadsPerBlock)
    for_each_row_build(std::uint32_t n, B b, std::uint32_t lanes_log2, std::uint32_t scratch_bytes);

struct System {
  template <class T>
  using vector = thrust::cuda::vector<T, QuietFreeAllocator<T>>;  // (frees never throw: free_quietly)
  static auto exec() { return thrust::cuda::par(temporary_storage()).on(engine_stream()); }
  /// The same without the stream synchronisation at the end of each algorithm: the engine's
  /// stream keeps the order, the caching allocator hands a block back to a later algorithm on
  /// the same stream only.
  static auto queue() { return thrust::cuda::par_nosync(temporary_storage()).on(engine_stream()); }
  /// Test hook BIODEM_TEST_GPU_FAULT_AT_STEP: a kernel that traps, which breaks the CUDA
  /// context; the launch returns, the fault surfaces at the next wait or copy.
  static void inject_fault() {
    trap_kernel<<<1, 1, 0, engine_stream()>>>();
    check_cuda("the injected fault's launch");
  }
  /// Waits for everything launched on the engine's stream (BIODEM_GPU_PROFILE).
  static void wait() {
    const cudaError_t e = cudaStreamSynchronize(engine_stream());
    if (e != cudaSuccess) throw_cuda(e, "a wait for the device");
  }
  /// One thread per index, launch_block() per block (for_each_index is compiled for blocks of up
  /// to kMostThreadsPerBlock); no host wait.
  template <class F>
  static void launch(std::uint32_t n, const F& f) {
    const std::uint32_t block = launch_block();
    // (blocks in 64 bits: n + block - 1 wraps in 32 for n near 2^32; thread indices are 32-bit)
    const std::uint64_t blocks = (static_cast<std::uint64_t>(n) + block - 1) / block;
    if (blocks * block > 0xffffffffull)
      throw Error("GPU engine: a kernel over " + std::to_string(n) + " items exceeds 2^32 threads (32-bit indices)");
    launch_kernel(for_each_index<F>, static_cast<std::uint32_t>(blocks), block, n, f);
    check_cuda("a kernel launch");
  }
  /// Row walks (kernels.hpp, walk_row) over n items: a group of row lanes per item
  /// (for_each_walk), or one thread per item when BIODEM_GPU_ROW_LANES=1; no host wait.
  /// packed: where one thread would walk each row, the walks of a warp share their touching
  /// contacts (walk_packed, for_each_packed_walk; BIODEM_GPU_WALK_PACK=1).
  /// split_log2: with `packed`, 2^split_log2 lanes of the warp share each item's walk
  /// (walk_packed; BIODEM_GPU_PACK_SPLIT).
  template <class W>
  static void launch_walks(std::uint32_t n, const W& w, bool single, bool packed = false, std::uint32_t split_log2 = 0) {
    const std::uint32_t log2 = single ? 0u : row_lanes_log2();
    if (log2 == 0 && packed && launch_packed_walks(n, w, split_log2)) return;
    if (log2 == 0) {
      launch(n, w);
      return;
    }
    const std::uint32_t block = launch_block();  // (at least 32: a multiple of the lanes)
    const std::uint64_t threads = static_cast<std::uint64_t>(n) << log2;
    if (threads + block - 1 > 0xffffffffull)  // (thread indices are 32-bit, the grid rounded up included)
      throw Error("GPU engine: " + std::to_string(n) + " row walks of " + std::to_string(1u << log2) +
                  " lanes exceed 2^32 threads; set BIODEM_GPU_ROW_LANES lower");
    launch_kernel(for_each_walk<W>, static_cast<std::uint32_t>((threads + block - 1) / block), block, n, w, log2);
    check_cuda("a kernel launch");
  }
  /// n items with a group of 2^lanes_log2 lanes of a warp each (f.run(item, WarpGroup); lanes_log2
  /// at most 5); no host wait.
  template <class F>
  static void launch_groups(std::uint32_t n, const F& f, std::uint32_t lanes_log2) {
    if (lanes_log2 == 0) {
      launch(n, f);
      return;
    }
    const std::uint32_t block = launch_block();  // (at least 32: a multiple of the lanes)
    const std::uint64_t threads = static_cast<std::uint64_t>(n) << lanes_log2;
    if (threads + block - 1 > 0xffffffffull)
      throw Error("GPU engine: " + std::to_string(n) + " items of " + std::to_string(1u << lanes_log2) +
                  " lanes exceed 2^32 threads");
    launch_kernel(for_each_group<F>, static_cast<std::uint32_t>((threads + block - 1) / block), block, n, f,
                  lanes_log2);
    check_cuda("a kernel launch");
  }
  /// launch_groups for WalkKickGroups with the warp's row walks sharing their touching contacts
  /// (WalkKickGroups::run_packed, for_each_packed_group; BIODEM_GPU_WALK_PACK=1).
  template <class F>
  static void launch_groups_packed(std::uint32_t n, const F& f, std::uint32_t lanes_log2) {
    launch_packed_groups(n, f, lanes_log2);
  }
  /// The row lanes, as run.log names them.
  static std::string walk_lanes() { return std::to_string(1u << row_lanes_log2()) + " lanes per sphere"; }
  /// The grouped list build (kernels.hpp, BuildRowsGrouped) over n spheres: a group of
  /// build_lanes_log2() lanes per sphere, each group's scratch in the block's shared memory
  /// (RowScratch::bytes for the rows' capacity; as many groups per block as launch_block() holds
  /// and 48 KB of shared memory allow); no host wait.
  template <class B>
  static void launch_row_builds(std::uint32_t n, const B& b) {
    const std::uint32_t log2 = build_lanes_log2() ? build_lanes_log2() : 4u;
    const std::uint32_t lanes = 1u << log2, bytes = B::scratch_bytes(b.rows.cap);
    std::uint32_t groups = launch_block() / lanes;
    if (groups * bytes > kRowBuildSharedBytes) groups = kRowBuildSharedBytes / bytes;
    if (groups == 0) groups = 1;
    const std::uint32_t block = groups * lanes;
    const std::uint64_t threads = static_cast<std::uint64_t>(n) << log2;
    if (threads + block - 1 > 0xffffffffull)
      throw Error("GPU engine: " + std::to_string(n) + " row builds of " + std::to_string(lanes) +
                  " lanes exceed 2^32 threads; set BIODEM_GPU_BUILD_LANES lower");
    for_each_row_build<<<static_cast<std::uint32_t>((threads + block - 1) / block), block, groups * bytes,
                         engine_stream()>>>(n, b, log2, bytes);
    check_cuda("a list build launch");
  }
  static std::string build_lanes() {
    return std::to_string(1u << (build_lanes_log2() ? build_lanes_log2() : 4u)) + " lanes per sphere";
  }
  /// Doubles of device memory that sum_into needs: the result, then one per block.
  static std::size_t sum_scratch(std::uint32_t n) { return 1 + (n + kSumBlock - 1) / kSumBlock; }
  /// out[0] = the sum of f(i) over i < n, left in device memory (no host wait): block sums of a
  /// fixed tree, then the block sums in order (deterministic on one device and build; not
  /// Thrust's order). `out` has sum_scratch(n) doubles.
  template <class F, class H>
  static void sum_into(std::uint32_t n, const F& f, double* out, const H& halt) {
    const std::uint32_t blocks = (n + kSumBlock - 1) / kSumBlock;
    if (blocks) block_sums<<<blocks, kSumBlock, 0, engine_stream()>>>(n, f, out + 1, halt);
    sum_blocks<<<1, 1, 0, engine_stream()>>>(blocks, out + 1, out, halt);
    check_cuda("a kinetic energy sum");
  }
  using Graphs = cuda_device::Graphs;
  using Staging = cuda_device::Staging;
  /// BIODEM_GPU_FORCES=auto times the two contact kernel sets on the device (Engine::Tuning).
  static constexpr bool kTimedChoice = true;
  /// Threads of one wave at 128 registers (the timed choice's split sets: candidate_sets).
  static std::uint32_t wave_threads() { return one_wave_threads(); }
  using Timer = cuda_device::Timer;
  template <class T>
  using Pending = cuda_device::Pending<T>;
  template <class T>
  using PendingCopy = cuda_device::PendingCopy<T>;
};

}  // namespace biodem::gpu::cuda_device

#define BIODEM_GPU_NS cuda_device
#include "gpu/engine_impl.hpp"

namespace biodem::gpu::cuda_device {

/// A group of 2^lanes_log2 lanes of one warp (for_each_walk, for_each_row_build): ballots,
/// shuffles and syncs over the group's lanes only (a group never straddles a warp: its size
/// divides 32 and the block). Its members are host-device (walk_row_lanes and
/// BuildRowsGrouped::build are) but only mean something on the device.
struct WarpGroup {
  unsigned mask;  // the group's lanes within the warp
  std::uint32_t first, my_lane, count;
  __device__ static WarpGroup of_thread(std::uint32_t lanes_log2) {
    const std::uint32_t lanes = 1u << lanes_log2;
    const unsigned first = (threadIdx.x & 31u) & ~(lanes - 1u);
    const unsigned mask = lanes == 32u ? 0xffffffffu : ((1u << lanes) - 1u) << first;
    return WarpGroup{mask, first, threadIdx.x & (lanes - 1u), lanes};
  }
  __host__ __device__ std::uint32_t lane() const { return my_lane; }
  __host__ __device__ std::uint32_t size() const { return count; }
  __host__ __device__ std::uint32_t ballot(bool b) const {
#ifdef __CUDA_ARCH__
    const std::uint32_t all = __ballot_sync(mask, b);
    return count == 32u ? all : (all >> first) & ((1u << count) - 1u);
#else
    return b ? 1u : 0u;
#endif
  }
  __host__ __device__ void sync() const {
#ifdef __CUDA_ARCH__
    __syncwarp(mask);
#endif
  }
  /// The word that lane src of the group holds (every lane of the group calls it).
  __host__ __device__ long long shuffle(long long v, std::uint32_t src) const {
#ifdef __CUDA_ARCH__
    return __shfl_sync(mask, v, static_cast<int>(src), static_cast<int>(count));
#else
    (void)src;
    return v;
#endif
  }
  /// The contact that lane src of the group holds (every lane of the group calls it).
  __host__ __device__ RowContact shuffle(const RowContact& r, std::uint32_t src) const {
#ifdef __CUDA_ARCH__
    RowContact o;
    const int w = static_cast<int>(count), l = static_cast<int>(src);
    o.force.x = __shfl_sync(mask, r.force.x, l, w);
    o.force.y = __shfl_sync(mask, r.force.y, l, w);
    o.force.z = __shfl_sync(mask, r.force.z, l, w);
    o.torque.x = __shfl_sync(mask, r.torque.x, l, w);
    o.torque.y = __shfl_sync(mask, r.torque.y, l, w);
    o.torque.z = __shfl_sync(mask, r.torque.z, l, w);
    o.kind = __shfl_sync(mask, r.kind, l, w);
    return o;
#else
    (void)src;
    return r;
#endif
  }
};

/// Row walks with a group of 2^lanes_log2 lanes per item (kernels.hpp, walk_row_lanes): the
/// same bits as one thread walking the row. A group never straddles a warp (lanes <= 32 divides
/// the block), and its lanes leave together (the item is the group's).
template <class W>
__global__ void __launch_bounds__(kMostThreadsPerBlock) for_each_walk(std::uint32_t n, W w, std::uint32_t lanes_log2) {
  after_previous_kernel();
  const std::uint32_t item = (blockIdx.x * blockDim.x + threadIdx.x) >> lanes_log2;
  if (item >= n) return;
  walk_row_lanes(w, item, WarpGroup::of_thread(lanes_log2));
}

template <bool Split, class W>
__global__ void __launch_bounds__(kMostThreadsPerBlock)
    for_each_packed_walk(std::uint32_t n, W w, std::uint32_t split_log2);

template <class W>
bool launch_packed_walks(std::uint32_t n, const W& w, std::uint32_t split_log2) {
  if constexpr (!WalksPacked<W>::value) {
    (void)n;
    (void)w;
    (void)split_log2;
    return false;
  } else {
    // (whole warps: at least 32; at most 256, so that the warps' scratch stays within the 48 KB
    // of shared memory a block may take without asking: 8 x 3,840 bytes)
    const std::uint32_t block = launch_block() < 256u ? launch_block() : 256u;
    const std::uint64_t threads = static_cast<std::uint64_t>(n) << split_log2;
    const std::uint64_t blocks = (threads + block - 1) / block;
    if (blocks * block > 0xffffffffull)
      throw Error("GPU engine: a kernel over " + std::to_string(n) + " items of " + std::to_string(1u << split_log2) +
                  " lanes exceeds 2^32 threads (32-bit indices)");
    const auto bytes = static_cast<std::uint32_t>((block / 32) * sizeof(PackedWalkScratch<ContactArgs::EntryHead>));
    static_assert(8 * sizeof(PackedWalkScratch<ContactArgs::EntryHead>) <= 48u * 1024u, "a block's scratch within 48 KB");
    if (split_log2)
      launch_kernel_shared(for_each_packed_walk<true, W>, static_cast<std::uint32_t>(blocks), block, bytes, n, w, split_log2);
    else
      launch_kernel_shared(for_each_packed_walk<false, W>, static_cast<std::uint32_t>(blocks), block, bytes, n, w, 0u);
    check_cuda("a kernel launch");
    return true;
  }
}

template <class F>
__global__ void __launch_bounds__(kMostThreadsPerBlock)
    for_each_packed_group(std::uint32_t n, F f, std::uint32_t lanes_log2);

template <class F>
void launch_packed_groups(std::uint32_t n, const F& f, std::uint32_t lanes_log2) {
  const std::uint32_t block = launch_block() < 256u ? launch_block() : 256u;  // (as launch_packed_walks)
  const std::uint64_t threads = static_cast<std::uint64_t>(n) << lanes_log2;
  if (threads + block - 1 > 0xffffffffull)
    throw Error("GPU engine: " + std::to_string(n) + " items of " + std::to_string(1u << lanes_log2) +
                " lanes exceed 2^32 threads");
  const auto bytes = static_cast<std::uint32_t>((block / 32) * sizeof(PackedWalkScratch<ContactArgs::EntryHead>));
  launch_kernel_shared(for_each_packed_group<F>, static_cast<std::uint32_t>((threads + block - 1) / block), block, bytes,
                       n, f, lanes_log2);
  check_cuda("a kernel launch");
}

/// Row walks of whole warps with their touching contacts shared (kernels.hpp, walk_packed): a
/// warp's lanes walk items 32 w .. 32 w + 31 (with split_log2 > 0, 2^split_log2 consecutive
/// lanes per item: items 32 w / 2^split_log2 onwards), and lanes past n stay in the warp to take
/// their share (whole warps past n leave). Each warp's scratch is its part of the block's
/// dynamic shared memory (System::launch_walks).
template <bool Split, class W>
__global__ void __launch_bounds__(kMostThreadsPerBlock)
    for_each_packed_walk(std::uint32_t n, W w, std::uint32_t split_log2) {
  after_previous_kernel();
  extern __shared__ __align__(16) unsigned char packed_walk_shared[];
  const std::uint32_t s = Split ? split_log2 : 0u;  // (0 known to the compiler without the split)
  const std::uint32_t thread = blockIdx.x * blockDim.x + threadIdx.x, item = thread >> s;
  if (((thread & ~31u) >> s) >= n) return;
  using Scratch = PackedWalkScratch<ContactArgs::EntryHead>;
  Scratch& sc = reinterpret_cast<Scratch*>(packed_walk_shared)[threadIdx.x >> 5];
  walk_packed<Split>(w, item, item < n, WarpGroup::of_thread(5), sc, s);
}

/// Items with a group of 2^lanes_log2 lanes each whose row walks share the warp's touching
/// contacts (WalkKickGroups::run_packed): as for_each_group, but the lanes of groups past n stay
/// in the warp to take their share (whole warps past n leave); each warp's scratch in the
/// block's dynamic shared memory.
template <class F>
__global__ void __launch_bounds__(kMostThreadsPerBlock)
    for_each_packed_group(std::uint32_t n, F f, std::uint32_t lanes_log2) {
  after_previous_kernel();
  extern __shared__ __align__(16) unsigned char packed_group_shared[];
  const std::uint32_t thread = blockIdx.x * blockDim.x + threadIdx.x, item = thread >> lanes_log2;
  if (((thread & ~31u) >> lanes_log2) >= n) return;
  using Scratch = PackedWalkScratch<ContactArgs::EntryHead>;
  Scratch& sc = reinterpret_cast<Scratch*>(packed_group_shared)[threadIdx.x >> 5];
  f.run_packed(item, item < n, WarpGroup::of_thread(lanes_log2), WarpGroup::of_thread(5), sc);
}

/// Items with a group of 2^lanes_log2 lanes each (System::launch_groups): a group never
/// straddles a warp, and its lanes leave together (the item is the group's).
template <class F>
__global__ void __launch_bounds__(kMostThreadsPerBlock) for_each_group(std::uint32_t n, F f, std::uint32_t lanes_log2) {
  after_previous_kernel();
  const std::uint32_t item = (blockIdx.x * blockDim.x + threadIdx.x) >> lanes_log2;
  if (item >= n) return;
  f.run(item, WarpGroup::of_thread(lanes_log2));
}

/// Row builds with a group of 2^lanes_log2 lanes per sphere (kernels.hpp, BuildRowsGrouped);
/// group g of the block has bytes [g * scratch_bytes, (g + 1) * scratch_bytes) of the block's
/// shared memory. A group's lanes share its sphere, so they leave together.
template <class B>
__global__ void __launch_bounds__(kMostThreadsPerBlock)
    for_each_row_build(std::uint32_t n, B b, std::uint32_t lanes_log2, std::uint32_t scratch_bytes) {
  after_previous_kernel();
  extern __shared__ __align__(16) unsigned char row_build_shared[];
  const std::uint32_t item = (blockIdx.x * blockDim.x + threadIdx.x) >> lanes_log2;
  if (item >= n) return;
  b.build(item, WarpGroup::of_thread(lanes_log2),
          RowScratch::at(row_build_shared + (threadIdx.x >> lanes_log2) * scratch_bytes, b.rows.cap));
}

}  // namespace biodem::gpu::cuda_device

namespace biodem::gpu::cuda_device {

/// Runs f, giving a CUDA error that Thrust met inside one of its algorithms or vectors (it throws
/// thrust::system_error, or bad_alloc when device memory runs out) the one line that the
/// engine's own CUDA calls give it (throw_cuda: a DeviceFault when the context is lost). Before,
/// such an error ended the run as "internal error" (status 3).
template <class F>
decltype(auto) thrust_errors_named(const char* what, F&& f) {
  try {
    return f();
  } catch (const thrust::system_error& e) {
    if (e.code().category() == thrust::cuda_category())
      throw_cuda(static_cast<cudaError_t>(e.code().value()), std::string("a Thrust call of ") + what + " (" + e.what() + ")");
    throw Error(std::string("GPU engine: ") + what + ": " + e.what());
  } catch (const std::bad_alloc& e) {
    // Thrust's device allocations throw bad_alloc for any failed cudaMalloc, also the one that
    // meets a fault's lost context: that is a DeviceFault.
    if (const cudaError_t st = cudaDeviceSynchronize(); context_lost(st))
      throw_cuda(st, std::string("an allocation in ") + what + " (" + e.what() + ")");
    throw Error(std::string("GPU engine: out of memory (device or host) in ") + what + " (" + e.what() + ")");
  }
}

/// The CUDA engine as the run driver sees it: every call that may reach the device goes through
/// thrust_errors_named.
class NamedErrorsEngine final : public DeviceEngine {
 public:
  NamedErrorsEngine(sim::Simulation& host, std::string name) : e_(host, std::move(name)) {}
  void upload() override { thrust_errors_named("an upload", [&] { e_.upload(); }); }
  void download(bool history) override { thrust_errors_named("a download", [&] { e_.download(history); }); }
  void step() override { thrust_errors_named("a step", [&] { e_.step(); }); }
  Advanced advance(std::uint64_t max_steps) override {
    return thrust_errors_named("a run of steps", [&] { return e_.advance(max_steps); });
  }
  void begin_settle(const SettleCriterion& c, std::uint64_t phase_step, std::uint64_t below) override {
    thrust_errors_named("a settle criterion's start", [&] { e_.begin_settle(c, phase_step, below); });
  }
  void end_settle() override { thrust_errors_named("a settle criterion's end", [&] { e_.end_settle(); }); }
  double kinetic_energy_j() override {
    return thrust_errors_named("a kinetic energy sum", [&] { return e_.kinetic_energy_j(); });
  }
  double translational_kinetic_energy_j() override {
    return thrust_errors_named("a kinetic energy sum", [&] { return e_.translational_kinetic_energy_j(); });
  }
  void sync_walls() override { thrust_errors_named("a wall update", [&] { e_.sync_walls(); }); }
  void set_retime_every(std::uint64_t steps) override { e_.set_retime_every(steps); }
  void retime_kernels() override { thrust_errors_named("a new timing of the contact kernels", [&] { e_.retime_kernels(); }); }
  std::string device_name() const override { return e_.device_name(); }
  void set_check_every(std::uint32_t steps) override { e_.set_check_every(steps); }
  std::uint64_t list_builds() const override { return e_.list_builds(); }
  std::uint64_t waitless_list_checks() const override { return e_.waitless_list_checks(); }
  std::uint64_t guard_stops() const override { return e_.guard_stops(); }
  std::uint64_t removal_tests() const override { return e_.removal_tests(); }
  std::uint64_t removal_uploads() const override { return e_.removal_uploads(); }
  std::uint64_t graph_runs() const override { return e_.graph_runs(); }
  std::uint64_t plain_runs() const override { return e_.plain_runs(); }
  void set_grouped_list_build(bool on) override { e_.set_grouped_list_build(on); }
  std::uint64_t grouped_list_builds() const override { return e_.grouped_list_builds(); }
  std::string list_build_kernel() const override { return e_.list_build_kernel(); }
  std::uint64_t row_widenings() const override { return e_.row_widenings(); }
  std::uint32_t row_capacity() const override { return e_.row_capacity(); }
  void set_fused_kick(bool on) override { thrust_errors_named("a kernel switch", [&] { e_.set_fused_kick(on); }); }
  std::uint64_t fused_steps() const override { return e_.fused_steps(); }
  std::uint64_t sums_in_kick_steps() const override { return e_.sums_in_kick_steps(); }
  void set_entry_forces(bool on) override {
    thrust_errors_named("a kernel switch", [&] { e_.set_entry_forces(on); });
  }
  void set_sum_lanes(bool on) override {
    thrust_errors_named("a kernel switch", [&] { e_.set_sum_lanes(on); });
  }
  void set_walk_kick(bool on) override {
    thrust_errors_named("a kernel switch", [&] { e_.set_walk_kick(on); });
  }
  std::uint64_t walk_kick_steps() const override { return e_.walk_kick_steps(); }
  std::string contact_kernels() const override { return e_.contact_kernels(); }
  std::uint64_t entry_force_passes() const override { return e_.entry_force_passes(); }
  void set_fixed_sums(bool on) override {
    thrust_errors_named("a kernel switch", [&] { e_.set_fixed_sums(on); });
  }
  bool fixed_sums() const override { return e_.fixed_sums(); }
  double fixed_force_quantum() const override { return e_.fixed_force_quantum(); }
  double fixed_torque_quantum() const override { return e_.fixed_torque_quantum(); }
  void set_fixed_caps(double force_cap_n, double torque_cap_n_m) override { e_.set_fixed_caps(force_cap_n, torque_cap_n_m); }
  std::uint64_t fixed_sum_passes() const override { return e_.fixed_sum_passes(); }
  std::int64_t listed_pairs() override {
    return thrust_errors_named("a download of the pair count", [&] { return e_.listed_pairs(); });
  }
  std::int64_t listed_wall_slots() override {
    return thrust_errors_named("a download of the wall-slot count", [&] { return e_.listed_wall_slots(); });
  }
  std::string profile_report() const override { return e_.profile_report(); }
  void set_sort_every(std::uint32_t builds) override { e_.set_sort_every(builds); }
  std::uint64_t body_sorts() const override { return e_.body_sorts(); }
  std::vector<std::uint32_t> body_order() override {
    return thrust_errors_named("a download of the body order", [&] { return e_.body_order(); });
  }
  std::vector<std::pair<std::uint32_t, std::uint32_t>> list_pairs(std::size_t* unmirrored) override {
    return thrust_errors_named("a download of the list", [&] { return e_.list_pairs(unmirrored); });
  }

 private:
  Engine e_;
};

std::unique_ptr<DeviceEngine> make_engine(sim::Simulation& host) {
  {
    const LaunchSwitches sw = launch_switches();  // (checked: BIODEM_GPU_BLOCK, _ROW_LANES, _BUILD_LANES)
    launch_block() = sw.block;
    pdl_launch() = sw.pdl;  // (and the device's compute capability, below)
    row_lanes_log2() = sw.row_lanes_log2;
    build_lanes_log2() = sw.build_lanes_log2;
  }
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
                "." + std::to_string(prop.minor) + "; the GPU engine needs 8.0 or later");
  {
    // Whether this build holds code the device can run (a binary for its architecture, or PTX it
    // can compile): asked before any output is made, instead of failing at the first launch.
    cudaFuncAttributes fa{};
    const cudaError_t fe = cudaFuncGetAttributes(&fa, for_each_index<KickDriftSpheres>);
    (void)cudaGetLastError();
    if (fe != cudaSuccess)
      throw Error(std::string("--device gpu: this build has no kernels ") + prop.name + " (compute capability " +
                  std::to_string(prop.major) + "." + std::to_string(prop.minor) + ") can run (" +
                  cudaGetErrorString(fe) + "); rebuild with CMAKE_CUDA_ARCHITECTURES including " +
                  std::to_string(prop.major) + std::to_string(prop.minor));
  }
  // Programmatic launches need the kernels' wait (after_previous_kernel), which is compiled only
  // for compute_90 and later: not on an older device, nor from a build without sm_90 code (PTX
  // of an older target run on a Hopper GPU).
  if (prop.major < 9) pdl_launch() = false;
  one_wave_threads() = static_cast<std::uint32_t>(prop.multiProcessorCount) * 512u;
  if (pdl_launch()) {
    cudaFuncAttributes fa{};
    if (cudaFuncGetAttributes(&fa, for_each_index<KickDriftSpheres>) != cudaSuccess || fa.ptxVersion < 90)
      pdl_launch() = false;
    (void)cudaGetLastError();
  }
  const std::string name = std::string(prop.name) + " (sm_" + std::to_string(prop.major) +
                           std::to_string(prop.minor) + ", " + std::to_string(prop.multiProcessorCount) +
                           " SMs, CUDA)";
  return thrust_errors_named("the engine's set-up", [&] { return std::make_unique<NamedErrorsEngine>(host, name); });
}
}  // namespace biodem::gpu::cuda_device
