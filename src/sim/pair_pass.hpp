// The pair pass of the CPU engine: the sphere-sphere contacts of a range of neighbour-list rows
// (docs/performance.md). Each row's entries are written by the thread that evaluates the row; the
// row owner sums its own side (force and torque on i, in entry order) and stores for the j side
// what j gathers later (simulation_step.cpp, gather_and_walls).
//
// Two implementations of the same arithmetic:
// - scalar: one contact at a time (the reference);
// - lanes: the distance test runs entry by entry and stages the touching contacts' data in a
//   structure-of-arrays batch; the shared contact laws (src/contact, templates over the number
//   type) then evaluate W contacts at once in SIMD lanes (std::experimental::simd: W = 2 with
//   SSE2, 4 with AVX2, 8 with AVX-512F, each in its own translation unit built for that
//   instruction set, chosen at run time from what the CPU supports); the results are scattered
//   back and summed in entry order. Every lane does the scalar law's IEEE operations in the same
//   order and no translation unit contracts them into fused multiply-adds, so both give the same
//   bits (tests/unit/test_pair_pass.cpp).
// The sphere-wall contacts use the same lanes (WallBatch, evaluated in wall_pass_lanes*.cpp,
// staged by Simulation::gather_and_wall_batches) whenever the pair pass is not scalar.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>

#include "contact/pair_table.hpp"
#include "core/vec3.hpp"
#include "neighbor/verlet_list.hpp"
#include "state/particle_store.hpp"

namespace biodem::sim {

/// What the pair pass reads and writes (views into the Simulation's stores).
struct PairPassData {
  const Vec3* position_m = nullptr;
  const Vec3* velocity_m_s = nullptr;
  const Vec3* angular_velocity_rad_s = nullptr;
  const double* radius_m = nullptr;
  const double* body_mass_kg = nullptr;
  const std::uint16_t* material = nullptr;
  const contact::PairTable* pairs = nullptr;
  neighbor::VerletList* list = nullptr;
  Vec3* force_n = nullptr;     // written: the sum over the row's own entries
  Vec3* torque_n_m = nullptr;  // written: the same for the torque on i
  double dt_s = 0.0;
  bool periodic = false;
};

/// The views of a sphere store, its list and pair table (Simulation, benchmarks, tests).
PairPassData make_pair_pass_data(state::SphereStore& s, neighbor::VerletList& list, const contact::PairTable& pairs,
                                 double dt_s, bool periodic);

/// Which implementation evaluates the contacts: Scalar, or SIMD lanes of 2, 4 or 8 doubles.
enum class PairKernel { Scalar = 1, Lanes2 = 2, Lanes4 = 4, Lanes8 = 8 };

/// The widest kernel this build and this CPU support.
PairKernel best_pair_kernel();
/// True when this build has the kernel and the CPU can run it.
bool pair_kernel_available(PairKernel k);
/// "scalar", "2 lanes (SSE2)", "4 lanes (AVX2)", "8 lanes (AVX-512F)".
std::string pair_kernel_name(PairKernel k);
/// The kernel named by BIODEM_PAIR_KERNEL (scalar, 2, 4, 8; for measurements and tests), else the
/// best one. Throws biodem::Error when the variable names a kernel this machine cannot run.
PairKernel pair_kernel_from_environment();

/// Rows [i0, i1): evaluates their entries with the given kernel; returns the touching contacts.
template <bool Cohesion, bool Rolling>
std::size_t pair_rows(PairKernel kernel, const PairPassData& d, std::size_t i0, std::size_t i1);

// ---- internal: the staged batch and the per-width lane evaluators ---------------------------

/// Up to kCapacity touching contacts: the separation found by the distance test and the sphere
/// and entry indices (the evaluator gathers everything else), then the results as structure of
/// arrays.
struct PairBatch {
  enum Field : int {
    Dx, Dy, Dz, Dist2,
    Fx, Fy, Fz, Tix, Tiy, Tiz, Tjx, Tjy, Tjz,  // outputs
    Xix, Xiy, Xiz, Mrx, Mry, Mrz,  // the updated history
    kFields
  };
  static constexpr int kCapacity = 64;  // a multiple of the widest lane count
  // Each field's row is 8 doubles longer than the capacity, so that the rows do not start at the
  // same address modulo 4 KiB (loads would wait on unrelated stores: 4K aliasing).
  static constexpr int kStride = kCapacity + 8;
  alignas(64) double a[kFields][kStride];
  alignas(64) std::uint32_t i[kCapacity], j[kCapacity], k[kCapacity];
  const contact::PairParams* params[kCapacity];
  int n = 0;  // contacts staged; slots up to the next multiple of 8 repeat the last one
  const PairPassData* data = nullptr;
};

/// Up to kCapacity touching sphere-wall contacts (simulation_step.cpp, gather_and_walls): what
/// the scalar wall loop computed before the contact law (the wall's normal and gap, its surface
/// velocity and spin at the contact), the sphere and wall-slot indices and the pair parameters;
/// then the results. The sphere's radius, mass, velocity and spin are gathered by index.
struct WallBatch {
  enum Field : int {
    Nx, Ny, Nz, Gap, Vwx, Vwy, Vwz, Wwx, Wwy, Wwz,  // inputs
    Fx, Fy, Fz, Tix, Tiy, Tiz,  // outputs
    Xix, Xiy, Xiz, Mrx, Mry, Mrz,  // the wall slot's history: in, then updated
    kFields
  };
  static constexpr int kCapacity = 64;
  static constexpr int kStride = kCapacity + 8;
  alignas(64) double a[kFields][kStride];
  alignas(64) std::uint32_t i[kCapacity], slot[kCapacity];
  const contact::PairParams* params[kCapacity];
  int n = 0;
  const state::SphereStore* spheres = nullptr;
  double dt_s = 0.0;
};

// Each evaluates slots [0, n rounded up to its width) of the batch. BIODEM_SIMD_LANES: the
// compiler has <experimental/simd> (CMakeLists.txt); without it the pass is scalar only.
#if defined(BIODEM_SIMD_LANES)
template <bool Cohesion, bool Rolling> void evaluate_batch_lanes2(PairBatch& b);
template <bool Cohesion, bool Rolling> void evaluate_wall_batch_lanes2(WallBatch& b);
#endif
#if defined(BIODEM_X86_LANES)
template <bool Cohesion, bool Rolling> void evaluate_batch_lanes4(PairBatch& b);
template <bool Cohesion, bool Rolling> void evaluate_batch_lanes8(PairBatch& b);
template <bool Cohesion, bool Rolling> void evaluate_wall_batch_lanes4(WallBatch& b);
template <bool Cohesion, bool Rolling> void evaluate_wall_batch_lanes8(WallBatch& b);
#endif
/// The wall batch evaluator of a pair kernel (nullptr for the scalar kernel).
template <bool Cohesion, bool Rolling> void (*wall_batch_evaluator(PairKernel k))(WallBatch&);

}  // namespace biodem::sim
