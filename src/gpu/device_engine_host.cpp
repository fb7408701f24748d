// The GPU engine on CPU threads: the kernels of gpu/kernels.hpp launched through Thrust's OpenMP
// system. Slow next to the CPU engine (full neighbour list, every contact evaluated twice); it
// exists so that the GPU engine's physics runs in the tests on machines without a GPU.
#include <thrust/for_each.h>
#include <thrust/transform_reduce.h>
#include <thrust/iterator/counting_iterator.h>
#include <thrust/system/cpp/execution_policy.h>
#include <thrust/system/omp/execution_policy.h>
#include <thrust/system/omp/vector.h>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "gpu/device_engine.hpp"
#include "core/parallel.hpp"

#define BIODEM_GPU_NS host_threads
namespace biodem::gpu::host_threads {
// Kernels over at least kParallelThreshold indices run on the OpenMP threads, smaller ones on
// the calling thread (as the CPU engine's loops: waking a team costs more than small work, and
// on a loaded machine a waiting team stalls for milliseconds). Sorts, scans and reductions run
// on the calling thread: O(n) once per list check, and their summation order then does not
// depend on the thread count.
/// The walks of walk_packed, each with a group of one lane (defined after the kernels, below);
/// false when W is not such a walker (kernels.hpp, WalksPacked).
template <class W>
bool run_packed_walks(std::uint32_t n, const W& w);

struct System {
  template <class T>
  using vector = thrust::omp::vector<T>;
  static auto exec() { return thrust::cpp::par; }
  static auto queue() { return thrust::cpp::par; }
  /// Test hook BIODEM_TEST_GPU_FAULT_AT_STEP: on CPU threads no kernel can fault, so the fault
  /// is marked, and the next read of a queued result, wait or download throws what a fault on
  /// a GPU gives there (the kernels in between still run: no state from them is read).
  static bool& faulted() {
    static bool f = false;
    return f;
  }
  static void inject_fault() { faulted() = true; }
  static void throw_if_faulted() {
    if (faulted())
      throw DeviceFault("GPU engine: a kernel faulted on the device (the fault injected by "
                        "BIODEM_TEST_GPU_FAULT_AT_STEP, CPU threads); the device cannot go on in this run: --resume "
                        "continues from the last checkpoint");
  }
  /// Waits for the launched work (BIODEM_GPU_PROFILE): here every launch has returned already.
  static void wait() { throw_if_faulted(); }
  /// The list check's reduction, queued before the last step of a run of steps and read at the
  /// check after it (on CUDA it runs meanwhile): here computed when queued, in index order on
  /// the calling thread.
  template <class T>
  class Pending {
   public:
    template <class F, class Op>
    bool prepare(std::uint32_t, const F&, const Op&, const T&) {
      return false;
    }
    template <class F, class Op>
    void enqueue(std::uint32_t n, const F& f, const Op& op, const T& init) {
      value_ = thrust::transform_reduce(thrust::cpp::par, thrust::counting_iterator<std::uint32_t>(0),
                                        thrust::counting_iterator<std::uint32_t>(n), f, init, op);
    }
    T get() const {
      throw_if_faulted();
      return value_;
    }

   private:
    T value_{};
  };
  /// A small device value copied when queued (on CUDA: into pinned memory behind an event).
  template <class T>
  class PendingCopy {
   public:
    explicit PendingCopy(const char*) {}
    bool prepare() { return false; }
    void enqueue(const T* src) { value_ = *src; }
    T get() const {
      throw_if_faulted();
      return value_;
    }

   private:
    T value_{};
  };
  /// BIODEM_GPU_FORCES=auto picks the contact kernels by the sphere count here (timing them on
  /// CPU threads would say nothing of a GPU); =timed times them with this clock.
  static constexpr bool kTimedChoice = false;
  /// Threads of one wave of a GPU at 128 registers (the timed choice's split sets): here those
  /// of an H100 (132 SMs x 512), so that BIODEM_GPU_FORCES=timed makes the same sets as there.
  static std::uint32_t wave_threads() { return 132u * 512u; }
  class Timer {
   public:
    void start() { t0_ = std::chrono::steady_clock::now(); }
    double stop() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count(); }

   private:
    std::chrono::steady_clock::time_point t0_;
  };
  template <class F>
  static void launch(std::uint32_t n, const F& f) {
    if (n >= kParallelThreshold)
      thrust::for_each_n(thrust::omp::par, thrust::counting_iterator<std::uint32_t>(0), n, f);
    else
      for (std::uint32_t i = 0; i < n; ++i) f(i);
  }
  /// Row walks (kernels.hpp, walk_row): here one thread walks each item's row, whether or not
  /// `single` (one thread per item) is asked.
  /// packed (BIODEM_GPU_WALK_PACK=1): walk_packed with a group of one lane per item, one scratch
  /// per thread (the same bits; what the lanes of a warp do together is covered by
  /// tests/gpu/test_group_lanes.cpp).
  /// (split_log2, the lanes per item of packed walks on CUDA: here one lane, whatever asked)
  template <class W>
  static void launch_walks(std::uint32_t n, const W& w, bool /*single*/, bool packed = false,
                           std::uint32_t /*split_log2*/ = 0) {
    if (packed && run_packed_walks(n, w)) return;
    launch(n, w);
  }
  static std::string walk_lanes() { return "row lanes (on CPU threads, one thread per sphere too)"; }
  /// Items with a group of lanes each: here one thread per item, a group of one lane (f(i)).
  template <class F>
  static void launch_groups(std::uint32_t n, const F& f, std::uint32_t /*lanes_log2*/) {
    launch(n, f);
  }
  /// launch_groups with the groups' row walks sharing their touching contacts
  /// (WalkKickGroups::run_packed): here one thread per item, a group and a warp of one lane.
  template <class F>
  static void launch_groups_packed(std::uint32_t n, const F& f, std::uint32_t /*lanes_log2*/);
  /// The grouped list build (kernels.hpp, BuildRowsGrouped): here one thread runs each row's
  /// group as a group of one lane.
  template <class B>
  static void launch_row_builds(std::uint32_t n, const B& b) {
    launch(n, b);
  }
  static std::string build_lanes() { return "one lane per sphere (CPU threads)"; }
  /// Doubles of device memory that sum_into needs (the result in the first).
  static std::size_t sum_scratch(std::uint32_t) { return 1; }
  /// out[0] = f(0) + ... + f(n - 1) in index order, left in device memory (no host wait): the
  /// order of the sequential reductions of exec(), so the emulated settle criterion sees the bits
  /// the host-side reduction gave before it moved to the device.
  template <class F, class H>
  static void sum_into(std::uint32_t n, const F& f, double* out, const H& halt);
  /// download()'s batch of copies: here the device arrays are host memory, read in place.
  class Staging {
   public:
    std::size_t add(const void* src, std::size_t) {
      src_.push_back(src);
      return src_.size() - 1;
    }
    void run() { throw_if_faulted(); }
    const void* host(std::size_t item) const { return src_[item]; }
    void clear() { src_.clear(); }

   private:
    std::vector<const void*> src_;
  };
  /// CUDA graphs do not exist here: the engine launches plainly.
  struct Graphs {
    template <class R>
    bool prepare(std::uint64_t, R&) { return false; }
    template <class R>
    bool run(std::uint64_t, R&) { return false; }
    void clear() {}
  };
};
}  // namespace biodem::gpu::host_threads
#include "gpu/engine_impl.hpp"

namespace biodem::gpu::host_threads {
template <class F, class H>
void System::sum_into(std::uint32_t n, const F& f, double* out, const H& halt) {
  const SequentialSum<F> sum{f, n, out, halt};
  sum(0);
}

template <class F>
void System::launch_groups_packed(std::uint32_t n, const F& f, std::uint32_t) {
  launch(n, [&f](std::uint32_t k) {
    thread_local PackedWalkScratch<ContactArgs::EntryHead> sc;  // (one per thread, not zeroed per item)
    f.run_packed(k, true, OneLane{}, OneLane{}, sc);
  });
}

template <class W>
bool run_packed_walks(std::uint32_t n, const W& w) {
  if constexpr (!WalksPacked<W>::value) {
    (void)n;
    (void)w;
    return false;
  } else {
    System::launch(n, [&w](std::uint32_t i) {
      thread_local PackedWalkScratch<ContactArgs::EntryHead> sc;  // (one per thread, not zeroed per item)
      walk_packed(w, i, true, OneLane{}, sc);
    });
    return true;
  }
}
}  // namespace biodem::gpu::host_threads

namespace biodem::gpu::host_threads {
std::unique_ptr<DeviceEngine> make_engine(sim::Simulation& host) {
  return std::make_unique<Engine>(host, "CPU threads (the GPU engine's kernels through Thrust's OpenMP system)");
}
}  // namespace biodem::gpu::host_threads
