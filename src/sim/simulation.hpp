// The DEM engine: particle stores, walls, pair tables, neighbour list and the velocity-Verlet
// time step. Built from plain values (no TOML, no files); the run driver in src/driver feeds it
// from a case and writes outputs.
//
// One time step (velocity Verlet, Allen & Tildesley sec. 3.2; rotation of clumps by the
// symplectic splitting in integrate/rigid_rotation.hpp):
//   1. half kick  v += dt/2 F/m,  L += dt/2 T (spheres: omega += dt/2 T/I)
//   2. drift      x += dt v, orientation advanced by the free-rotor splitting
//   3. spheres placed from their bodies, and the displacement since the last list build tested
//      (1-3 are one parallel pass over the bodies)
//   4. serial, rare: sinks, lost bodies, spatial sort and neighbour-list rebuild when a sphere
//      moved more than skin/2
//   5. one parallel region: each thread owns a contiguous block of bodies (cut for equal work
//      at each list build) and evaluates its spheres' list rows (each entry written by one
//      thread); one barrier; then each sphere gathers its entries and its wall contacts in a
//      fixed order, each body sums its spheres (force with gravity, torque about the centre of
//      mass) and gets the second half kick.
//   6. step(true), when the caller will not read the state before the next step: right after
//      its kick each block of bodies gets the next step's 1-3 (the same functions on the same
//      data, while they are in the cache), and the next step begins at 4.
// Determinism: no atomics or thread-order-dependent sums anywhere; the result is bit-identical
// for any number of threads on the same build.
#pragma once
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "contact/contact_model.hpp"
#include "contact/pair_table.hpp"
#include "neighbor/verlet_list.hpp"
#include "sim/pair_pass.hpp"
#include "shapes/clump_template.hpp"
#include "sim/sink.hpp"
#include "state/particle_store.hpp"
#include "walls/wall_translation.hpp"
#include "walls/wall_geometry.hpp"

namespace biodem::sim {

struct WallSpec {
  walls::WallGeometry geometry;
  std::uint16_t material = 0;
  bool drum_wall = false;            // turns with the drum when rotation is on
  double drum_sign = 1.0;            // +1 / -1: orientation of the wall normal along the drum axis
  // Prescribed translation: the wall moves at translation_velocity_m_s from move_start_s to
  // move_end_s (simulation time) and rests before and after; its position is a function of the
  // time only (point at t = initial point + velocity * clamp(t - start, 0, end - start)).
  Vec3 translation_velocity_m_s;
  double move_start_s = 0.0, move_end_s = 0.0;
  bool translates() const { return move_end_s > move_start_s && norm2(translation_velocity_m_s) > 0.0; }
};

/// Sparse wall contact table (CSR by sphere): the walls each sphere may touch before the next
/// neighbour build (candidates), with their contact history. Walls within reach (radius + skin)
/// at the last build, walls still touching, and every translating wall are candidates; memory
/// is per candidate, not per sphere and wall, so any number of walls works.
struct WallContacts {
  std::vector<std::uint32_t> start{0};  // n_spheres + 1
  std::vector<std::uint32_t> wall;
  std::vector<contact::ContactHistory> history;
  std::vector<std::uint8_t> touching;
};

/// Where bodies must stay (issue 10, "lost particles"): inside the drum (centre no farther from
/// the axis than the mantle radius plus the body's bounding radius, and, with end plates,
/// between them within that radius) or inside an explicit box: the [run] bounds box, or else the
/// [domain] box of an explicit scene (its periodic axes excepted). Checked at every neighbour build.
struct LostRegion {
  enum class Kind { None, Drum, Box };
  Kind kind = Kind::None;
  double radius_m = 0.0, z0_m = 0.0, z1_m = 0.0;  // drum: axis z through the origin
  bool periodic_z = false;
  Vec3 min_m, max_m;                         // box
  bool box_periodic[3] = {false, false, false};  // box: axes not checked (periodic [domain] axes)
  const char* box_name = "[run] bounds box";     // named in the error
  bool remove = false;  // false: a lost body stops the run with an error; true: it is removed and counted
};

/// Wall-clock time spent in the phases of the CPU step (run --profile), summed over steps.
struct StepProfile {
  std::uint64_t steps = 0, builds = 0;
  double step_s = 0.0;        // whole steps
  double drift_s = 0.0;       // half kick, drift, sphere placement, displacement test
  double list_s = 0.0;        // sinks, lost bodies, sorting and list rebuilds
  double pairs_s = 0.0;       // pair rows, up to the barrier (the slowest thread)
  double pairs_busy_s = 0.0;  // pair rows, mean over threads of their own time (balance = busy / pairs)
  double gather_s = 0.0;      // gather, wall contacts, body sums, second half kick
};

struct BodyInit {
  std::uint32_t shape = 0;
  std::uint16_t material = 0;
  Vec3 position_m;
  Vec3 velocity_m_s;
  Vec3 angular_velocity_rad_s;
  Quat orientation;  // body (principal) frame -> lab
};

class Simulation {
 public:
  Simulation(std::vector<shapes::ClumpTemplate> templates, std::vector<double> material_density_kg_m3,
             contact::PairTable pairs, double dt_s, Vec3 gravity_m_s2);

  // --- set-up ---
  std::uint32_t add_wall(const WallSpec& w);
  std::uint32_t add_body(const BodyInit& b);
  void add_sink(const SinkSpec& s) { sinks_.push_back(s); }
  void set_lost_region(const LostRegion& r) { lost_region_ = r; }
  const LostRegion& lost_region() const { return lost_region_; }
  /// Bodies removed because they left the LostRegion (with lost_particles = "remove").
  std::uint64_t lost_bodies() const { return lost_bodies_; }
  void set_lost_bodies(std::uint64_t n) { lost_bodies_ = n; }
  /// Checks every body against the LostRegion: throws biodem::Error naming the first lost body
  /// (id, position, time), or removes the lost ones when the region says so.
  void check_lost_bodies();
  /// Stops the run with one line naming the first body whose position is not finite (an
  /// unstable run: not a lost body, nor one inside a sink, in any lost_particles mode).
  void check_finite_bodies() const;
  /// Starts a prescribed translation of wall k now (it rests before): velocity v from t0 to t1.
  void start_wall_translation(std::size_t k, const Vec3& v, double t0, double t1) {
    set_wall_translation(k, walls_[k].geometry.point_m, v, t0, t1);
  }
  /// The full schedule (checkpoints): point at t = initial + v clamp(t - t0, 0, t1 - t0).
  void set_wall_translation(std::size_t k, const Vec3& initial_point_m, const Vec3& v, double t0, double t1) {
    wall_initial_point_m_[k] = initial_point_m;
    walls_[k].translation_velocity_m_s = v;
    walls_[k].move_start_s = t0;
    walls_[k].move_end_s = t1;
    update_wall_motion(time_s_);
    if (list_valid_) update_wall_candidates();  // a moving wall is a candidate of every sphere
  }
  const Vec3& wall_initial_point_m(std::size_t k) const { return wall_initial_point_m_[k]; }
  /// Wall k's translation schedule (walls/wall_translation.hpp; meaningful when it translates()).
  walls::WallTranslation translation_of_wall(std::size_t k) const {
    const WallSpec& w = walls_[k];
    return walls::WallTranslation{wall_initial_point_m_[k], w.translation_velocity_m_s, w.move_start_s, w.move_end_s};
  }
  /// Puts the translating walls where their schedules have them at time t (the CPU engine does so
  /// at each step; the GPU engine moves its own copies and calls this when it brings the host up
  /// to date).
  void update_wall_motion(double t);
  const std::vector<SinkSpec>& sinks() const { return sinks_; }
  /// Removes the bodies flagged (by storage index) with their spheres and contacts; the others
  /// keep their stable ids and their contact history. Counts them and their mass as removed.
  std::size_t remove_bodies(const std::vector<std::uint8_t>& remove);
  /// Removes the bodies whose centre is inside a sink: the CPU engine after the drift of each
  /// step, the GPU engine at its list checks (after a drift too).
  void apply_sinks();
  /// Bodies removed so far (sinks and remove_bodies) and their total mass.
  std::uint64_t removed_bodies() const { return removed_bodies_; }
  double removed_mass_kg() const { return removed_mass_kg_; }
  void set_removed(std::uint64_t n, double mass_kg) { removed_bodies_ = n; removed_mass_kg_ = mass_kg; }
  void set_domain(const neighbor::Domain& d) { domain_ = d; }
  void set_skin(double skin_m) { skin_m_ = skin_m; }
  /// Spatial re-sorting period in neighbour-list builds (0: never).
  void set_sort_every_builds(std::size_t n) { sort_every_builds_ = n; }
  /// Drum walls turn at this angular velocity (rad/s, about the drum axis) while rotation is on.
  void set_drum_angular_velocity(double omega_rad_s) { drum_omega_ = omega_rad_s; apply_drum_rotation(); }
  void set_drum_rotation(bool on) { drum_rotating_ = on; apply_drum_rotation(); }
  /// EPSD2 at walls with the particle's own angular velocity (LIGGGHTS 3.8.0, "lab") instead of
  /// its velocity relative to the wall (default, SPEC 2.3).
  void set_wall_rolling_lab(bool lab) { wall_rolling_lab_ = lab; }
  bool wall_rolling_lab() const { return wall_rolling_lab_; }
  bool drum_rotating() const { return drum_rotating_; }

  // --- stepping ---
  /// One step. next_follows: the caller makes the next step before it reads or changes anything
  /// (outputs, energies, insertion, checkpoints); the step then ends with the next step's half
  /// kick, drift and placement done (steps_ahead()), and the state may not be read until
  /// step() is called again (the accessors throw). Same results either way.
  void step(bool next_follows = false);
  /// True between a step(true) and the next step: the state is half a step ahead.
  bool steps_ahead() const { return ahead_; }
  /// Per-phase timers of step() (off by default: they read the clock a few times per step).
  void set_profile(bool on) { profile_on_ = on; }
  /// The implementation of the sphere-sphere contacts (sim/pair_pass.hpp): by default the widest
  /// SIMD kernel the CPU supports, or the one BIODEM_PAIR_KERNEL names. Same results with any.
  void set_pair_kernel(PairKernel k) { pair_kernel_ = k; }
  PairKernel pair_kernel() const { return pair_kernel_; }
  const StepProfile& profile() const { return profile_; }
  void reset_profile() { profile_ = {}; }
  /// n steps, each but the last with next_follows (the state is readable afterwards).
  void run_steps(std::uint64_t n) { for (std::uint64_t i = 0; i < n; ++i) step(i + 1 < n); }

  // --- state and diagnostics ---
  double time_s() const { return time_s_; }
  void set_time_s(double t) { time_s_ = t; }
  std::uint64_t step_count() const { return steps_; }
  void set_step_count(std::uint64_t n) { steps_ = n; }
  double dt_s() const { return dt_s_; }
  Vec3 gravity_m_s2() const { return gravity_; }
  /// True when body forces are those of the current state (after refresh(), a step or a restore).
  bool forces_current() const { return forces_valid_ && list_valid_; }
  /// The GPU engine downloaded new body states: sphere arrays are recomputed from them on access.
  void mark_spheres_stale() { spheres_stale_ = true; }
  void set_contact_count(std::size_t n) { contacts_ = n; }
  /// Recomputes the wall candidates of every sphere from the list's build positions, keeping
  /// the entries (and history) of touching walls (the GPU engine's download uses it).
  void refresh_wall_candidates() { update_wall_candidates(); }
  const state::SphereStore& spheres() const {
    require_not_ahead();
    if (spheres_stale_) const_cast<Simulation*>(this)->update_spheres_from_bodies();
    return spheres_;
  }
  const state::BodyStore& bodies() const {
    require_not_ahead();
    return bodies_;
  }
  state::SphereStore& spheres_mut() {
    require_not_ahead();
    if (spheres_stale_) update_spheres_from_bodies();
    return spheres_;
  }
  state::BodyStore& bodies_mut() {
    require_not_ahead();
    return bodies_;
  }
  const std::vector<shapes::ClumpTemplate>& templates() const { return templates_; }
  const std::vector<WallSpec>& walls() const { return walls_; }
  const neighbor::VerletList& neighbor_list() const { return list_; }
  neighbor::VerletList& neighbor_list_mut() {
    require_not_ahead();
    return list_;
  }
  WallContacts& wall_contacts() { return wall_contacts_; }
  const WallContacts& wall_contacts() const { return wall_contacts_; }
  const contact::PairTable& pair_table() const { return pairs_; }
  double skin_m() const { return skin_m_; }
  const neighbor::Domain& domain() const { return domain_; }

  double kinetic_energy_j() const;          // translational + rotational, all bodies
  double translational_kinetic_energy_j() const;  // sum of m v^2 / 2 (serial, reproducible)
  std::size_t contact_count() const { return contacts_; }  // touching pairs + wall contacts (last force evaluation)
  double elastic_energy_j() const;          // Hertz normal elastic energy of all open contacts
  Vec3 linear_momentum() const;
  Vec3 angular_momentum_about_origin() const;
  Vec3 center_of_mass_m() const;
  double total_mass_kg() const;

  /// Recomputes sphere positions from bodies and forces from scratch (after set-up).
  void refresh();
  /// After the stores, histories and neighbour list were loaded from a checkpoint: restores the
  /// clock and bookkeeping without recomputing anything, so the run continues bit for bit.
  void restore_after_checkpoint(double time_s, std::uint64_t steps, bool rotating, double skin_m,
                                std::vector<Vec3> list_built_at, std::size_t list_builds);

 private:
  /// Throws biodem::Error (an internal error: a caller broke step(true)'s promise) while the
  /// state is half a step ahead.
  void require_not_ahead() const;
  void update_spheres_from_bodies();
  void place_spheres_of(std::size_t b);
  int drift_bodies(std::size_t b0, std::size_t b1, bool have_built, double limit2);
  /// drift_bodies; with KickFirst preceded, body by body, by reduce_and_kick(.., true)'s work.
  template <bool KickFirst>
  int advance_bodies(std::size_t b0, std::size_t b1, bool have_built, double limit2);
  /// The whole step in one parallel region when no list rebuild is due (false: drifted only).
  bool step_in_one_region(bool ahead_next);
  /// The team's job: (drift, barrier, rebuild test,) pair rows, barrier, gather/walls/sums/kick.
  template <bool Cohesion, bool Rolling>
  bool step_job(bool drift, bool kick, bool ahead_next);
  /// Contact forces, body sums and (with kick) the second half kick, in one parallel region.
  void forces_and_kick(bool kick, bool ahead_next = false);
  PairPassData pair_pass_data();
  template <bool Cohesion, bool Rolling>
  std::size_t gather_and_walls(std::size_t i0, std::size_t i1);
  template <bool Cohesion, bool Rolling>
  std::size_t gather_and_wall_batches(std::size_t i0, std::size_t i1, void (*evaluate)(WallBatch&));
  void reduce_and_kick(std::size_t b0, std::size_t b1, bool kick);
  /// Cuts the bodies into one block of about equal work per thread (block_body_).
  void update_work_blocks();
  void ensure_work_blocks();
  void apply_drum_rotation();
  /// Renumbers bodies (and their spheres) in cell order so that neighbours are close in memory;
  /// remaps the contact history. Stable ids are kept in BodyStore::id.
  void reorder_spatially();
  /// Takes renumbered stores (re-sort, removal) with the wall slots and the list remapped.
  void adopt_renumbered(state::BodyStore&& nbs, state::SphereStore&& nss,
                        const std::vector<std::uint32_t>& old_sphere_of_new,
                        const std::vector<std::uint32_t>& new_of_old_sphere);
  /// Rebuilds the list and the per-sphere wall candidate masks.
  void rebuild_neighbors();
  /// Walls within r + skin of each sphere at the last build (spheres move less than skin/2
  /// between builds, so no other wall can be touched before the next build).
  void update_wall_candidates();
  /// Places translating walls where their schedule puts them at time t and sets their velocity.

  std::vector<shapes::ClumpTemplate> templates_;
  std::vector<double> density_;
  contact::PairTable pairs_;
  double dt_s_;
  Vec3 gravity_;
  std::vector<WallSpec> walls_;
  state::SphereStore spheres_;
  state::BodyStore bodies_;
  neighbor::Domain domain_;
  neighbor::VerletList list_;
  double skin_m_ = -1.0;
  WallContacts wall_contacts_;
  std::vector<Vec3> wall_initial_point_m_;  // point_m of each wall at t = 0 (translating walls)
  std::vector<SinkSpec> sinks_;
  LostRegion lost_region_;
  std::uint64_t lost_bodies_ = 0;
  std::uint64_t removed_bodies_ = 0;
  double removed_mass_kg_ = 0.0;
  bool list_valid_ = false;
  bool spheres_stale_ = false;  // sphere velocities lag the bodies' second half kick
  bool ahead_ = false;        // the next step's half kick, drift and placement are done (step(true))
  bool ahead_moved_ = false;  // ... and a sphere moved more than skin/2 in it
  bool forces_valid_ = false;
  double drum_omega_ = 0.0;
  bool drum_rotating_ = false;
  double time_s_ = 0.0;
  std::uint64_t steps_ = 0;
  std::size_t contacts_ = 0;
  bool cohesion_ = false, rolling_ = false;
  bool wall_rolling_lab_ = false;
  std::size_t sort_every_builds_ = 16;
  std::vector<std::uint8_t> ahead_moved_by_;     // per block: the same for the drift made ahead
  std::vector<std::uint8_t> block_moved_;        // per block: a sphere moved more than skin/2
  static constexpr int kChunksPerThread = 8;     // work chunks per thread (stealing, see ChunkCursors)
  static constexpr std::size_t kGatherPiece = 256;  // bodies per piece of the gather-kick-drift pass
  int threads_ = 1;                              // team size the chunks were cut for
  std::vector<std::size_t> block_body_;          // work chunks: bodies [block_body_[k], block_body_[k+1])
  std::pair<std::size_t, std::size_t> blocks_for_;  // (bodies, threads) the blocks were cut for
  bool profile_on_ = false;
  StepProfile profile_;
  PairKernel pair_kernel_ = PairKernel::Scalar;  // set in the constructor (best available)
};

}  // namespace biodem::sim
