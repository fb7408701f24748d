// The GPU engine (docs/gpu.md): the time step of sim::Simulation - the same force laws (the
// BIODEM_HD headers in src/contact, src/walls, src/integrate), the same walls, periodic axis and
// clumps - executed as data-parallel kernels over a copy of the state held on the device.
//
// The host Simulation stays the owner of the run: it is built from the case, inserts particles,
// writes outputs and checkpoints. The engine uploads its state (bodies, spheres, contact history
// of pairs and walls), steps on the device, and downloads the state into the host Simulation
// (positions and velocities for samples; everything, contact history included, for checkpoints
// and between insertion waves), so a checkpoint has one format whatever device wrote it.
//
// Backends: `Cuda` (built when CMake finds a CUDA compiler; kernels launched through Thrust's
// CUDA system) and `HostThreads` (the same kernel functors launched through Thrust's OpenMP
// system on CPU threads: the tests run the GPU engine's physics on every commit without a GPU).
//
// Results do not depend on the storage order of spheres or on when the neighbour list is
// rebuilt: every sphere sums its pair contacts in the order of its neighbours' stable ids, then
// its walls in wall order, and every pair is evaluated from the side of its lower stable id
// (by both spheres' threads in the row walk, with identical arithmetic, so the two copies of the
// pair's history in the full neighbour list stay bit-identical and the two forces are exact
// opposites; once, for both entries, by the entry kernels). A run resumed on the same device and
// build therefore continues bit for bit.
#pragma once
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/error.hpp"
#include "sim/simulation.hpp"

namespace biodem::gpu {

enum class Backend { Cuda, HostThreads };

/// Most walls a sphere is tested against each step (the drum has three); make_device_engine
/// refuses a scene with more.
inline constexpr std::size_t kMaxDeviceWalls = 16;

/// True when this biodem was built with the CUDA engine.
bool cuda_built();

/// The CUDA engine's launch switches, read from the environment and checked by
/// make_device_engine for either backend (a bad value stops a run on CPU threads too, before
/// anything is computed), applied by the CUDA engine: BIODEM_GPU_BLOCK (threads per block of
/// the one-index kernels: 32, 64, 128, 256, 512) and BIODEM_GPU_ROW_LANES (lanes per row walk:
/// 1, 2, 4, 8, 16, 32) and BIODEM_GPU_BUILD_LANES (lanes per row of a list build: 1, which is
/// one thread per sphere (BuildRows) on either backend, or 2, 4, 8, 16, 32: BuildRowsGrouped)
/// and BIODEM_GPU_PDL (1, the default: the step kernels with programmatic dependent launch on
/// compute capability 9.0 and later; 0: plain launches).
struct LaunchSwitches {
  std::uint32_t block = 64;  // (H100: 64 faster than 128 by ~1.4 us/step at 20k and 40k spheres, docs/gpu.md)
  std::uint32_t row_lanes_log2 = 2;    // 4 lanes (H100: faster than 16 on every bench drum, docs/gpu.md)
  std::uint32_t build_lanes_log2 = 4;  // 16 lanes
  bool pdl = true;                     // BIODEM_GPU_PDL: programmatic dependent launch (sm_90+)
};
/// Throws Error naming the variable when a value is not one of those listed.
LaunchSwitches launch_switches();

/// A fault on the device: a kernel faulted and the CUDA context is lost, so nothing more can
/// run on the device in this process. The engine's fallbacks (a queued list check or settle poll
/// that cannot be read, a graph that cannot be captured) rethrow it rather than go on, so the
/// run ends with this one line.
class DeviceFault : public InternalError {  // (exit status 3)
 public:
  using InternalError::InternalError;
};

class DeviceEngine {
 public:
  virtual ~DeviceEngine() = default;
  /// Copies the complete state of `host` to the device (after set-up, insertion or a restore).
  virtual void upload() = 0;
  /// Makes the host Simulation current: bodies (and, from them, spheres), forces, clock, contact
  /// count; with `history`, also a fresh host neighbour list carrying the device's pair history
  /// and the wall history, so that the host can checkpoint, insert or continue on the CPU.
  virtual void download(bool history) = 0;
  /// One velocity-Verlet step on the device; advances the host's clock (time and step count).
  virtual void step() = 0;
  /// Up to `max_steps` velocity-Verlet steps on the device without a host wait between list
  /// checks (on CUDA: the steps between two checks as one CUDA graph, docs/gpu.md). With a settle
  /// criterion begun (begin_settle), the device evaluates it after every step and the steps after
  /// the one that meets it do nothing; the host learns it at the next list check or at the end.
  /// Returns the steps made (fewer than `max_steps` only when the criterion was met) and leaves
  /// the host's clock after them, as that many calls of step() would.
  struct Advanced {
    std::uint64_t steps = 0;
    std::uint64_t below = 0;  // settle criterion: consecutive steps below the threshold so far
    bool settled = false;     // the criterion was met at the last step made
  };
  virtual Advanced advance(std::uint64_t max_steps) = 0;
  /// The settle criterion of a phase (the run driver's rule, SPEC 5): after step k of the phase,
  /// below = (mean kinetic energy per body < threshold) ? below + 1 : 0; settled when
  /// k >= min_steps and below >= hold_steps. Evaluated on the device by advance() from phase step
  /// `phase_step` with counter `below` (both from a checkpoint when resumed) until end_settle().
  struct SettleCriterion {
    double threshold_j = 0.0;   // mean kinetic energy per body
    bool translational = false; // m v^2 / 2 only
    std::uint64_t min_steps = 0, hold_steps = 1;
  };
  virtual void begin_settle(const SettleCriterion& c, std::uint64_t phase_step, std::uint64_t below) = 0;
  virtual void end_settle() = 0;
  /// Total kinetic energy of all bodies (one device reduction).
  virtual double kinetic_energy_j() = 0;
  virtual double translational_kinetic_energy_j() = 0;  // sum of m v^2 / 2
  /// Re-reads the host walls (their prescribed angular velocities change with the drum phases).
  virtual void sync_walls() = 0;
  /// A new phase starts (the driver calls it at each): the timed choice of the contact kernels
  /// (BIODEM_GPU_FORCES=timed, the default on a GPU) times its sets again from the next run of
  /// steps, since the bed's contacts may differ from those it was timed on. No effect otherwise.
  virtual void retime_kernels() = 0;
  /// Steps of the chosen set after which the timed choice times the sets again (default 20,000);
  /// for tests.
  virtual void set_retime_every(std::uint64_t steps) = 0;
  /// Device description for run.log ("NVIDIA H100 80GB HBM3 (sm_90, CUDA)").
  virtual std::string device_name() const = 0;
  /// Steps between two neighbour-list checks (default 10); for tests and tuning.
  virtual void set_check_every(std::uint32_t steps) = 0;
  /// Neighbour-list builds on the device so far.
  virtual std::uint64_t list_builds() const = 0;
  /// List checks that read the motion (largest displacement and speed) that the check before
  /// them started on the device, so without waiting for it (all but the first after an upload;
  /// docs/gpu.md).
  virtual std::uint64_t waitless_list_checks() const = 0;
  /// Times the list guard stopped the device after a drift that took a sphere past half the skin
  /// (the steps launched after it taken back, the list rebuilt there; docs/gpu.md).
  virtual std::uint64_t guard_stops() const = 0;
  /// Removal tests (sinks, lost bodies with lost_particles = "remove": a count on the device
  /// every 10th step) made, and those that removed bodies (each a download and an upload).
  virtual std::uint64_t removal_tests() const = 0;
  virtual std::uint64_t removal_uploads() const = 0;
  /// Runs of steps (between two list checks) launched as one CUDA graph, and launched kernel by
  /// kernel (graphs off, a failed capture, runs longer than a graph holds, CPU threads).
  virtual std::uint64_t graph_runs() const = 0;
  virtual std::uint64_t plain_runs() const = 0;
  /// The list build's rows by a group of lanes per sphere (BuildRowsGrouped: 16 lanes on a GPU,
  /// BIODEM_GPU_BUILD_LANES; one thread running the same code on CPU threads) or by one thread
  /// per sphere scanning its 27 cells (BuildRows): the same rows and history, so the same bits.
  /// On by default (BIODEM_GPU_BUILD_LANES=1 or this switch: off); rows wider than 128 entries
  /// are always built by BuildRows. grouped_list_builds() counts the row builds of the first
  /// kind; list_build_kernel() says which runs (run.log).
  virtual void set_grouped_list_build(bool on) = 0;
  virtual std::uint64_t grouped_list_builds() const = 0;
  virtual std::string list_build_kernel() const = 0;
  /// Times a list build found a row longer than the row capacity and rebuilt with wider rows,
  /// and the capacity now (entries per sphere); run.log reports both (scripts/gpu_check.sh).
  virtual std::uint64_t row_widenings() const = 0;
  virtual std::uint32_t row_capacity() const = 0;
  /// Between two list checks outside a settle-criterion phase, the body reduction of step c
  /// (ReduceKick) and the first half of step c + 1 (KickDriftSpheres) run as one kernel,
  /// ReduceKickDrift (same bits). On by default; off with BIODEM_GPU_FUSE=0 or this switch, for
  /// tests and comparisons. fused_steps() counts the steps whose halves were joined so far.
  virtual void set_fused_kick(bool on) = 0;
  virtual std::uint64_t fused_steps() const = 0;
  /// In a scene whose bodies are all single spheres, the fused steps with the entry kernels also
  /// sum each sphere's contacts inside the body kernel (SumEntriesKickDrift: one launch fewer,
  /// same bits); this counts those steps. (The row walk cannot move there: it reads the
  /// neighbours' positions, which the body kernel's drift changes.)
  virtual std::uint64_t sums_in_kick_steps() const = 0;
  /// The contact forces as one thread per row entry and wall slot (PairEntries) then one per
  /// sphere summing its row and walls in order (SumEntries), or one thread per sphere walking its
  /// row and walls (Forces): the same operations in the same order, so the same bits. By default
  /// timed on a GPU and chosen by the sphere count on CPU threads (entries below 15,000 spheres,
  /// docs/gpu.md section 4); BIODEM_GPU_FORCES=entries|rows|timed|auto or this switch for tests
  /// and comparisons.
  /// entry_force_passes() counts the steps whose forces the entry kernels evaluated.
  virtual void set_entry_forces(bool on) = 0;
  /// The entry kernels' per-sphere sums as a row walk shared by the row lanes (SumEntriesWalk,
  /// SumEntriesKickDriftWalk) or by one thread per sphere; the same bits. By default one of the
  /// timed sets on a GPU, one thread on CPU threads; BIODEM_GPU_SUM_LANES=1|0|auto or this switch.
  virtual void set_sum_lanes(bool on) = 0;
  /// The row walk and the body update in one kernel (single-sphere bodies: ForcesKickDrift;
  /// clumps of up to 32 spheres: ForcesKickDriftGroups, a group of lanes per body; the sphere
  /// motion in two buffers swapped every step) or apart; the same bits. By default one of the timed sets on a GPU, apart on CPU threads;
  /// BIODEM_GPU_WALK_KICK=1|0|auto or this switch. walk_kick_steps() counts its steps.
  virtual void set_walk_kick(bool on) = 0;
  virtual std::uint64_t walk_kick_steps() const = 0;
  /// Which contact kernels run and why (run.log): set by a switch, by the sphere count, or timed
  /// (BIODEM_GPU_FORCES=timed, and auto on a GPU: after each upload the first runs of steps
  /// between list checks alternate the two sets, each timed on the device, and the faster runs
  /// on; the same bits either way).
  virtual std::string contact_kernels() const = 0;
  virtual std::uint64_t entry_force_passes() const = 0;
  /// The order-free family (BIODEM_GPU_SUMS=fixed or this switch; docs/gpu.md section 2): the
  /// per-contact kernels add each contact's force and torque to its spheres' sums as 64-bit
  /// fixed-point integers (src/gpu/fixed_sums.hpp), in any order, so the sums are the same bits
  /// on any number of threads; each contribution is rounded to the grid of
  /// fixed_force_quantum() (N) and fixed_torque_quantum() (N m), chosen at upload from the case
  /// (0 when off). A contribution beyond the grid's range stops the run at the next list check.
  /// set_fixed_caps (for tests) sets the grid for contributions up to the given magnitudes
  /// instead. fixed_sum_passes() counts the steps whose sums were fixed-point.
  virtual void set_fixed_sums(bool on) = 0;
  virtual bool fixed_sums() const = 0;
  virtual double fixed_force_quantum() const = 0;
  virtual double fixed_torque_quantum() const = 0;
  virtual void set_fixed_caps(double force_cap_n, double torque_cap_n_m) = 0;
  virtual std::uint64_t fixed_sum_passes() const = 0;
  /// The per-contact passes run over lists of the pairs and of the wall slots within reach, made
  /// at each list build (BIODEM_GPU_PAIR_LIST=compact, the default), or over every row entry and
  /// wall slot (full): the same bits. For tests: the pairs in the list now, -1 when there is
  /// none (full).
  virtual std::int64_t listed_pairs() = 0;
  /// Likewise the wall slots (sphere, wall) in the list now: those whose sphere touched the wall
  /// or was within its radius plus the skin of it at the last build (walls::within_reach).
  virtual std::int64_t listed_wall_slots() = 0;
  /// With BIODEM_GPU_PROFILE=1: one line saying where the wall time of the steps went (step
  /// kernels between list checks, list checks, list builds, the rest), for run.log; empty
  /// otherwise. The host then waits for the device after each of them to time it.
  virtual std::string profile_report() const = 0;
  /// The bodies are stored on the device sorted by the neighbour-list cell of their first sphere
  /// (each body's spheres contiguous, in template order), re-sorted at the list build of every
  /// upload and every N-th build after it (N = 4 by default; BIODEM_GPU_SORT=N or this switch;
  /// 0: never). Results and downloads do not depend on it (docs/gpu.md). body_sorts() counts the
  /// sorts that reordered the bodies; body_order() gives, for each device slot, the host
  /// Simulation's index of the body stored there (for tests).
  virtual void set_sort_every(std::uint32_t builds) = 0;
  virtual std::uint64_t body_sorts() const = 0;
  virtual std::vector<std::uint32_t> body_order() = 0;
  /// For tests: the pairs (i < j, storage indices) of the current device list, sorted, and the
  /// number of row entries whose mirror entry (j's row holding i) is missing (0 in a valid list).
  virtual std::vector<std::pair<std::uint32_t, std::uint32_t>> list_pairs(std::size_t* unmirrored) = 0;
};

/// Creates an engine on `backend` bound to `host`. Throws biodem::Error with one line when the
/// backend is not built or no GPU is present.
std::unique_ptr<DeviceEngine> make_device_engine(Backend backend, sim::Simulation& host);

}  // namespace biodem::gpu
