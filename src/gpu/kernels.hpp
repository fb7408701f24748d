// The GPU engine's kernels: functors over one index (a body, a sphere), launched through Thrust
// (thrust::for_each_n over a counting iterator). The same functors compile with nvcc for the GPU
// and with g++ for CPU threads (Thrust's OpenMP system), so the tests execute this exact code.
// Every functor reads and writes flat arrays through raw pointers; no atomics, except the integer
// additions of the fixed-point sums (BIODEM_GPU_SUMS=fixed, fixed_sums.hpp), whose result does not
// depend on their order.
//
// This header lives in a namespace chosen by the including translation unit
// (BIODEM_GPU_NS), so that the CUDA and the host-threads instantiations never share a symbol.
#pragma once
#include <cstddef>
#include <cstdint>
#include <limits>

#include "contact/contact_model.hpp"
#include "core/hd.hpp"
#include "core/quat.hpp"
#include "core/vec3.hpp"
#include "gpu/fixed_sums.hpp"
#include "integrate/rigid_rotation.hpp"
#include "integrate/velocity_verlet.hpp"
#include "sim/sink.hpp"
#include "walls/wall_geometry.hpp"
#include "walls/wall_translation.hpp"

#ifndef BIODEM_GPU_NS
#error "define BIODEM_GPU_NS before including gpu/kernels.hpp"
#endif

namespace biodem::gpu::BIODEM_GPU_NS {

/// The list guard's words on the device (docs/gpu.md, "The list guard"; Engine::guard_): every
/// drift compares each sphere's new centre with its centre at the last list build, and one past
/// half the skin (or not finite) raises over[b], b the motion buffer the drift wrote (0: the
/// first, 1: the second of ForcesKickDrift's two); the kernels after it find the flag, raise
/// `stop` and do nothing, so the device stays after that drift, before any forces at its
/// positions, until the host rebuilds the list there (as the CPU engine does at such a step).
/// `drifts` counts the drifts made since the upload (at sphere 0), from which the host learns
/// how many of the steps it launched were made.
struct StepFlags {
  std::uint32_t stop = 0;
  std::uint32_t over[2] = {0u, 0u};
  std::uint32_t unused = 0;
  unsigned long long drifts = 0;
};
/// A flag written and read by the threads of one kernel (the guard's): on a GPU a plain load or
/// store of one aligned word; on CPU threads a relaxed atomic access (no data race).
BIODEM_HD inline std::uint32_t flag_load(const std::uint32_t* p) {
#ifdef __CUDA_ARCH__
  return *p;
#else
  return __atomic_load_n(p, __ATOMIC_RELAXED);
#endif
}
BIODEM_HD inline void flag_raise(std::uint32_t* p) {
#ifdef __CUDA_ARCH__
  *p = 1u;
#else
  __atomic_store_n(p, 1u, __ATOMIC_RELAXED);
#endif
}

/// Lowers the list guard's over flags (one thread, at a list build: the new list's positions are
/// those of now).
struct ClearGuardOver {
  StepFlags* guard;
  BIODEM_HD void operator()(std::uint32_t) const {
    guard->over[0] = 0u;
    guard->over[1] = 0u;
  }
};

/// What a step kernel reads at its entry to know whether to do nothing: the settle state's flag
/// in a criterion phase (once SettleUpdate found the criterion met, the later steps of the same
/// advance() do nothing, so the state stays that of the step that met it), and the list guard's
/// words (StepFlags). A kernel that raises an over flag never reads it (`ignore`): its own
/// threads may raise it while others start, and every thread of a kernel must decide from words
/// written before its launch, so that all decide alike. A kernel halted by an over flag raises
/// `stop`, which every later kernel reads. Default (set-up evaluations): never halted.
struct Halt {
  const std::uint32_t* settled = nullptr;
  StepFlags* guard = nullptr;
  std::uint32_t ignore = 0;  // bit b: over[b] not read (the kernel raises it)
};
BIODEM_HD inline bool halted(const Halt& h) {
  if (h.settled && *h.settled) return true;
  if (!h.guard) return false;
  StepFlags* g = h.guard;
  if (flag_load(&g->stop)) return true;
  if ((!(h.ignore & 1u) && flag_load(&g->over[0])) || (!(h.ignore & 2u) && flag_load(&g->over[1]))) {
    flag_raise(&g->stop);
    return true;
  }
  return false;
}

struct Int3 {
  std::int32_t x = 0, y = 0, z = 0;
};

/// A wall as the kernels see it: geometry (with its current prescribed angular velocity) and material.
struct DeviceWall {
  walls::WallGeometry geometry;
  std::uint32_t material = 0;
  std::uint32_t translates = 0;  // a prescribed translation (sim::WallSpec::translates): every sphere's candidate
};

/// A translating wall's schedule on the device (MoveWalls): which wall, and its translation.
struct DeviceWallMotion {
  walls::WallTranslation translation;
  std::uint32_t wall = 0;
};


struct BodyArrays {
  Vec3 *position, *velocity, *omega, *ang_momentum, *force, *torque, *inertia;
  Quat* orientation;
  double* mass;
  std::uint32_t *first_sphere, *sphere_count;
};

/// What a contact reads of one sphere, in one 96-byte record per sphere (BIODEM_GPU_RECORDS=1):
/// centre and radius, velocity and body mass, spin and material, each pair of words 16-byte
/// aligned, so that a GPU thread loads a sphere in six 16-byte loads within three 32-byte sectors,
/// instead of twelve 8-byte loads from six arrays (about seven and a half sectors: a 24-byte
/// `Vec3` straddles two sectors one time in two). A copy of the arrays below, which stay the
/// engine's state: every kernel that writes a sphere's motion writes its record too (set_motion),
/// and PackRecords fills the records wherever the arrays are filled or reordered (upload, sort).
struct alignas(32) SphereRecord {
  Vec3 position;
  double radius;
  Vec3 velocity;
  double body_mass;
  Vec3 omega;
  std::uint32_t material, pad;
};
static_assert(sizeof(SphereRecord) == 96, "a sphere record is three 32-byte sectors");
// (load_sphere_record's 16-byte loads read the words at these offsets)
static_assert(offsetof(SphereRecord, radius) == 24 && offsetof(SphereRecord, velocity) == 32 &&
                  offsetof(SphereRecord, body_mass) == 56 && offsetof(SphereRecord, omega) == 64 &&
                  offsetof(SphereRecord, material) == 88,
              "the record's words in pairs: centre x y | z radius | velocity x y | z mass | spin x y | z material");

struct SphereArrays {
  Vec3 *position, *velocity, *omega, *offset, *force, *torque, *built_at;
  double *radius, *body_mass;
  std::uint32_t *body, *material, *sid, *contacts;
  SphereRecord* record = nullptr;  // null: no records (BIODEM_GPU_RECORDS=0, the default)
  // The list guard (StepFlags), set in the arrays a drift writes through (set_motion); null
  // elsewhere: the guard's words, half the skin squared, and the motion buffer written.
  StepFlags* guard = nullptr;
  double half_skin2 = 0.0;
  std::uint32_t buffer = 0;
};

/// A sphere's data as a contact needs it, in registers.
struct SphereState {
  Vec3 position;
  double radius;
  Vec3 velocity;
  double body_mass;
  Vec3 omega;
  std::uint32_t material;
};
/// Sphere i from the arrays (twelve loads, one round).
BIODEM_HD inline SphereState load_sphere_arrays(const SphereArrays& s, std::uint32_t i) {
  return SphereState{s.position[i], s.radius[i], s.velocity[i], s.body_mass[i], s.omega[i], s.material[i]};
}
/// Sphere i from its record (on a GPU six 16-byte loads, one round). The same values.
BIODEM_HD inline SphereState load_sphere_record(const SphereRecord* rec, std::uint32_t i) {
#ifdef __CUDA_ARCH__
  const double2* p = reinterpret_cast<const double2*>(rec + i);
  const double2 a = p[0], b = p[1], c = p[2], d = p[3], e = p[4], f = p[5];
  return SphereState{Vec3{a.x, a.y, b.x}, b.y, Vec3{c.x, c.y, d.x}, d.y, Vec3{e.x, e.y, f.x},
                     static_cast<std::uint32_t>(static_cast<unsigned long long>(__double_as_longlong(f.y)) & 0xffffffffull)};
#else
  const SphereRecord& r = rec[i];
  return SphereState{r.position, r.radius, r.velocity, r.body_mass, r.omega, r.material};
#endif
}
/// (-DBIODEM_GPU_NO_RECORD_PATHS: a build without the records' branches, so that a lease can time
/// the default path against the binary before them, docs/gpu.md section 6; the engine then
/// refuses BIODEM_GPU_RECORDS=1 and BIODEM_GPU_OWN_SPHERE=1.)
BIODEM_HD inline SphereState load_sphere(const SphereArrays& s, std::uint32_t i) {
#ifdef BIODEM_GPU_NO_RECORD_PATHS
  return load_sphere_arrays(s, i);
#else
  return s.record ? load_sphere_record(s.record, i) : load_sphere_arrays(s, i);
#endif
}
/// Sphere i's centre and radius only (a contact's cut-off test: walk_packed's test round): from
/// its record when there are records (on a GPU two 16-byte loads), else from the arrays. The
/// values load_sphere gives.
BIODEM_HD inline void load_centre(const SphereArrays& s, std::uint32_t i, Vec3& x, double& r) {
#ifndef BIODEM_GPU_NO_RECORD_PATHS
  if (s.record) {
#ifdef __CUDA_ARCH__
    const double2* p = reinterpret_cast<const double2*>(s.record + i);
    const double2 a = p[0], b = p[1];
    x = Vec3{a.x, a.y, b.x};
    r = b.y;
#else
    x = s.record[i].position;
    r = s.record[i].radius;
#endif
    return;
  }
#endif
  x = s.position[i];
  r = s.radius[i];
}
/// Sphere i's motion stored: the arrays, and its record when there are records.
BIODEM_HD inline void set_motion(const SphereArrays& s, std::uint32_t i, const Vec3& x, const Vec3& v, const Vec3& w) {
  s.position[i] = x;
  s.velocity[i] = v;
  s.omega[i] = w;
  if (s.guard) {  // the list guard (StepFlags): past half the skin from the last build, or not finite
    if (!(norm2(x - s.built_at[i]) <= s.half_skin2)) flag_raise(&s.guard->over[s.buffer]);
    if (i == 0) ++s.guard->drifts;
  }
#ifndef BIODEM_GPU_NO_RECORD_PATHS
  if (s.record) {
    SphereRecord& r = s.record[i];
    r.position = x;
    r.velocity = v;
    r.omega = w;
  }
#endif
}
/// The records filled from the arrays (one index per sphere): at upload and after a sort.
struct PackRecords {
  SphereArrays s;
  SphereRecord* to;
  BIODEM_HD void operator()(std::uint32_t i) const {
    SphereRecord r;
    r.position = s.position[i];
    r.radius = s.radius[i];
    r.velocity = s.velocity[i];
    r.body_mass = s.body_mass[i];
    r.omega = s.omega[i];
    r.material = s.material[i];
    r.pad = 0;
    to[i] = r;
  }
};

/// Fixed-width neighbour rows, column-major (entry q of sphere i at q * n + i) so that the threads
/// of neighbouring spheres read neighbouring words. Each row is sorted by the neighbour's stable id,
/// which the row keeps beside the neighbour's index (`sid`): the list build sorts and carries the
/// history by it, and the force kernels tell a pair's lower-id side by it, without a second,
/// dependent load through the neighbour's index.
struct RowArrays {
  std::uint32_t* j;
  std::uint32_t* sid;  // stable id of sphere j[k]
  std::int32_t* image;  // periodic image shift from the row owner's side, packed int8 x3
  std::uint8_t* touching;
  contact::ContactHistory* history;  // from the side of the pair's lower stable id
  std::uint32_t* length;
  std::uint32_t cap;
  std::uint32_t* mirror;  // of an entry from its pair's lower-id side: the entry of the other side (MirrorEntries)
  Vec3* entry_force;   // PairEntries -> SumEntries: force on the pair's lower-id sphere
  Vec3* entry_torque;  // and torque on the row's sphere, per touching entry
  Vec3* wall_force;    // and per touching wall contact [wall * n + sphere]
  Vec3* wall_torque;
};

BIODEM_HD inline std::int32_t pack_image(int sx, int sy, int sz) {
  return static_cast<std::int32_t>(static_cast<std::uint8_t>(static_cast<std::int8_t>(sx))) |
         (static_cast<std::int32_t>(static_cast<std::uint8_t>(static_cast<std::int8_t>(sy))) << 8) |
         (static_cast<std::int32_t>(static_cast<std::uint8_t>(static_cast<std::int8_t>(sz))) << 16);
}
BIODEM_HD inline int image_component(std::int32_t c, int axis) {
  return static_cast<int>(static_cast<std::int8_t>((c >> (8 * axis)) & 0xff));
}


/// Moves the translating walls to the time of the step whose forces follow (one thread, before
/// each step's contact kernels): the device clock advances by dt as the host's does (t += dt,
/// from the host's time at upload), so each wall is where the CPU engine's update_wall_motion(t +
/// dt) puts it before the same step's forces (walls::place_translating_wall), bit for bit. A
/// halted step (settle criterion met) neither moves the clock nor the walls.
struct MoveWalls {
  DeviceWall* walls;
  const DeviceWallMotion* motion;
  std::uint32_t n_moving;
  double* clock;
  double dt;
  Halt halt;
  BIODEM_HD void operator()(std::uint32_t) const {
    if (halted(halt)) return;
    const double t = *clock + dt;
    *clock = t;
    for (std::uint32_t k = 0; k < n_moving; ++k)
      walls::place_translating_wall(walls[motion[k].wall].geometry, motion[k].translation, t);
  }
};

/// Sphere i of body k from the body (centre, velocity, spin); R is the body's rotation matrix.
BIODEM_HD inline void sphere_from_body(const BodyArrays& b, const SphereArrays& s, std::uint32_t k, std::uint32_t i,
                                       const Mat3& R) {
  const Vec3 x = b.position[k], v = b.velocity[k], w = b.omega[k];
  const Vec3 arm = R * s.offset[i];
  set_motion(s, i, x + arm, v + cross(w, arm), w);
}

/// Sphere centres, velocities and spins from their bodies (one index per sphere; upload).
struct SpheresFromBodies {
  BodyArrays b;
  SphereArrays s;
  BIODEM_HD void operator()(std::uint32_t i) const {
    const std::uint32_t k = s.body[i];
    if (b.sphere_count[k] == 1 && s.offset[i] == Vec3{}) {
      set_motion(s, i, b.position[k], b.velocity[k], b.omega[k]);
      return;
    }
    sphere_from_body(b, s, k, i, to_matrix(b.orientation[k]));
  }
};

/// The spheres s0 .. s0 + ns - 1 of a body (centres, velocities, spins) from the body's centre
/// x, velocity v, spin w and orientation q, held by the caller (in registers: not read back from
/// the body arrays it has just written), with the formula of SpheresFromBodies (bit for bit:
/// the rotation matrix is a function of the orientation only). The offsets are loaded a chunk at
/// a time before the chunk's stores, so that a GPU thread waits for them once per chunk.
///
/// `centred`: the caller knows the body is one sphere at its centre (every body of the scene is,
/// Engine::centred_spheres_), so the sphere takes the body's centre, velocity and spin without
/// the load of its offset that the test below makes (one round of memory after the body's
/// stores fewer; the same values).
BIODEM_HD inline void spheres_of_body(const SphereArrays& s, std::uint32_t s0, std::uint32_t ns, const Vec3& x,
                                      const Vec3& v, const Vec3& w, const Quat& q, bool centred = false) {
  if (centred || (ns == 1 && s.offset[s0] == Vec3{})) {
    set_motion(s, s0, x, v, w);
    return;
  }
  const Mat3 R = to_matrix(q);
  constexpr std::uint32_t kChunk = 4;
  for (std::uint32_t c0 = 0; c0 < ns; c0 += kChunk) {
    Vec3 offset[kChunk];
    for (std::uint32_t c = 0; c < kChunk; ++c)
      if (c0 + c < ns) offset[c] = s.offset[s0 + c0 + c];
    for (std::uint32_t c = 0; c < kChunk && c0 + c < ns; ++c) {
      const std::uint32_t i = s0 + c0 + c;
      const Vec3 arm = R * offset[c];
      set_motion(s, i, x + arm, v + cross(w, arm), w);
    }
  }
}

/// Body k's state, integrated in registers, stored once, then its spheres updated from it
/// (KickDriftSpheres, ReduceKickDrift).
BIODEM_HD inline void store_body(const BodyArrays& b, const SphereArrays& s, std::uint32_t k, std::uint32_t s0,
                                 std::uint32_t ns, const Vec3& x, const Vec3& v, const Vec3& w, const Vec3& l,
                                 const Quat& q, bool centred = false) {
  b.position[k] = x;
  b.velocity[k] = v;
  b.omega[k] = w;
  b.ang_momentum[k] = l;
  b.orientation[k] = q;
  spheres_of_body(s, s0, ns, x, v, w, q, centred);
}

/// The first part of a step, one thread per body (kick-drift and sphere update fused): half
/// kick, drift and free-rotor rotation of body k (the CPU engine's step, parts 1-2, same
/// arithmetic), then its spheres (spheres_of_body). The body's state is loaded into registers,
/// integrated there and stored once (the same operations on the same values as integrating it
/// in place in memory).
struct KickDriftSpheres {
  BodyArrays b;
  SphereArrays s;
  double h, dt;
  Halt halt;
  bool centred = false;  // every body is one sphere at its centre (spheres_of_body)
  BIODEM_HD void operator()(std::uint32_t k) const {
    if (halted(halt)) return;
    const std::uint32_t s0 = b.first_sphere[k], ns = b.sphere_count[k];
    Vec3 x = b.position[k], v = b.velocity[k], w = b.omega[k], l = b.ang_momentum[k];
    Quat q = b.orientation[k];
    const double m = b.mass[k];
    const Vec3 inertia = b.inertia[k], f = b.force[k], t = b.torque[k];
    integrate::kick_and_drift(x, v, w, l, q, m, inertia, ns, f, t, h, dt);
    store_body(b, s, k, s0, ns, x, v, w, l, q, centred);
  }
};

struct Box {
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
};
/// The lost region of [run] lost_particles = "remove" on the device (sim::LostRegion), with the
/// smallest bounding radius of the scene's shapes: BodyMayBeLost is 1 for every body the host's
/// test (Simulation::check_lost_bodies, with the body's own bounding radius, at least this one)
/// finds lost, and for a body between the two radii, which the host then keeps.
struct DeviceLostRegion {
  std::uint32_t drum = 0;  // 1: the drum (axis z through the origin), 0: the box
  double radius_m = 0.0, z0_m = 0.0, z1_m = 0.0;
  std::uint32_t periodic_z = 0;
  Vec3 min_m, max_m;
  std::uint32_t periodic[3] = {0, 0, 0};
  double rb_min = 0.0;
};
struct BodyMayBeLost {
  const Vec3* position;
  DeviceLostRegion r;
  BIODEM_HD std::uint32_t operator()(std::uint32_t k) const {
    const Vec3 x = position[k];
    bool lost = !(x.x == x.x && x.y == x.y && x.z == x.z);
    if (r.drum) {
      const double lim = r.radius_m + r.rb_min;
      lost = lost || x.x * x.x + x.y * x.y > lim * lim;
      if (!r.periodic_z) lost = lost || x.z < r.z0_m - r.rb_min || x.z > r.z1_m + r.rb_min;
    } else {
      for (int a = 0; a < 3; ++a) lost = lost || (!r.periodic[a] && (x[a] < r.min_m[a] || x[a] > r.max_m[a]));
    }
    return lost ? 1u : 0u;
  }
};

/// 1 when body k's centre is inside one of the n sinks (sim::SinkSpec::contains, the CPU
/// engine's test), else 0 (a term of the count the list check makes when its box reaches a sink).
struct BodyInSink {
  const Vec3* position;
  const sim::SinkSpec* sinks;
  std::uint32_t n;
  BIODEM_HD std::uint32_t operator()(std::uint32_t k) const {
    for (std::uint32_t q = 0; q < n; ++q)
      if (sinks[q].contains(position[k])) return 1u;
    return 0u;
  }
};
struct BoxOfSphere {
  SphereArrays s;
  BIODEM_HD Box operator()(std::uint32_t i) const { return Box{s.position[i], s.position[i]}; }
};
struct BoxUnion {
  BIODEM_HD Box operator()(const Box& a, const Box& c) const {
    Box r;
    r.lo = {a.lo.x < c.lo.x ? a.lo.x : c.lo.x, a.lo.y < c.lo.y ? a.lo.y : c.lo.y, a.lo.z < c.lo.z ? a.lo.z : c.lo.z};
    r.hi = {a.hi.x > c.hi.x ? a.hi.x : c.hi.x, a.hi.y > c.hi.y ? a.hi.y : c.hi.y, a.hi.z > c.hi.z ? a.hi.z : c.hi.z};
    return r;
  }
};

/// Largest squared displacement since the last build and largest squared sphere speed (a NaN
/// displacement, from a non-finite position, counts as infinite), the spheres' bounding box, and
/// whether the last build found a pair in one row only (MirrorEntries' flag, as 0 or 1): the
/// list check's one reduction, which also gives a rebuild its box. (All doubles: no padding
/// bytes for the reduction to copy.)
struct Motion {
  double disp2 = 0.0, speed2 = 0.0;
  Box box;
  double unmirrored = 0.0;
  double radial2 = 0.0;  // the largest x^2 + y^2 of a sphere centre (the drum's axis is z through the origin)
  // The list guard (StepFlags), read with the motion: 2 when a kernel stopped at a raised flag
  // (the device has stopped after a drift past half the skin), 1 when a drift raised one and no
  // kernel has read it yet (the last drift before the motion), 0 when none.
  double guard_halted = 0.0;
};
struct SphereMotion {
  SphereArrays s;
  const std::uint32_t* missing;        // MirrorEntries' flag
  const StepFlags* guard = nullptr;    // the list guard's words (null: no guard)
  BIODEM_HD Motion operator()(std::uint32_t i) const {
    const Vec3 x = s.position[i];
    const double d2 = norm2(x - s.built_at[i]);
    double halted_by_guard = 0.0;
    if (i == 0 && guard) halted_by_guard = guard->stop ? 2.0 : guard->over[0] || guard->over[1] ? 1.0 : 0.0;
    return Motion{d2 == d2 ? d2 : 1e300, norm2(s.velocity[i]), Box{x, x}, i == 0 && *missing ? 1.0 : 0.0,
                  x.x * x.x + x.y * x.y, halted_by_guard};
  }
};
struct MotionMax {
  BIODEM_HD Motion operator()(const Motion& a, const Motion& b) const {
    return Motion{a.disp2 > b.disp2 ? a.disp2 : b.disp2, a.speed2 > b.speed2 ? a.speed2 : b.speed2,
                  BoxUnion{}(a.box, b.box), a.unmirrored > b.unmirrored ? a.unmirrored : b.unmirrored,
                  a.radial2 > b.radial2 ? a.radial2 : b.radial2,
                  a.guard_halted > b.guard_halted ? a.guard_halted : b.guard_halted};
  }
};

/// The longest row, the entries of all rows and the wall slots within reach, in one reduction
/// (the list build: the one wait it makes for the host).
struct RowLengths {
  std::uint32_t longest = 0;
  std::uint64_t total = 0, wall_slots = 0;
};
struct RowLengthsMax {
  BIODEM_HD RowLengths operator()(const RowLengths& a, const RowLengths& b) const {
    return RowLengths{a.longest > b.longest ? a.longest : b.longest, a.total + b.total, a.wall_slots + b.wall_slots};
  }
};

struct IsNotFinite {
  SphereArrays s;
  BIODEM_HD bool operator()(std::uint32_t i) const {
    const Vec3 x = s.position[i];
    return !(x.x - x.x == 0.0 && x.y - x.y == 0.0 && x.z - x.z == 0.0);
  }
};

/// i where sphere i's position is not finite, else `none`: reduced with thrust::minimum, the
/// first such sphere. (A reduction over plain integers rather than thrust::find_if, whose CUB
/// reduction over tuple<bool, long> partials reads bytes it never wrote: compute-sanitizer
/// initcheck reported them on an H100, docs/gpu.md section 4.)
struct FirstNotFinite {
  SphereArrays s;
  std::uint32_t none;
  BIODEM_HD std::uint32_t operator()(std::uint32_t i) const { return IsNotFinite{s}(i) ? i : none; }
};

/// 1 where key[i + 1] < key[i], else 0: summed over i < n - 1, zero when the keys are sorted
/// (in place of thrust::is_sorted, for the reason given at FirstNotFinite).
struct Descends {
  const std::uint32_t* key;
  BIODEM_HD std::uint32_t operator()(std::uint32_t i) const { return key[i + 1] < key[i] ? 1u : 0u; }
};

/// After the set-up force evaluation (not a time step): a pair or wall contact that was
/// touching before keeps the history it had, a new one starts from zero (as the CPU engine's
/// refresh()). One index per row or wall slot.
struct KeepSetupHistory {
  contact::ContactHistory* history;              // after the evaluation
  const contact::ContactHistory* history_before;
  const std::uint8_t* touching;                  // after the evaluation
  const std::uint8_t* touching_before;
  BIODEM_HD void operator()(std::uint32_t k) const {
    if (touching[k]) history[k] = touching_before[k] ? history_before[k] : contact::ContactHistory{};
  }
};

/// The cell grid of one build (host-computed, same rules as the CPU list: cells at least the
/// cut-off wide, periodic axes split into an integer number of cells).
struct GridParams {
  Int3 n{1, 1, 1};
  Vec3 lo;
  Vec3 period;  // domain length on periodic axes
  double cell = 1.0;
  bool periodic[3] = {false, false, false};
};

/// Cell of every sphere (and, on periodic axes, its image index floor((x - lo) / L)).
struct CellOf {
  SphereArrays s;
  GridParams g;
  std::uint32_t* cell_key;
  Int3* wrap;
  Int3* cell;
  BIODEM_HD void operator()(std::uint32_t i) const {
    int c[3], w[3] = {0, 0, 0};
    // A sphere outside the grid (the box of the list check one step before) goes to the
    // nearest edge cell. A non-finite coordinate (which the next list check reports; the
    // cut-off test keeps the sphere out of every row) goes to an edge cell too: NaN and -inf to
    // cell 0, +inf to the last on a bounded axis; cell 0, image 0 on a periodic one.
    for (int k = 0; k < 3; ++k) {
      double x = s.position[i][k] - g.lo[k];
      const int nk = k == 0 ? g.n.x : (k == 1 ? g.n.y : g.n.z);
      if (g.periodic[k]) {
        const double L = g.period[k];
        const double wk = floor(x / L);
        if (!(wk >= -1e6 && wk <= 1e6)) {  // (non-finite; or beyond the image shifts, which the build refuses)
          w[k] = 0;
          c[k] = 0;
          continue;
        }
        w[k] = static_cast<int>(wk);
        x -= wk * L;
        const double q = x / (L / nk);
        c[k] = !(q >= 0.0) ? 0 : (q >= static_cast<double>(nk - 1) ? nk - 1 : static_cast<int>(q));
      } else {
        const double q = x / g.cell;
        c[k] = !(q >= 0.0) ? 0 : (q > static_cast<double>(nk - 1) ? nk - 1 : static_cast<int>(q));
      }
    }
    wrap[i] = Int3{w[0], w[1], w[2]};
    cell[i] = Int3{c[0], c[1], c[2]};
    cell_key[i] = static_cast<std::uint32_t>((c[2] * g.n.y + c[1]) * g.n.x + c[0]);
  }
};

/// The spheres in cell order (position p of `sorted`), packed for BuildRows: a row build then
/// reads each candidate's data at p directly instead of through its index (one dependent global
/// load per candidate instead of two). One index per position p.
struct CellPacked {
  Vec3* position;
  double* radius;
  std::uint32_t *body, *sid;
  Int3* wrap;
};
struct PackByCell {
  SphereArrays s;
  const std::uint32_t* sorted;
  const Int3* wrap;  // by sphere index (CellOf)
  CellPacked out;
  BIODEM_HD void operator()(std::uint32_t p) const {
    const std::uint32_t j = sorted[p];
    out.position[p] = s.position[j];
    out.radius[p] = s.radius[j];
    out.body[p] = s.body[j];
    out.sid[p] = s.sid[j];
    out.wrap[p] = wrap[j];
  }
};

/// Rows up to this long are built in the thread's own memory (on a GPU its local memory, which
/// the L1 cache holds: 576 bytes of stack per thread on sm_90, reads of its own recent writes
/// without the round trip to L2 that the row arrays cost) and written out once; wider rows are
/// built in place in the row arrays. The same rows either way. Not yet timed against the
/// in-place build on a GPU.
inline constexpr std::uint32_t kLocalRow = 48;

/// What a list build reads and writes (BuildRows, BuildRowsGrouped).
struct RowBuildArgs {
  SphereArrays s;
  GridParams g;
  const std::uint32_t* sorted;      // sphere indices sorted by cell
  const std::uint32_t* cell_start;  // per cell, first position in `sorted` (size ncell + 1)
  CellPacked packed;                // the spheres' data at the positions of `sorted` (PackByCell)
  const Int3* wrap;
  const Int3* cell;
  RowArrays old_rows, rows;
  std::uint32_t n;
  double skin;
  const std::uint32_t* old_of;  // new sphere index -> its index in old_rows (null: identity)
};

/// The sphere whose row is built (loaded once per row).
struct RowOwner {
  Vec3 x;
  double r;
  std::uint32_t body;
  Int3 cell, wrap;
};
BIODEM_HD inline RowOwner row_owner(const RowBuildArgs& a, std::uint32_t i) {
  return RowOwner{a.s.position[i], a.s.radius[i], a.s.body[i], a.cell[i], a.wrap[i]};
}

/// A row entry found by a build: the neighbour's index, its stable id, the packed image shift.
struct RowCandidate {
  std::uint32_t j, sid;
  std::int32_t image;
};

/// The list's cut-off test of the sphere at position p of the cell order against the row's
/// owner o, whose neighbour cell the candidate was found in with periodic shift cw (per axis,
/// -1, 0 or 1: the cell wrapped round the axis): another body's sphere closer than r_i + r_j +
/// skin (the periodic image by the two spheres' image indices and cw). Both builds call it, so
/// they pass the same candidates bit for bit.
BIODEM_HD inline bool row_candidate(const RowBuildArgs& a, const RowOwner& o, std::uint32_t p, const int cw[3],
                                    RowCandidate& out) {
  if (a.packed.body[p] == o.body) return false;  // (the owner itself included)
  const Int3 wj = a.packed.wrap[p];
  const int wiv[3] = {o.wrap.x, o.wrap.y, o.wrap.z}, wjv[3] = {wj.x, wj.y, wj.z};
  int sh[3] = {0, 0, 0};
  Vec3 dv = o.x - a.packed.position[p];
  for (int k = 0; k < 3; ++k)
    if (a.g.periodic[k]) {
      sh[k] = wiv[k] - wjv[k] + cw[k];
      dv[k] -= sh[k] * a.g.period[k];
    }
  const double cut = o.r + a.packed.radius[p] + a.skin;
  if (!(norm2(dv) < cut * cut)) return false;
  out = RowCandidate{a.sorted[p], a.packed.sid[p], pack_image(sh[0], sh[1], sh[2])};
  return true;
}

/// Builds sphere i's full neighbour row (all spheres of other bodies closer than r_i + r_j +
/// skin, sorted by stable id) and carries the history of touching pairs over from the old row.
/// A row longer than the capacity is counted (length > cap) and not stored; the host then
/// enlarges the rows and builds again. When the bodies were sorted just before this build, the
/// old rows are in the storage order before the sort: sphere i's old row is column old_of[i]
/// (null: the same order). Old and new entries are matched by stable id, which a sort leaves
/// unchanged. One thread per sphere, scanning the 27 cells around it; the rows of widths above
/// kGroupRowCap (and BIODEM_GPU_BUILD_LANES=1) are built so. BuildRowsGrouped builds the same
/// rows with a group of lanes per sphere.
struct BuildRows : RowBuildArgs {
  BIODEM_HD void operator()(std::uint32_t i) const {
    const RowOwner own = row_owner(*this, i);
    const Int3 ci = own.cell;
    const bool local = rows.cap <= kLocalRow;
    std::uint32_t lj[kLocalRow], lsid[kLocalRow];
    std::int32_t limg[kLocalRow];
    std::uint32_t len = 0;
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int d[3] = {dx, dy, dz};
          const int c0[3] = {ci.x, ci.y, ci.z};
          const int nn[3] = {g.n.x, g.n.y, g.n.z};
          int c[3], cw[3] = {0, 0, 0};
          bool skip = false;
          for (int k = 0; k < 3; ++k) {
            c[k] = c0[k] + d[k];
            if (c[k] < 0 || c[k] >= nn[k]) {
              if (!g.periodic[k]) {
                skip = true;
                break;
              }
              cw[k] = c[k] < 0 ? -1 : 1;
              c[k] -= cw[k] * nn[k];
            }
          }
          if (skip) continue;
          const std::uint32_t key = static_cast<std::uint32_t>((c[2] * nn[1] + c[1]) * nn[0] + c[0]);
          const std::uint32_t p_end = cell_start[key + 1];
          for (std::uint32_t p = cell_start[key]; p < p_end; ++p) {
            RowCandidate e;
            if (!row_candidate(*this, own, p, cw, e)) continue;
            if (len < rows.cap) {
              // insertion into the row, sorted by stable id
              const std::uint32_t jj = e.j, sj = e.sid;
              const std::int32_t img = e.image;
              std::uint32_t q = len;
              if (local) {
                while (q > 0 && lsid[q - 1] > sj) {
                  lj[q] = lj[q - 1];
                  lsid[q] = lsid[q - 1];
                  limg[q] = limg[q - 1];
                  --q;
                }
                lj[q] = jj;
                lsid[q] = sj;
                limg[q] = img;
              } else {
                while (q > 0 && rows.sid[(q - 1) * n + i] > sj) {
                  rows.j[q * n + i] = rows.j[(q - 1) * n + i];
                  rows.sid[q * n + i] = rows.sid[(q - 1) * n + i];
                  rows.image[q * n + i] = rows.image[(q - 1) * n + i];
                  --q;
                }
                rows.j[q * n + i] = jj;
                rows.sid[q * n + i] = sj;
                rows.image[q * n + i] = img;
              }
            }
            ++len;
          }
        }
    rows.length[i] = len;
    if (len > rows.cap) return;
    if (local)
      for (std::uint32_t q = 0; q < len; ++q) {
        rows.j[q * n + i] = lj[q];
        rows.sid[q * n + i] = lsid[q];
        rows.image[q * n + i] = limg[q];
      }
    // History carried over: both rows are sorted by stable id, so one merge pass.
    const std::uint32_t oi = old_of ? old_of[i] : i;
    std::uint32_t o = 0;
    const std::uint32_t o_end = old_rows.length[oi];
    std::uint32_t so = o < o_end ? old_rows.sid[oi] : 0;  // stable id of old entry o
    for (std::uint32_t q = 0; q < len; ++q) {
      const std::uint32_t sj = local ? lsid[q] : rows.sid[q * n + i];
      while (o < o_end && so < sj) {
        ++o;
        if (o < o_end) so = old_rows.sid[o * n + oi];
      }
      if (o < o_end && so == sj && old_rows.touching[o * n + oi]) {
        rows.history[q * n + i] = old_rows.history[o * n + oi];
        rows.touching[q * n + i] = 1;
      } else {
        rows.history[q * n + i] = contact::ContactHistory{};
        rows.touching[q * n + i] = 0;
      }
    }
  }
};

/// The grouped build (BuildRowsGrouped) handles rows up to this wide (its staging lives in the
/// block's shared memory on a GPU); wider rows are built by BuildRows.
inline constexpr std::uint32_t kGroupRowCap = 128;
/// The candidates of a row are those of at most 18 runs of consecutive positions of the cell
/// order: the 9 lines (dy, dz) of the 3 x 3 x 3 cells around the sphere's, each the cells
/// dx = -1, 0, 1 (consecutive cell keys), cut in two where a periodic x axis wraps.
inline constexpr std::uint32_t kCellRuns = 18;

/// Run r (< kCellRuns) of the candidates around a sphere in cell `ci`: the positions [begin, end)
/// of the cell order and the periodic shift of its cells (cw, per axis). Empty where the cells
/// lie outside a non-periodic grid (or where line r / 2 needs no second piece). Every cell of
/// the 27 that BuildRows scans lies in exactly one run, with the same shift: the grid has at
/// least 3 cells along a periodic axis, so no cell is reached twice.
BIODEM_HD inline void cell_run(const RowBuildArgs& a, const Int3& ci, std::uint32_t r, std::uint32_t& begin,
                               std::uint32_t& end, int cw[3]) {
  begin = end = 0;
  cw[0] = cw[1] = cw[2] = 0;
  const int line = static_cast<int>(r / 2), piece = static_cast<int>(r % 2);
  const int nn[3] = {a.g.n.x, a.g.n.y, a.g.n.z};
  int c[3] = {0, ci.y + line % 3 - 1, ci.z + line / 3 - 1};
  for (int k = 1; k < 3; ++k)
    if (c[k] < 0 || c[k] >= nn[k]) {
      if (!a.g.periodic[k]) return;
      cw[k] = c[k] < 0 ? -1 : 1;
      c[k] -= cw[k] * nn[k];
    }
  int lo = ci.x - 1, hi = ci.x + 1;  // cells lo..hi along x, all with shift cw[0]
  if (!a.g.periodic[0]) {
    if (piece == 1) return;
    lo = lo < 0 ? 0 : lo;
    hi = hi > nn[0] - 1 ? nn[0] - 1 : hi;
  } else if (lo < 0) {  // the cell before wraps to the last: piece 0 is that cell, piece 1 the rest
    if (piece == 0) {
      lo = hi = nn[0] - 1;
      cw[0] = -1;
    } else {
      lo = 0;
    }
  } else if (hi >= nn[0]) {  // the cell after wraps to the first: piece 1 is that cell
    if (piece == 0) {
      hi = nn[0] - 1;
    } else {
      lo = hi = 0;
      cw[0] = 1;
    }
  } else if (piece == 1) {
    return;
  }
  const std::uint32_t key = static_cast<std::uint32_t>((c[2] * nn[1] + c[1]) * nn[0]);
  begin = a.cell_start[key + static_cast<std::uint32_t>(lo)];
  end = a.cell_start[key + static_cast<std::uint32_t>(hi) + 1];
}
BIODEM_HD inline std::int32_t pack_shift(const int cw[3]) { return pack_image(cw[0], cw[1], cw[2]); }

/// A group's scratch memory for one row (BuildRowsGrouped): on a GPU in the block's shared
/// memory, on CPU threads on the thread's stack.
struct RowScratch {
  std::uint32_t* run_begin;   // kCellRuns
  std::uint32_t* run_first;   // kCellRuns + 1: the runs' candidates numbered in run order
  std::int32_t* run_shift;    // kCellRuns, packed as the image shifts
  std::uint32_t* j;           // staged entries (cap), in the order found
  std::uint32_t* sid;
  std::int32_t* image;
  std::uint32_t* row_sid;     // cap: the stable ids in row order
  std::uint8_t* matched;      // cap: entry q took an old contact's history
  /// Bytes of one group's scratch for rows of capacity cap (a multiple of 16).
  BIODEM_HD static std::uint32_t bytes(std::uint32_t cap) {
    const std::uint32_t b = (3 * kCellRuns + 1 + 4 * cap) * 4 + cap;
    return (b + 15u) & ~15u;
  }
  BIODEM_HD static RowScratch at(unsigned char* base, std::uint32_t cap) {
    RowScratch sc;
    auto* w = reinterpret_cast<std::uint32_t*>(base);
    sc.run_begin = w;
    sc.run_first = w + kCellRuns;
    sc.run_shift = reinterpret_cast<std::int32_t*>(w + 2 * kCellRuns + 1);
    w += 3 * kCellRuns + 1;
    sc.j = w;
    sc.sid = w + cap;
    sc.image = reinterpret_cast<std::int32_t*>(w + 2 * cap);
    sc.row_sid = w + 3 * cap;
    sc.matched = reinterpret_cast<std::uint8_t*>(w + 4 * cap);
    return sc;
  }
};

/// One lane, the whole group (BuildRowsGrouped on CPU threads).
struct OneLane {
  BIODEM_HD std::uint32_t lane() const { return 0; }
  BIODEM_HD std::uint32_t size() const { return 1; }
  BIODEM_HD std::uint32_t ballot(bool b) const { return b ? 1u : 0u; }  // bit l: lane l's b
  BIODEM_HD void sync() const {}
};
BIODEM_HD inline std::uint32_t count_bits(std::uint32_t v) {
  std::uint32_t c = 0;
  for (; v; v &= v - 1u) ++c;
  return c;
}

/// The rows of BuildRows, built by a group of lanes per sphere (on a GPU 16 lanes of a warp,
/// BIODEM_GPU_BUILD_LANES; on CPU threads one): the lanes find the runs of candidate positions
/// (cell_run), then test the candidates numbered in run order, a round of `lanes` at a time
/// (row_candidate), the passing ones staged in the order found; each staged entry then goes to
/// its place in the row, the number of staged stable ids below its own (stable ids are unique
/// in a row: each sphere is in one cell, each cell in one run), and each touching contact of the
/// old row hands its history to the entry of the same stable id. The same rows, lengths and
/// history as BuildRows (GpuEngine.GroupedListBuildGivesTheRowsOfBuildRows), with the longest
/// chain of dependent loads a few rounds instead of a scan of 27 cells.
struct BuildRowsGrouped : RowBuildArgs {
  template <class Group>
  BIODEM_HD void build(std::uint32_t i, const Group& grp, const RowScratch& sc) const {
    const std::uint32_t lane = grp.lane(), lanes = grp.size(), cap = rows.cap;
    const RowOwner o = row_owner(*this, i);
    for (std::uint32_t r = lane; r < kCellRuns; r += lanes) {
      std::uint32_t b, e;
      int cw[3];
      cell_run(*this, o.cell, r, b, e, cw);
      sc.run_begin[r] = b;
      sc.run_first[r + 1] = e - b;  // (counts, summed by lane 0 below)
      sc.run_shift[r] = pack_shift(cw);
    }
    grp.sync();
    if (lane == 0) {
      sc.run_first[0] = 0;
      for (std::uint32_t r = 0; r < kCellRuns; ++r) sc.run_first[r + 1] += sc.run_first[r];
    }
    grp.sync();
    const std::uint32_t total = sc.run_first[kCellRuns];
    const std::uint32_t below = (1u << lane) - 1u;  // the lanes before this one
    std::uint32_t len = 0, r = 0;
    for (std::uint32_t t0 = 0; t0 < total; t0 += lanes) {  // (the same rounds in every lane)
      const std::uint32_t t = t0 + lane;
      RowCandidate e{};
      bool pass = false;
      if (t < total) {
        while (sc.run_first[r + 1] <= t) ++r;
        const std::int32_t shift = sc.run_shift[r];
        const int cw[3] = {image_component(shift, 0), image_component(shift, 1), image_component(shift, 2)};
        pass = row_candidate(*this, o, sc.run_begin[r] + (t - sc.run_first[r]), cw, e);
      }
      const std::uint32_t passed = grp.ballot(pass);
      const std::uint32_t slot = len + count_bits(passed & below);
      if (pass && slot < cap) {
        sc.j[slot] = e.j;
        sc.sid[slot] = e.sid;
        sc.image[slot] = e.image;
      }
      len += count_bits(passed);
    }
    if (lane == 0) rows.length[i] = len;
    if (len > cap) return;  // (the host widens the rows and builds again)
    grp.sync();
    // Each entry's place: the number of staged stable ids below its own. Every place is taken
    // once because a row's stable ids are unique (each sphere lies in one cell, each cell in one
    // run: the engine refuses fewer than 3 cells along a periodic axis); with a repeated id a
    // place would stay unwritten and two lanes would write another.
    for (std::uint32_t q = lane; q < len; q += lanes) {
      const std::uint32_t sj = sc.sid[q];
      std::uint32_t at = 0;
      for (std::uint32_t m = 0; m < len; ++m) at += sc.sid[m] < sj ? 1u : 0u;
      rows.j[at * n + i] = sc.j[q];
      rows.sid[at * n + i] = sj;
      rows.image[at * n + i] = sc.image[q];
      sc.row_sid[at] = sj;
      sc.matched[at] = 0;
    }
    grp.sync();
    const std::uint32_t oi = old_of ? old_of[i] : i;
    const std::uint32_t o_end = old_rows.length[oi];
    // Each touching old contact hands its history to the new entry of its stable id (unique in
    // the old row too, so each new entry is written by one lane at most).
    for (std::uint32_t k = lane; k < o_end; k += lanes) {
      if (!old_rows.touching[k * n + oi]) continue;
      const std::uint32_t so = old_rows.sid[k * n + oi];
      std::uint32_t lo = 0, hi = len;  // the first entry of the new row with stable id >= so
      while (lo < hi) {
        const std::uint32_t mid = (lo + hi) / 2;
        if (sc.row_sid[mid] < so) lo = mid + 1;
        else hi = mid;
      }
      if (lo < len && sc.row_sid[lo] == so) {
        rows.history[lo * n + i] = old_rows.history[k * n + oi];
        rows.touching[lo * n + i] = 1;
        sc.matched[lo] = 1;
      }
    }
    grp.sync();
    for (std::uint32_t q = lane; q < len; q += lanes)
      if (!sc.matched[q]) {
        rows.history[q * n + i] = contact::ContactHistory{};
        rows.touching[q * n + i] = 0;
      }
  }
  /// Bytes of one group's scratch (RowScratch) for rows of capacity cap.
  BIODEM_HD static std::uint32_t scratch_bytes(std::uint32_t cap) { return RowScratch::bytes(cap); }
  /// One thread per sphere (CPU threads): the group is that thread, its scratch on the stack
  /// (sized for kGroupRowCap; wider rows, which the engine never gives it, go to BuildRows).
  BIODEM_HD void operator()(std::uint32_t i) const {
    if (rows.cap > kGroupRowCap) {
      BuildRows{*this}(i);
      return;
    }
    alignas(16) unsigned char scratch[(3 * kCellRuns + 1 + 4 * kGroupRowCap) * 4 + kGroupRowCap + 16];
    build(i, OneLane{}, RowScratch::at(scratch, rows.cap));
  }
};

/// After a list build, one thread per entry k = q * n + a (q < rows.cap): for an entry from its
/// pair's lower-id side, the entry of the other side (b's row holds a: its position found by a
/// binary search of b's row, which is sorted by stable id), into rows.mirror[k]. The list is
/// symmetric (the cut-off test gives the same bits from both sides), so it is always found; if
/// it were not, the entry names itself and `missing` is set (the next list check or download
/// stops the run).
struct MirrorEntries {
  RowArrays rows;
  const std::uint32_t* sid;  // stable id of each sphere
  std::uint32_t n;
  std::uint32_t* missing;
  BIODEM_HD void operator()(std::uint32_t k) const {
    const std::uint32_t a = k % n, q = k / n;
    if (q >= rows.length[a]) return;
    const std::uint32_t sid_a = sid[a];
    if (!(sid_a < rows.sid[k])) return;
    const std::uint32_t b = rows.j[k];
    std::uint32_t lo = 0, hi = rows.length[b];  // the first entry of b's row with stable id >= sid_a
    while (lo < hi) {
      const std::uint32_t mid = (lo + hi) / 2;
      if (rows.sid[mid * n + b] < sid_a) lo = mid + 1;
      else hi = mid;
    }
    if (lo < rows.length[b] && rows.sid[lo * n + b] == sid_a) {
      rows.mirror[k] = lo * n + b;
    } else {
      rows.mirror[k] = k;
      *missing = 1;
    }
  }
};

/// The history of each pair, advanced by PairEntries in its lower-id side's entry, copied to the
/// other side's entry (one thread per entry k = q * n + a), so that both rows hold it again as
/// the row walk keeps them (before a download of the rows, or a switch to Forces).
struct MirrorHistory {
  RowArrays rows;
  const std::uint32_t* sid;
  std::uint32_t n;
  BIODEM_HD void operator()(std::uint32_t k) const {
    const std::uint32_t a = k % n, q = k / n;
    if (q >= rows.length[a] || !(sid[a] < rows.sid[k])) return;
    rows.history[rows.mirror[k]] = rows.history[k];
  }
};

/// The bodies' storage order on the device (docs/gpu.md, "Bodies sorted by cell"): after the
/// bodies were reordered (new slot d holds the body that was at slot order[d]; counts and the
/// new first spheres already in the new order), the source of every sphere of the new order
/// (its index before) and its new body index. One thread per body (new order).
struct SphereSources {
  const std::uint32_t* order;      // new body slot -> old body slot
  const std::uint32_t* old_first;  // old body slot -> its first sphere before
  const std::uint32_t* first;      // new body slot -> its first sphere now
  const std::uint32_t* count;      // new body slot -> its spheres
  std::uint32_t* src;              // new sphere index -> old sphere index
  std::uint32_t* body;             // new sphere index -> new body slot
  BIODEM_HD void operator()(std::uint32_t d) const {
    const std::uint32_t from = old_first[order[d]], to = first[d], c = count[d];
    for (std::uint32_t q = 0; q < c; ++q) {
      src[to + q] = from + q;  // the body's spheres stay contiguous, in template order
      body[to + q] = d;
    }
  }
};

/// Several arrays of one length reordered together (a sort of the bodies, docs/gpu.md): with
/// `src` null, each array is copied into its stash (stash[i] = live[i]); then, with `src`, each
/// takes its new order from the stash (live[i] = stash[src[i]]). Two launches for all the
/// arrays of bodies (or of spheres) instead of two Thrust calls per array; each live array keeps
/// its buffer (the CUDA graphs hold the addresses). One thread per index.
struct Permutation {
  static constexpr int kMost = 8;
  Vec3 *v3[kMost], *v3_stash[kMost];
  Quat *q[kMost], *q_stash[kMost];
  double *d[kMost], *d_stash[kMost];
  std::uint32_t *u[kMost], *u_stash[kMost];
  int n3 = 0, nq = 0, nd = 0, nu = 0;
  const std::uint32_t* src = nullptr;
  BIODEM_HD void operator()(std::uint32_t i) const {
    if (!src) {
      for (int k = 0; k < n3; ++k) v3_stash[k][i] = v3[k][i];
      for (int k = 0; k < nq; ++k) q_stash[k][i] = q[k][i];
      for (int k = 0; k < nd; ++k) d_stash[k][i] = d[k][i];
      for (int k = 0; k < nu; ++k) u_stash[k][i] = u[k][i];
      return;
    }
    const std::uint32_t j = src[i];
    for (int k = 0; k < n3; ++k) v3[k][i] = v3_stash[k][j];
    for (int k = 0; k < nq; ++k) q[k][i] = q_stash[k][j];
    for (int k = 0; k < nd; ++k) d[k][i] = d_stash[k][j];
    for (int k = 0; k < nu; ++k) u[k][i] = u_stash[k][j];
  }
};

/// A dense (wall, sphere) array [w * n + i] in the new sphere order takes slot w n + i from slot
/// w n + src[i] (the map of a thrust::gather).
struct WallSlotSource {
  const std::uint32_t* src;
  std::uint32_t n;
  BIODEM_HD std::uint32_t operator()(std::uint32_t slot) const {
    const std::uint32_t w = slot / n, i = slot - w * n;
    return w * n + src[i];
  }
};

/// f of the body that the host Simulation holds at index h (slot[h]: its device slot): sums over
/// the bodies (kinetic energy) run in the host's order, whatever the device's storage order, so
/// they give the same bits sorted or not.
template <class F>
struct InHostOrder {
  F f;
  const std::uint32_t* slot;
  BIODEM_HD double operator()(std::uint32_t h) const { return f(slot[h]); }
};

/// What the force kernels share: the arrays and parameters of the contacts of one step.
struct ContactArgs {
  SphereArrays s;
  RowArrays rows;
  const DeviceWall* walls;
  contact::ContactHistory* wall_history;  // [wall * n + sphere]
  std::uint8_t* wall_touching;
  std::uint32_t n_walls;
  const contact::PairParams* pairs;
  std::uint32_t n_materials;
  Vec3 period;
  bool periodic;
  std::uint32_t n;
  double dt;
  bool wall_rolling_lab;  // EPSD2 at walls with the particle's own spin (LIGGGHTS 3.8.0)
  Halt halt;
  /// The walk by one thread holds its own sphere's data for the whole row (Forces::walk_heads<true>;
  /// BIODEM_GPU_OWN_SPHERE=1) instead of loading it again at each entry.
  bool own_sphere = false;
  /// The pairs' lower-id entries and the wall slots within reach, listed at each list build
  /// (LowerSide, WallSlotNear, ScatterFlagged): the per-contact passes launch one thread per
  /// listed entry (`cap` threads, those from `*count` on loading their slot, then doing nothing)
  /// and per listed wall slot (`wall_cap`, likewise), instead of one per row entry and wall slot.
  /// Off
  /// (BIODEM_GPU_PAIR_LIST=full): one per row entry and wall slot.
  struct PairList {
    const std::uint32_t* k = nullptr;
    const std::uint32_t* j = nullptr;  // the neighbour of entry k[t] (rows.j[k[t]] at the build)
    const std::uint32_t* count = nullptr;
    std::uint32_t cap = 0;
    bool on = false;
    // and the wall slots that may touch before the next build (WallSlotNear), likewise
    const std::uint32_t* wall_k = nullptr;
    const std::uint32_t* wall_count = nullptr;
    std::uint32_t wall_cap = 0;
  } pair_list;

  /// Thread t of a per-contact pass (PairEntries, PairEntriesFixed): pair(k, a, sid_a, b) for
  /// the entry k of sphere a's row that is its pair's lower-id side, wall(a, w, listed) for
  /// sphere a and wall w (listed: from the wall-slot list); nothing for the other threads (a
  /// pair's higher-id side, entries past a row's end, listed slots past the count). b: the
  /// neighbour when the pair list gives it (then sid_a is not loaded: a is known to be the
  /// lower-id side), else kUnlisted. The threads of a pass: pass_threads.
  static constexpr std::uint32_t kUnlisted = 0xffffffffu;
  template <class Pair, class Wall>
  BIODEM_HD void pair_pass(std::uint32_t t, const Pair& pair, const Wall& wall) const {
    if (pair_list.on) {
      if (t < pair_list.cap) {
        // The count, the entry and its neighbour in one round of loads (the slots past the count
        // hold zeros or an earlier build's values: loaded, not used).
        const std::uint32_t count = *pair_list.count, k = pair_list.k[t], b = pair_list.j[t];
        if (t >= count) return;
        pair(k, k % n, 0u, b);
        return;
      }
      // (the count and the slot in one round, as the pairs')
      const std::uint32_t u = t - pair_list.cap, count = *pair_list.wall_count, slot = pair_list.wall_k[u];
      if (u >= count) return;
      wall(slot % n, slot / n, true);
      return;
    }
    const std::uint32_t a = t % n, q = t / n;
    if (q >= rows.cap) {
      wall(a, q - rows.cap, false);
      return;
    }
    // (Loading the row's length, the sphere's stable id, the entry's head and its mirror in one
    // round, before the two exits below, was measured slower on an H100 where this kernel is
    // throughput-bound: 53.4 against 46.8 us/step on the raw drum, 36.2 against 31.4 on the
    // glass drum, with no gain on the small one; docs/gpu.md section 4. Most threads exit here.)
    if (q >= rows.length[a]) return;
    const std::uint32_t sid_a = s.sid[a];
    if (!(sid_a < rows.sid[t])) return;  // the pair's higher-id side: written by the other entry
    pair(t, a, sid_a, kUnlisted);
  }
  /// The threads of a per-contact pass over rows of `cap` entries and `walls` walls.
  static std::uint32_t pass_threads(const PairList& l, std::uint32_t cap, std::uint32_t walls, std::uint32_t n) {
    return l.on ? l.cap + l.wall_cap : (cap + walls) * n;
  }

  /// What a force kernel reads of entry k first: the neighbour, its stable id and whether the
  /// pair touched at the last evaluation.
  struct EntryHead {
    std::uint32_t b = 0, sid_b = 0;
    bool was_touching = false;
  };
  BIODEM_HD EntryHead entry_head(std::uint32_t k) const { return EntryHead{rows.j[k], rows.sid[k], rows.touching[k] != 0}; }

  /// Entry k = q * n + a of sphere a's row (sid_a: a's stable id): the pair evaluated from the
  /// side of its lower stable id, with that side's copy of the history in the entry. True when
  /// the spheres touch, with the force on the lower-id sphere (`force_low`), the torque on a
  /// (`torque_a`) and whether a is the lower-id sphere; false (history reset) otherwise.
  template <bool Cohesion, bool Rolling>
  BIODEM_HD bool pair_entry(std::uint32_t a, std::uint32_t sid_a, std::uint32_t k, Vec3& force_low, Vec3& torque_a,
                            bool& a_low, Vec3* torque_b = nullptr) const {
    return pair_entry_from<Cohesion, Rolling>(entry_head(k), a, sid_a, k, force_low, torque_a, a_low, torque_b);
  }
  /// The same with entry k's head (entry_head) already loaded by the caller. Listed: entry k
  /// comes from the pair list, so a is the pair's lower-id side (sid_a and e.sid_b are not read)
  /// and e.b the list's neighbour: the two spheres' loads and the history's then wait for no
  /// load of the entry (the same values, the same arithmetic: the same bits).
  template <bool Cohesion, bool Rolling, bool Listed = false>
  BIODEM_HD bool pair_entry_from(const EntryHead& e, std::uint32_t a, std::uint32_t sid_a, std::uint32_t k,
                                 Vec3& force_low, Vec3& torque_a, bool& a_low, Vec3* torque_b = nullptr) const {
    // The loads in as few dependent rounds as the data allow (on a GPU each round is a wait for
    // memory): the entry's head (neighbour, its stable id, the touching flag; the callers load
    // it together with their own first loads), then everything of the two spheres that the
    // contact may need, with the history of a contact that was touching (the usual case of a
    // touching pair), all before the cut-off test; the pair's parameters (a small table,
    // cached) and a new contact's history after it (Listed: the history with the spheres,
    // whatever the flag). Loads only: the arithmetic and its order are unchanged.
    const std::uint32_t b = e.b;
    if constexpr (Listed) a_low = true;
    else a_low = sid_a < e.sid_b;
    const std::uint32_t i = a_low ? a : b, j = a_low ? b : a;
    return pair_contact<Cohesion, Rolling, Listed>(e, k, load_sphere(s, i), load_sphere(s, j), a_low, force_low,
                                                   torque_a, torque_b);
  }
  /// pair_entry_from in a walk that holds its own sphere a (`own`, loaded once for the whole
  /// row: BIODEM_GPU_OWN_SPHERE=1) and loads only the neighbour per entry. The same values.
  template <bool Cohesion, bool Rolling>
  BIODEM_HD bool pair_entry_own(const EntryHead& e, const SphereState& own, std::uint32_t sid_a, std::uint32_t k,
                                Vec3& force_low, Vec3& torque_a, bool& a_low) const {
    a_low = sid_a < e.sid_b;
    const SphereState other = load_sphere(s, e.b);
    return pair_contact<Cohesion, Rolling, false>(e, k, a_low ? own : other, a_low ? other : own, a_low, force_low,
                                                  torque_a, nullptr);
  }
  /// The contact of entry k (head e) between the pair's lower-id sphere si and the other, sj
  /// (a_low: the row's sphere is si): pair_entry_from's arithmetic.
  template <bool Cohesion, bool Rolling, bool Listed>
  BIODEM_HD bool pair_contact(const EntryHead& e, std::uint32_t k, const SphereState& si, const SphereState& sj,
                              bool a_low, Vec3& force_low, Vec3& torque_a, Vec3* torque_b) const {
    const bool was_touching = e.was_touching;
    const Vec3 pi = si.position, pj = sj.position;
    const double ri = si.radius, rj = sj.radius;
    const double mi = si.body_mass, mj = sj.body_mass;
    const Vec3 vi = si.velocity, vj = sj.velocity, wi = si.omega, wj = sj.omega;
    const std::uint32_t mat_i = si.material, mat_j = sj.material;
    contact::ContactHistory h{};
    // (Listed: loaded whatever the flag, in the round of the spheres' loads; a new contact below
    // takes the same value, nothing having written it since.)
    if (Listed || was_touching) h = rows.history[k];
    const Vec3 d = pair_offset(k, pi, pj, a_low);
    const double dist2 = norm2(d), rsum = ri + rj;
    if (dist2 >= rsum * rsum) {
      if (was_touching) {
        rows.touching[k] = 0;
        rows.history[k] = contact::ContactHistory{};
      }
      return false;
    }
    if (!Listed && !was_touching) h = rows.history[k];
    const contact::PairParams p = pairs[mat_i * n_materials + mat_j];
    const double dist = sqrt(dist2);
    const contact::ContactGeometry geo = contact::sphere_sphere_geometry(d, dist, ri, rj, mi, mj, vi, vj, wi, wj);
    const double area = Cohesion ? contact::sjkr_area_sphere_sphere(ri, rj, dist) : 0.0;
    const contact::ContactOutput out = contact::evaluate_contact<Cohesion, Rolling>(geo, p, h, area, dt);
    rows.history[k] = h;
    rows.touching[k] = 1;
    force_low = out.force_i;
    torque_a = a_low ? out.torque_i : out.torque_j;
    if (torque_b) *torque_b = a_low ? out.torque_j : out.torque_i;
    return true;
  }

  /// The centre-to-centre vector of entry k's pair from the lower-id sphere's centre pi to the
  /// other's pj, with the entry's periodic image shift (a_low: the row's sphere is the lower-id
  /// one): pair_contact's and pair_touches' (the same operations, so the same cut-off test).
  BIODEM_HD Vec3 pair_offset(std::uint32_t k, const Vec3& pi, const Vec3& pj, bool a_low) const {
    Vec3 d = pi - pj;
    if (periodic) {
      const std::int32_t c = rows.image[k];
      const int sx = a_low ? image_component(c, 0) : -image_component(c, 0);
      const int sy = a_low ? image_component(c, 1) : -image_component(c, 1);
      const int sz = a_low ? image_component(c, 2) : -image_component(c, 2);
      d -= Vec3{static_cast<double>(sx) * period.x, static_cast<double>(sy) * period.y,
                static_cast<double>(sz) * period.z};
    }
    return d;
  }
  /// pair_entry_from's cut-off test alone, for entry k (head e) of sphere a's row: the two
  /// spheres' centres and radii only; true when they touch (nothing written: pair_entry_from
  /// evaluates the contact), false after what pair_entry_from does for a pair apart (the
  /// touching flag and history of a contact that was touching reset). The same test on the same
  /// values as pair_contact, so both say the same.
  BIODEM_HD bool pair_touches(const EntryHead& e, std::uint32_t a, std::uint32_t sid_a, std::uint32_t k) const {
    const bool a_low = sid_a < e.sid_b;
    Vec3 pi, pj;
    double ri, rj;
    load_centre(s, a_low ? a : e.b, pi, ri);
    load_centre(s, a_low ? e.b : a, pj, rj);
    const Vec3 d = pair_offset(k, pi, pj, a_low);
    const double dist2 = norm2(d), rsum = ri + rj;
    if (dist2 >= rsum * rsum) {
      if (e.was_touching) {
        rows.touching[k] = 0;
        rows.history[k] = contact::ContactHistory{};
      }
      return false;
    }
    return true;
  }
  /// wall_contact's test alone for sphere a and wall w (as pair_touches: true when touching,
  /// nothing written; false after the reset of a contact that was touching).
  BIODEM_HD bool wall_touches(std::uint32_t a, std::uint32_t w) const {
    const std::uint32_t slot = w * n + a;
    const bool was_touching = wall_touching[slot] != 0;
    Vec3 xa;
    double ra;
    load_centre(s, a, xa, ra);
    if (!walls::wall_hit(walls[w].geometry, xa, ra).touching) {
      if (was_touching) {
        wall_touching[slot] = 0;
        wall_history[slot] = contact::ContactHistory{};
      }
      return false;
    }
    return true;
  }

  /// Adds a pair entry's contribution to sphere a's sums (each pair counted once, by its
  /// lower-id sphere).
  BIODEM_HD static void add_pair(const Vec3& force_low, const Vec3& torque_a, bool a_low, Vec3& f, Vec3& t,
                                 std::uint32_t& count) {
    if (a_low) {
      f += force_low;
      t += torque_a;
      ++count;
    } else {
      f -= force_low;
      t += torque_a;
    }
  }

  /// Sphere a's contact sums from the entry buffers of PairEntries (SumEntries): its touching
  /// pair entries in row order, then its touching walls in wall order, with the operations of
  /// the row walk. The entries (and walls) are read in chunks of kChunk: every load of a chunk is
  /// issued before the first addition, so a GPU thread waits for memory once per chunk rather
  /// than once per entry. The additions stay in row order.
  /// The first chunk is loaded whatever the row's length (entries below rows.cap are in the
  /// arrays; those past the length are not added), so that its loads do not wait for the length.
#ifndef BIODEM_GPU_SUM_CHUNK
#define BIODEM_GPU_SUM_CHUNK 4
#endif
  // 4 (H100, 2026-11-26: the entry kernels 16.3/30.4/47.1 us/step on the three bench drums against
  // 18.2/36.3/52.9 with 8, whose 128 registers spilled); -DBIODEM_GPU_SUM_CHUNK=N for timing builds.
  static constexpr std::uint32_t kChunk = BIODEM_GPU_SUM_CHUNK;
  BIODEM_HD void sum_entries(std::uint32_t a, std::uint32_t sid_a, std::uint32_t len, Vec3& f, Vec3& t,
                             std::uint32_t& count) const {
    for (std::uint32_t q0 = 0; q0 == 0 || q0 < len; q0 += kChunk) {
      bool touching[kChunk], low[kChunk];
      Vec3 fe[kChunk], te[kChunk];
      for (std::uint32_t c = 0; c < kChunk; ++c) {
        const std::uint32_t q = q0 + c, k = q * n + a;
        touching[c] = false;
        low[c] = false;
        if (q < rows.cap) {
          touching[c] = (rows.touching[k] != 0) & (q < len);
          low[c] = sid_a < rows.sid[k];
          fe[c] = rows.entry_force[k];
          te[c] = rows.entry_torque[k];
        }
      }
      for (std::uint32_t c = 0; c < kChunk; ++c)
        if (touching[c]) add_pair(fe[c], te[c], low[c], f, t, count);
    }
    for (std::uint32_t w0 = 0; w0 < n_walls; w0 += kChunk) {
      bool touching[kChunk];
      Vec3 fw[kChunk], tw[kChunk];
      for (std::uint32_t c = 0; c < kChunk; ++c) {
        const std::uint32_t w = w0 + c, slot = w * n + a;
        touching[c] = false;
        if (w < n_walls) {
          touching[c] = wall_touching[slot] != 0;
          fw[c] = rows.wall_force[slot];
          tw[c] = rows.wall_torque[slot];
        }
      }
      for (std::uint32_t c = 0; c < kChunk; ++c)
        if (touching[c]) {
          f += fw[c];
          t += tw[c];
          ++count;
        }
    }
  }

  /// Sphere a's contact with wall w (slot w * n + a of the wall history): true when touching,
  /// with the force and torque on a; false (history reset) otherwise. Listed: the slot comes
  /// from the wall-slot list (a sphere within reach of the wall, often touching it): the
  /// history is loaded whatever the touching flag, in the round of the sphere's loads (the same
  /// value for a new contact: nothing writes it in between).
  template <bool Cohesion, bool Rolling, bool Listed = false>
  BIODEM_HD bool wall_entry(std::uint32_t a, std::uint32_t w, Vec3& force, Vec3& torque) const {
    return wall_contact<Cohesion, Rolling, Listed>(a, w, load_sphere(s, a), force, torque);
  }
  /// wall_entry with sphere a's data (sa) loaded by the caller.
  template <bool Cohesion, bool Rolling, bool Listed = false>
  BIODEM_HD bool wall_contact(std::uint32_t a, std::uint32_t w, const SphereState& sa, Vec3& force, Vec3& torque) const {
    // As pair_entry: the sphere's data, the slot's flag and a touching contact's history (Listed:
    // the history whatever the flag) loaded before the wall test; the arithmetic and its order
    // unchanged.
    const std::uint32_t slot = w * n + a;
    const bool was_touching = wall_touching[slot] != 0;
    const Vec3 xa = sa.position;
    const double ra = sa.radius, ma = sa.body_mass;
    const Vec3 va = sa.velocity, wa = sa.omega;
    const std::uint32_t mat_a = sa.material;
    contact::ContactHistory h{};
    if (Listed || was_touching) h = wall_history[slot];
    const DeviceWall& ws = walls[w];
    const walls::WallHit hit = walls::wall_hit(ws.geometry, xa, ra);
    if (!hit.touching) {
      if (was_touching) {
        wall_touching[slot] = 0;
        wall_history[slot] = contact::ContactHistory{};
      }
      return false;
    }
    if (!Listed && !was_touching) h = wall_history[slot];
    const Vec3 surface_point = xa - hit.gap_m * hit.normal;
    const Vec3 v_wall = walls::wall_velocity(ws.geometry, surface_point);
    const Vec3 w_wall = wall_rolling_lab ? Vec3{} : ws.geometry.angular_velocity_rad_s * ws.geometry.normal;
    const contact::ContactGeometry geo =
        contact::sphere_wall_geometry(hit.normal, hit.gap_m, ra, ma, va, wa, v_wall, w_wall);
    const contact::PairParams p = pairs[mat_a * n_materials + ws.material];
    const double area = Cohesion ? contact::sjkr_area_sphere_wall(ra, hit.gap_m) : 0.0;
    const contact::ContactOutput out = contact::evaluate_contact<Cohesion, Rolling>(geo, p, h, area, dt);
    wall_history[slot] = h;
    wall_touching[slot] = 1;
    force = out.force_i;
    torque = out.torque_i;
    return true;
  }
};

/// Every contact of the step at once, one thread per entry k = q * n + a over (rows.cap +
/// n_walls) * n indices: q < rows.cap is entry q of sphere a's row (entries past the row's length
/// do nothing), q = rows.cap + w is a's contact with wall w. Each pair is evaluated once, by the
/// thread of its entry in the row of its lower-id sphere (the entry of the other side does
/// nothing): it writes the pair's touching flag to both entries and, when touching, the force on
/// the lower-id sphere with each side's torque to both entries' slots of rows.entry_force and
/// rows.entry_torque (the other side's entry through rows.mirror), for SumEntries. A touching
/// wall contact's force and torque go to rows.wall_force and rows.wall_torque [w * n + a]. The
/// arithmetic of Forces' loop bodies, so the same bits (Forces evaluates each pair in both rows,
/// with the same operations); a sphere's contacts no longer wait for one another (on a GPU the
/// step's longest chain is one contact, not one row). The pair's history is advanced in the
/// lower-id side's entry only; MirrorHistory copies it to the other side's entry when the whole
/// rows are read (download, a switch to Forces).
template <bool Cohesion, bool Rolling>
struct PairEntries : ContactArgs {
  BIODEM_HD void operator()(std::uint32_t t) const {
    if (halted(halt)) return;
    pair_pass(
        t,
        [this](std::uint32_t k, std::uint32_t a, std::uint32_t sid_a, std::uint32_t b) {
          const std::uint32_t m = rows.mirror[k];
          Vec3 fl, ta, tb;
          bool a_low = true;
          const bool touching =
              b != kUnlisted
                  ? pair_entry_from<Cohesion, Rolling, true>(EntryHead{b, 0u, rows.touching[k] != 0}, a, sid_a, k, fl,
                                                             ta, a_low, &tb)
                  : pair_entry<Cohesion, Rolling>(a, sid_a, k, fl, ta, a_low, &tb);
          rows.touching[m] = touching ? 1 : 0;
          if (touching) {
            rows.entry_force[k] = fl;
            rows.entry_torque[k] = ta;
            rows.entry_force[m] = fl;
            rows.entry_torque[m] = tb;
          }
        },
        [this](std::uint32_t a, std::uint32_t w, bool listed) {
          Vec3 fw, tw;
          if (listed ? wall_entry<Cohesion, Rolling, true>(a, w, fw, tw) : wall_entry<Cohesion, Rolling>(a, w, fw, tw)) {
            rows.wall_force[w * n + a] = fw;
            rows.wall_torque[w * n + a] = tw;
          }
        });
  }
};

/// Whether entry k of the rows is its pair's lower-id side (the entry a per-contact pass
/// evaluates), as 0 or 1: the scan of the pair list's build.
struct LowerSide {
  RowArrays rows;
  const std::uint32_t* sid;
  std::uint32_t n;
  BIODEM_HD std::uint32_t operator()(std::uint32_t k) const {
    const std::uint32_t a = k % n, q = k / n;
    return q < rows.length[a] && sid[a] < rows.sid[k] ? 1u : 0u;
  }
};
/// Whether wall slot `slot` = w * n + a is one a per-contact pass evaluates (the wall-slot
/// list, ContactArgs::PairList): sphere a touched wall w at the last evaluation, or is within
/// reach of it (walls::within_reach, radius plus skin, as the CPU engine's wall candidates), or
/// the wall translates (before, during or after its motion, as in the CPU engine: a moving wall
/// may come to any sphere between two builds).
struct WallSlotNear {
  const Vec3* position;
  const double* radius;
  const DeviceWall* walls;
  const std::uint8_t* wall_touching;
  std::uint32_t n;
  double skin;
  BIODEM_HD std::uint32_t operator()(std::uint32_t slot) const {
    const std::uint32_t a = slot % n, w = slot / n;
    const walls::WallGeometry& g = walls[w].geometry;
    return wall_touching[slot] != 0 || walls[w].translates != 0 || norm2(g.velocity_m_s) > 0.0 ||
                   walls::within_reach(g, position[a], radius[a] + skin)
               ? 1u
               : 0u;
  }
};
/// RowLengths of sphere a (one term of the list build's reduction).
struct SphereListStats {
  const std::uint32_t* length;
  WallSlotNear near;
  std::uint32_t n_walls;
  BIODEM_HD RowLengths operator()(std::uint32_t a) const {
    RowLengths r{length[a], length[a], 0};
    for (std::uint32_t w = 0; w < n_walls; ++w) r.wall_slots += near(w * near.n + a);
    return r;
  }
};

/// A list from the exclusive scan of a flag (LowerSide: the pair list; WallSlotNear: the
/// wall-slot list) over `total` indices (one thread per index): each flagged index at its place,
/// so the list holds them in index order; the last thread writes the count. A list that does not
/// fit `cap` (the host's bound: for pairs half the entries of rows that hold each pair twice, for
/// wall slots the count of the build's reduction) sets `missing` (read at downloads: an internal
/// error) and keeps `cap`.
template <class Flag>
struct ScatterFlagged {
  Flag flag;
  const std::uint32_t* offset;
  std::uint32_t total, cap;
  std::uint32_t *list, *count, *missing;
  /// With `also`: also[place] = also_from[index] for each listed index (the pair list: the
  /// neighbour of each listed entry, rows.j).
  const std::uint32_t* also_from = nullptr;
  std::uint32_t* also = nullptr;
  BIODEM_HD void operator()(std::uint32_t k) const {
    const std::uint32_t f = flag(k), o = offset[k];
    if (f && o < cap) {
      list[o] = k;
      if (also) also[o] = also_from[k];
    }
    if (k + 1 == total) {
      const std::uint32_t c = o + f;
      *count = c < cap ? c : cap;
      if (c > cap) *missing = 1;
    }
  }
};

/// One contact of a sphere's row walk (Forces): contact v of the walk, v < the row's length the
/// pair entry v, then the walls in wall order.
struct RowContact {
  Vec3 force{}, torque{};
  std::uint32_t kind = 0;  // 0: none (not touching, or past the walk's end); 1: a pair, the sphere its
                           // lower-id side; 2: a pair, the higher-id side; 3: a wall
};

/// Where a row walk starts: the sphere, its stable id, its row's length and the walk's length
/// (row + walls).
struct WalkStart {
  std::uint32_t a = 0, sid_a = 0, len = 0, total = 0;
};

/// Contact r's share of the walk's sums, exactly as the walk adds it (each pair counted once, by
/// its lower-id sphere).
BIODEM_HD inline void walk_add(const RowContact& r, Vec3& f, Vec3& t, std::uint32_t& count) {
  if (r.kind == 1 || r.kind == 3) {
    f += r.force;
    t += r.torque;
    ++count;
  } else if (r.kind == 2) {
    f -= r.force;
    t += r.torque;
  }
}

/// The sums of a walk by one thread as the walk adds them (walk_add): the ordered family.
struct OrderedWalkSums {
  Vec3 f{}, t{};
  std::uint32_t count = 0;
  BIODEM_HD void add(const RowContact& r) { walk_add(r, f, t, count); }
  BIODEM_HD void finish(Vec3& fo, Vec3& to, std::uint32_t& co) const {
    fo = f;
    to = t;
    co = count;
  }
};

/// A row walk, item by item (W: Forces): W::walk_begin (false: nothing to do),
/// then each contact of the walk evaluated (W::walk_entry) and added in walk order, then
/// W::walk_end with the sums. The contacts of one walk write disjoint memory (their own entry's
/// history and flag, or their own wall slot), so on a GPU a group of lanes evaluates them at once
/// and the sums are still added in walk order (System::launch_walks): the same bits.
template <class W>
BIODEM_HD inline void walk_row(const W& w, std::uint32_t item) {
  WalkStart st;
  if (!w.walk_begin(item, st)) return;
  Vec3 f, t;
  std::uint32_t count = 0;
  for (std::uint32_t v = 0; v < st.total; ++v) walk_add(w.walk_entry(st, v), f, t, count);
  w.walk_end(item, st, f, t, count);
}

/// The same walk shared by a group of lanes (Group: lane(), size(), shuffle(RowContact, src),
/// the contact lane src of the group holds; on CUDA a group of a warp, for_each_walk): lane l
/// evaluates contacts l, l + lanes, ... of the walk (each writes only its own entry or wall
/// slot), then every lane adds the round's contacts in walk order, taken from their lanes; lane
/// 0 ends the walk. The same contacts added in the same order with the same operations as
/// walk_row: the same bits (RowWalkLanes.GroupsOfThreadLanesGiveTheSumsOfOneThread). Every lane
/// of a group makes the same rounds and shuffles: the item, walk_begin and st.total are the
/// group's.
///
/// A walker that declares kHeadsAhead (Forces) has each lane load the head of its next row entry
/// (v + lanes) while it evaluates entry v, as the walk by one thread does one entry ahead: it then
/// provides head_limit() (entries below it are in the arrays whatever the row's length),
/// walk_head(item, v) and walk_entry_from(st, v, head) for v < st.len (the same contact as
/// walk_entry(st, v), from the head loaded before). The first head is loaded before walk_begin's
/// loads are used. The same contacts, so the same bits.
template <class W, class = void>
struct WalksHeadsAhead {
  static constexpr bool value = false;
};
template <class W>
struct WalksHeadsAhead<W, decltype(void(W::kHeadsAhead))> {
  static constexpr bool value = W::kHeadsAhead;
};

/// A walker of the order-free family (ForcesFixed) declares kFixedSums and gives its sums object
/// (walk_sums(): add(RowContact), finish(f, t, count), integer words q[kWords]).
template <class W, class = void>
struct WalksFixedSums {
  static constexpr bool value = false;
};
template <class W>
struct WalksFixedSums<W, decltype(void(W::kFixedSums))> {
  static constexpr bool value = W::kFixedSums;
};

/// walk_row_lanes of a walker of the order-free family (heads loaded ahead): lane l adds
/// contacts l, l + lanes, ... to its own integer sums, and at the end the lanes' sums are added
/// by a butterfly of shuffles (xor 1, 2, 4, ...), once per walk instead of each contact taken to
/// every lane in every round. Integer additions in any order are exact: the sums of one thread
/// walking the row, and of the per-contact kernels (FixedSumArrays), bit for bit.
template <class W, class Group>
BIODEM_HD inline void walk_row_lanes_fixed(const W& w, std::uint32_t item, const Group& grp) {
  const std::uint32_t lanes = grp.size(), lane = grp.lane();
  auto next = lane < w.head_limit() ? w.walk_head(item, lane) : decltype(w.walk_head(item, lane)){};
  WalkStart st;
  if (!w.walk_begin(item, st)) return;
  auto sums = w.walk_sums();
  for (std::uint32_t v0 = 0; v0 < st.total; v0 += lanes) {
    const std::uint32_t v = v0 + lane;
    if (v < st.len) {
      const auto head = next;
      if (v + lanes < st.len) next = w.walk_head(item, v + lanes);
      sums.add(w.walk_entry_from(st, v, head));
    } else if (v < st.total) {
      sums.add(w.walk_entry(st, v));  // a wall
    }
  }
  for (std::uint32_t m = 1; m < lanes; m <<= 1)
    for (std::uint32_t c = 0; c < sizeof(sums.q) / sizeof(sums.q[0]); ++c) sums.q[c] += grp.shuffle(sums.q[c], lane ^ m);
  if (lane == 0) {
    Vec3 f, t;
    std::uint32_t count = 0;
    sums.finish(f, t, count);
    w.walk_end(item, st, f, t, count);
  }
}

template <class W, class Group>
BIODEM_HD inline void walk_row_lanes(const W& w, std::uint32_t item, const Group& grp) {
  const std::uint32_t lanes = grp.size(), lane = grp.lane();
  if constexpr (WalksFixedSums<W>::value) {
    walk_row_lanes_fixed(w, item, grp);
  } else if constexpr (WalksHeadsAhead<W>::value) {
    auto next = lane < w.head_limit() ? w.walk_head(item, lane) : decltype(w.walk_head(item, lane)){};
    WalkStart st;
    if (!w.walk_begin(item, st)) return;
    Vec3 f, t;
    std::uint32_t count = 0;
    for (std::uint32_t v0 = 0; v0 < st.total; v0 += lanes) {
      const std::uint32_t v = v0 + lane;
      RowContact mine;
      if (v < st.len) {
        const auto head = next;
        if (v + lanes < st.len) next = w.walk_head(item, v + lanes);
        mine = w.walk_entry_from(st, v, head);
      } else {
        mine = w.walk_entry(st, v);  // a wall, or past the walk's end
      }
      const std::uint32_t in_round = st.total - v0 < lanes ? st.total - v0 : lanes;
      for (std::uint32_t src = 0; src < in_round; ++src) walk_add(grp.shuffle(mine, src), f, t, count);
    }
    if (lane == 0) w.walk_end(item, st, f, t, count);
  } else {
    WalkStart st;
    if (!w.walk_begin(item, st)) return;
    Vec3 f, t;
    std::uint32_t count = 0;
    for (std::uint32_t v0 = 0; v0 < st.total; v0 += lanes) {
      const RowContact mine = w.walk_entry(st, v0 + lane);
      const std::uint32_t in_round = st.total - v0 < lanes ? st.total - v0 : lanes;
      for (std::uint32_t src = 0; src < in_round; ++src) walk_add(grp.shuffle(mine, src), f, t, count);
    }
    if (lane == 0) w.walk_end(item, st, f, t, count);
  }
}

/// Index of the lowest set bit of v (v != 0).
BIODEM_HD inline std::uint32_t lowest_bit(std::uint32_t v) {
#ifdef __CUDA_ARCH__
  return static_cast<std::uint32_t>(__ffs(static_cast<int>(v)) - 1);
#else
  std::uint32_t i = 0;
  while (!(v & 1u)) {
    v >>= 1;
    ++i;
  }
  return i;
#endif
}

/// The scratch of one group of walk_packed (on a GPU a warp's part of the block's shared
/// memory, on CPU threads the caller's stack): the queue of touching contacts waiting for a
/// round of evaluation (at most twice the lanes: fewer than `lanes` wait before a step of the
/// walk, which adds at most `lanes`), and one round's results.
template <class Head>
struct PackedWalkScratch {
  static constexpr std::uint32_t kLanes = 32, kQueue = 2 * kLanes;
  RowContact result[kLanes];
  WalkStart owner[kQueue];  // the walk the contact is of
  std::uint32_t v[kQueue];  // its index in that walk
  Head head[kQueue];        // a pair entry's head (v < owner.len)
};

/// Row walks of a warp's spheres, one per lane, with the touching contacts shared by the lanes
/// (BIODEM_GPU_WALK_PACK=1; on CUDA a group of the 32 lanes of a warp, for_each_packed_walk; on
/// CPU threads one lane). In the walk by one thread per sphere a warp runs a touching contact's
/// long evaluation at every step of the walk where any of its 32 spheres touches (the raw drum:
/// 13.8 of 32 lanes active on average, ncu, lease 9). Here each lane tests its walk's entries
/// for contact in step (the cut-off test alone: W::walk_touches_from for pair entries, with
/// their heads loaded one entry ahead, and W::walk_touches for walls, which also do what the
/// walk does for a contact apart), the touching ones queue in the group's scratch in (step,
/// lane) order, and each time `lanes` of them wait, every lane evaluates one of them
/// (W::walk_entry_from, W::walk_entry: the walk's own evaluation, loads and test included). The
/// sphere that owns a contact then adds the round's results that are its own in queue order,
/// which is its walk order: the same contacts added in the same order with the same operations
/// as the walk by one thread, so the same bits. Every lane of the group calls it (`valid` false
/// for a lane past the items); a lane's walk writes only its own entries, wall slots and
/// sphere, so which lane evaluates a contact changes nothing. Groups of at most
/// PackedWalkScratch::kLanes (32) lanes: the queue holds fewer than twice the lanes.
/// With split_log2 > 0 (BIODEM_GPU_PACK_SPLIT; at most the group's lanes), 2^split_log2
/// consecutive lanes share one item's walk (all of them called with that item): the lane with
/// part p of it tests entries p, p + 2^split_log2, ..., so that the walk's tests take that many
/// times fewer steps; at a step the item's touching entries queue in lane order, which is their
/// walk order, and the item's first lane (part 0) owns them all: it adds them and ends the walk.
/// The same contacts in the same order: the same bits. (Split: compiled with the split; without
/// it, split_log2 is 0 and the walk holds none of the split's state: ptxas spilled the clumps'
/// packed groups, which never split, 20 bytes more with it.)
template <bool Split = false, class W, class Group, class Head>
BIODEM_HD inline void walk_packed(const W& w, std::uint32_t item, bool valid, const Group& grp,
                                  PackedWalkScratch<Head>& sc, std::uint32_t split_log2 = 0) {
  const std::uint32_t lanes = grp.size(), lane = grp.lane(), below = (1u << lane) - 1u;
  const std::uint32_t split = Split ? 1u << split_log2 : 1u, part = Split ? lane & (split - 1u) : 0u;
  // (the lanes of this item's walk, as bits of the group's ballots; split = 32: every lane)
  const std::uint32_t walk_lanes = !Split ? 1u << lane : split >= 32u ? ~0u : ((1u << split) - 1u) << (lane - part);
  Head next{};
  if (valid && part < w.head_limit()) next = w.walk_head(item, part);  // (entry `part` is in the arrays)
  WalkStart st{};
  const bool live = valid && w.walk_begin(item, st);
  OrderedWalkSums sums;
  std::uint32_t queued = 0, mine = 0, mine_next = 0;  // (mine: my contacts' slots in this round)
  // One round: the first `count` queued contacts evaluated, one per lane, and added by their
  // owners; the rest moved to the front.
  auto round = [&](std::uint32_t count) {
    grp.sync();  // (the queue's writes before its reads)
    if (lane < count) {
      const WalkStart& o = sc.owner[lane];
      const std::uint32_t v = sc.v[lane];
      sc.result[lane] = v < o.len ? w.walk_entry_from(o, v, sc.head[lane]) : w.walk_entry(o, v);
    }
    grp.sync();  // (the results before their owners read them)
    for (std::uint32_t m = mine; m; m &= m - 1u) sums.add(sc.result[lowest_bit(m)]);
    const std::uint32_t rest = queued - count;  // (< lanes: no lane reads a slot another writes)
    if (rest) {  // (the same for every lane; with none left, the next writes go to slots read before the second sync)
      WalkStart o{};
      std::uint32_t v = 0;
      Head h{};
      if (lane < rest) {
        o = sc.owner[count + lane];
        v = sc.v[count + lane];
        h = sc.head[count + lane];
      }
      grp.sync();  // (every read of this round before the moves and the next round's writes)
      if (lane < rest) {
        sc.owner[lane] = o;
        sc.v[lane] = v;
        sc.head[lane] = h;
      }
    }
    mine = mine_next;
    mine_next = 0;
    queued = rest;
  };
  for (std::uint32_t v = part; grp.ballot(live && v < st.total) != 0; v += split) {
    bool touching = false;
    Head head{};
    if (live && v < st.len) {
      head = next;
      if (v + split < st.len) next = w.walk_head(item, v + split);
      touching = w.walk_touches_from(st, v, head);
    } else if (live && v < st.total) {
      touching = w.walk_touches(st, v);  // a wall
    }
    const std::uint32_t voted = grp.ballot(touching);
    if (touching) {
      const std::uint32_t slot = queued + count_bits(voted & below);
      sc.owner[slot] = st;
      sc.v[slot] = v;
      sc.head[slot] = head;
      if constexpr (!Split) {
        if (slot < lanes) mine |= 1u << slot;
        else mine_next |= 1u << (slot - lanes);
      }
    }
    if constexpr (Split) {
      if (part == 0) {  // the walk's touching entries of this step, whichever of its lanes found them
        for (std::uint32_t m = voted & walk_lanes; m; m &= m - 1u) {
          const std::uint32_t k = lowest_bit(m), slot = queued + count_bits(voted & ((1u << k) - 1u));
          if (slot < lanes) mine |= 1u << slot;
          else mine_next |= 1u << (slot - lanes);
        }
      }
    }
    queued += count_bits(voted);
    if (queued >= lanes) round(lanes);
  }
  if (queued) round(queued);
  if (live && part == 0) {
    Vec3 f, t;
    std::uint32_t count = 0;
    sums.finish(f, t, count);
    w.walk_end(item, st, f, t, count);
  }
}

/// A walker walk_packed can run: it has the cut-off tests alone (walk_touches_from,
/// walk_touches) and adds its contacts as doubles in walk order (not the order-free family).
template <class W, class = void>
struct WalksPacked {
  static constexpr bool value = false;
};
template <class W>
struct WalksPacked<W, decltype(void(&W::walk_touches_from))> {
  static constexpr bool value = !WalksFixedSums<W>::value;
};

/// The contact forces on sphere a (one item per sphere): its pair contacts in the order of the
/// row (stable ids), then its walls in wall order, summed into its force, torque and contact
/// count (BIODEM_GPU_FORCES=rows). Each pair is evaluated from the side of its lower stable id,
/// in both of its spheres' walks with identical arithmetic; each walk keeps its own copy of the
/// pair's history in its entry, and the copies stay bit-identical. One thread per sphere walks
/// the whole row, or (CUDA) a group of lanes per sphere evaluates the contacts at once and adds
/// them in walk order (System::launch_walks, BIODEM_GPU_ROW_LANES).
template <bool Cohesion, bool Rolling>
struct Forces : ContactArgs {
  BIODEM_HD bool walk_begin(std::uint32_t a, WalkStart& st) const {
    if (halted(halt)) return false;
    st.a = a;
    st.sid_a = s.sid[a];
    st.len = rows.length[a];
    st.total = st.len + n_walls;
    return true;
  }
  BIODEM_HD RowContact walk_entry(const WalkStart& st, std::uint32_t v) const {
    RowContact r;
    if (v < st.len) {
      bool a_low = false;
      if (pair_entry<Cohesion, Rolling>(st.a, st.sid_a, v * n + st.a, r.force, r.torque, a_low)) r.kind = a_low ? 1 : 2;
    } else if (v < st.total) {
      if (wall_entry<Cohesion, Rolling>(st.a, v - st.len, r.force, r.torque)) r.kind = 3;
    }
    return r;
  }
  BIODEM_HD void walk_end(std::uint32_t, const WalkStart& st, const Vec3& f, const Vec3& t, std::uint32_t count) const {
    s.force[st.a] = f;
    s.torque[st.a] = t;
    s.contacts[st.a] = count;
  }
  /// The row lanes load each one's next entry head ahead (walk_row_lanes).
  static constexpr bool kHeadsAhead = true;
  BIODEM_HD std::uint32_t head_limit() const { return rows.cap; }
  BIODEM_HD EntryHead walk_head(std::uint32_t a, std::uint32_t v) const { return entry_head(v * n + a); }
  /// walk_packed's tests: pair entry v (< st.len) from its head, and wall v - st.len.
  BIODEM_HD bool walk_touches_from(const WalkStart& st, std::uint32_t v, const EntryHead& e) const {
    return this->pair_touches(e, st.a, st.sid_a, v * n + st.a);
  }
  BIODEM_HD bool walk_touches(const WalkStart& st, std::uint32_t v) const { return wall_touches(st.a, v - st.len); }
  /// Pair entry v (< st.len) of the walk from its head: walk_entry(st, v)'s contact.
  BIODEM_HD RowContact walk_entry_from(const WalkStart& st, std::uint32_t v, const EntryHead& e) const {
    RowContact r;
    bool a_low = false;
    if (pair_entry_from<Cohesion, Rolling>(e, st.a, st.sid_a, v * n + st.a, r.force, r.torque, a_low))
      r.kind = a_low ? 1 : 2;
    return r;
  }
  /// The walk by one thread (on CUDA with BIODEM_GPU_ROW_LANES=1 or when timed fastest; on CPU
  /// threads always): walk_row's contacts in walk order with the same operations, each entry's
  /// head loaded one entry ahead (the first with the sphere's stable id and row length), so that
  /// the thread waits for one round of loads per entry instead of two. The same bits as walk_row.
  BIODEM_HD void operator()(std::uint32_t a) const { walk_prefetched(*this, a); }
  /// That walk for W, Forces or a kernel derived from it: W::walk_end ends it. Sums: how the
  /// contacts are added (OrderedWalkSums: in walk order as doubles, walk_add; FixedWalkSums: as
  /// fixed-point integers, the order-free family).
  template <class W, class Sums = OrderedWalkSums>
  BIODEM_HD static void walk_prefetched(const W& w, std::uint32_t a, Sums sums = Sums{}) {
    if (halted(w.halt)) return;
#ifndef BIODEM_GPU_NO_RECORD_PATHS
    if (w.own_sphere) {
      walk_heads<true>(w, a, sums);
      return;
    }
#endif
    walk_heads<false>(w, a, sums);
  }
  /// walk_prefetched's walk. Own (BIODEM_GPU_OWN_SPHERE=1): the row's own sphere loaded once,
  /// with its stable id and row length, and held for every entry and wall, so that each entry
  /// loads only its neighbour; the same contacts in the same order with the same values, so the
  /// same bits.
  template <bool Own, class W, class Sums>
  BIODEM_HD static void walk_heads(const W& w, std::uint32_t a, Sums& sums) {
    const std::uint32_t sid_a = w.s.sid[a], len = w.rows.length[a];
    SphereState own{};
    if constexpr (Own) own = load_sphere(w.s, a);
    EntryHead next = w.entry_head(a);  // entry 0 (in the arrays whatever the row's length)
    for (std::uint32_t v = 0; v < len; ++v) {
      const EntryHead e = next;
      if (v + 1 < len) next = w.entry_head((v + 1) * w.n + a);
      RowContact r;
      bool a_low = false;
      bool touching;
      if constexpr (Own)
        touching = w.template pair_entry_own<Cohesion, Rolling>(e, own, sid_a, v * w.n + a, r.force, r.torque, a_low);
      else
        touching = w.template pair_entry_from<Cohesion, Rolling>(e, a, sid_a, v * w.n + a, r.force, r.torque, a_low);
      if (touching) r.kind = a_low ? 1 : 2;
      sums.add(r);
    }
    const WalkStart st{a, sid_a, len, len + w.n_walls};
    for (std::uint32_t v = len; v < st.total; ++v) {
      if constexpr (Own) {
        RowContact r;
        if (w.template wall_contact<Cohesion, Rolling>(a, v - len, own, r.force, r.torque)) r.kind = 3;
        sums.add(r);
      } else {
        sums.add(w.walk_entry(st, v));
      }
    }
    Vec3 f, t;
    std::uint32_t count = 0;
    sums.finish(f, t, count);
    w.walk_end(a, st, f, t, count);
  }
};

/// Sphere a's contact sums from the entry buffers of PairEntries (BIODEM_GPU_FORCES=entries):
/// the touching entries' and walls' results, read in row order then wall order, with the
/// operations of the row walk (Forces), so the same bits.
template <bool Cohesion, bool Rolling>
struct SumEntries : ContactArgs {
  BIODEM_HD void operator()(std::uint32_t a) const {
    if (halted(halt)) return;
    Vec3 f, t;
    std::uint32_t count = 0;
    sum_entries(a, s.sid[a], rows.length[a], f, t, count);
    s.force[a] = f;
    s.torque[a] = t;
    s.contacts[a] = count;
  }
};

/// Force on body k (gravity plus its spheres' contact forces, in template order) and torque
/// about its centre of mass (ReduceKick, ReduceKickDrift).
/// The spheres' force, torque and centre are loaded four spheres at a time, every load of a chunk
/// before its first addition (a GPU thread waits for memory once per chunk); the additions stay
/// in template order.
BIODEM_HD inline void body_sums(const BodyArrays& b, const SphereArrays& s, std::uint32_t k, const Vec3& gravity, Vec3& f,
                                Vec3& t) {
  const std::uint32_t s0 = b.first_sphere[k], ns = b.sphere_count[k];
  const Vec3 x = b.position[k];
  f = b.mass[k] * gravity;
  t = Vec3{};
  constexpr std::uint32_t kChunk = 4;
  for (std::uint32_t c0 = 0; c0 < ns; c0 += kChunk) {
    Vec3 fs[kChunk], ts[kChunk], ps[kChunk];
    for (std::uint32_t c = 0; c < kChunk; ++c)
      if (c0 + c < ns) {
        fs[c] = s.force[s0 + c0 + c];
        ts[c] = s.torque[s0 + c0 + c];
        ps[c] = s.position[s0 + c0 + c];
      }
    for (std::uint32_t c = 0; c < kChunk && c0 + c < ns; ++c) {
      f += fs[c];
      t += ts[c] + cross(ps[c] - x, fs[c]);
    }
  }
}

/// Body force and torque (body_sums); then, when `kick`, the second half kick (the CPU engine's
/// step, parts 5-6).
struct ReduceKick {
  BodyArrays b;
  SphereArrays s;
  Vec3 gravity;
  double h;
  bool kick;
  Halt halt;
  BIODEM_HD void operator()(std::uint32_t k) const {
    if (halted(halt)) return;
    const std::uint32_t ns = b.sphere_count[k];
    Vec3 f, t;
    body_sums(b, s, k, gravity, f, t);
    b.force[k] = f;
    b.torque[k] = t;
    if (!kick) return;
    integrate::half_kick(b.velocity[k], b.omega[k], b.ang_momentum[k], b.orientation[k], b.mass[k], b.inertia[k], ns, f,
                         t, h);
  }
};

/// ReduceKick of step c and KickDriftSpheres of step c + 1 in one thread per body: the launches
/// between two list checks outside a settle-criterion phase (nothing runs between the two
/// kernels there). The same operations in the same order as the two kernels (body sums in
/// template order, the second half kick with the sums, then half kick, drift and turn with the
/// same force and torque, then the spheres), so the same bits; the body's state stays in
/// registers between the two halves instead of going through memory.
/// Body k's state, loaded into registers (ReduceKickDrift, SumEntriesKickDrift).
struct BodyState {
  std::uint32_t s0, ns;
  double m;
  Vec3 x, inertia, v, w, l;
  Quat q;
};
BIODEM_HD inline BodyState load_body(const BodyArrays& b, std::uint32_t k) {
  return BodyState{b.first_sphere[k], b.sphere_count[k], b.mass[k],     b.position[k], b.inertia[k],
                   b.velocity[k],     b.omega[k],        b.ang_momentum[k], b.orientation[k]};
}

struct ReduceKickDrift {
  BodyArrays b;
  SphereArrays s;
  Vec3 gravity;
  double h, dt;
  Halt halt;
  bool centred = false;  // every body is one sphere at its centre (spheres_of_body)
  /// The rest of body k's step from its force and torque: both stored, the second half kick of
  /// step c, then the half kick, drift and turn of step c + 1 in registers, the state stored once.
  BIODEM_HD void finish(std::uint32_t k, BodyState st, const Vec3& f, const Vec3& t) const {
    b.force[k] = f;
    b.torque[k] = t;
    integrate::half_kick_then_kick_and_drift(st.x, st.v, st.w, st.l, st.q, st.m, st.inertia, st.ns, f, t, h, dt);
    store_body(b, s, k, st.s0, st.ns, st.x, st.v, st.w, st.l, st.q, centred);
  }
  BIODEM_HD void operator()(std::uint32_t k) const {
    if (halted(halt)) return;
    if (centred) {
      // Body k is sphere k at its centre (Engine::centred_spheres_): the sphere's force, torque
      // and centre loaded with the body's state, in one round, instead of after the body's
      // first sphere is known; body_sums' operations for one sphere.
      const Vec3 fs = s.force[k], ts = s.torque[k], p = s.position[k];
      const BodyState st = load_body(b, k);
      Vec3 f = st.m * gravity, t{};
      f += fs;
      t += ts + cross(p - st.x, fs);
      finish(k, st, f, t);
      return;
    }
    // Every load of the body's state before the first store (its force), so that none waits
    // behind a store it might alias; then the halves in registers and the state stored once.
    const BodyState st = load_body(b, k);
    Vec3 f, t;
    body_sums(b, s, k, gravity, f, t);
    finish(k, st, f, t);
  }
};

/// ReduceKickDrift of body k by a group of lanes (BIODEM_GPU_BODY_LANES; on a GPU lanes of one
/// warp, on CPU threads one lane), for scenes of clumps: every lane loads the body's state, the
/// body-frame offset of its own first sphere, and the body's spheres' sums (body_sums), all
/// before any store; after the group's sync every lane integrates the body in registers (the
/// same operations on the same values: the same bits in every lane), lane 0 stores the body,
/// and lane l places spheres l, l + lanes, ... (spheres_of_body's formula for each). Against
/// ReduceKickDrift in one thread: the offsets are not loaded after the body's stores (on the
/// H100, 22 % of that kernel's stall samples on the raw drum waited for them), and a needle's
/// three spheres are placed at once instead of one after another. The same bits
/// (BodyLanes.GroupsOfThreadLanesGiveTheBitsOfReduceKickDrift,
/// GpuEngine.SphereRecordsAndTheWalksOwnSphereGiveTheBitsOfTheArrays). Not for scenes whose
/// bodies are all centred single spheres (rkd.centred, which it ignores: the engine launches
/// it only in scenes with clumps).
struct ReduceKickDriftLanes {
  ReduceKickDrift rkd;
  template <class Group>
  BIODEM_HD void run(std::uint32_t k, const Group& grp) const {
    if (halted(rkd.halt)) return;  // (the same flag for every lane of the group)
    run_summing(k, grp, rkd.s);
  }
  /// run's body update with the body sums taken from `sums_from` (the spheres' forces, torques
  /// and the centres they were computed at) and the spheres placed in rkd.s: the same array set
  /// for run; the walk's buffer for ForcesKickDriftGroups, whose rkd.s is the other buffer.
  template <class Group>
  BIODEM_HD void run_summing(std::uint32_t k, const Group& grp, const SphereArrays& sums_from) const {
    const std::uint32_t lanes = grp.size(), lane = grp.lane();
    BodyState st = load_body(rkd.b, k);
    Vec3 f, t;
    body_sums(rkd.b, sums_from, k, rkd.gravity, f, t);
    // (after the sums, whose four spheres' loads in flight take the registers, and before the
    // stores: its wait overlaps the integration)
    Vec3 own_offset{};
    if (lane < st.ns) own_offset = rkd.s.offset[st.s0 + lane];
    grp.sync();  // (every lane's loads of the body and its spheres before the stores below)
    integrate::half_kick_then_kick_and_drift(st.x, st.v, st.w, st.l, st.q, st.m, st.inertia, st.ns, f, t, rkd.h,
                                             rkd.dt);
    if (lane == 0) {
      rkd.b.force[k] = f;
      rkd.b.torque[k] = t;
      rkd.b.position[k] = st.x;
      rkd.b.velocity[k] = st.v;
      rkd.b.omega[k] = st.w;
      rkd.b.ang_momentum[k] = st.l;
      rkd.b.orientation[k] = st.q;
    }
    if (st.ns == 1 && own_offset == Vec3{}) {  // (spheres_of_body's single centred sphere)
      if (lane == 0) set_motion(rkd.s, st.s0, st.x, st.v, st.w);
      return;
    }
    const Mat3 R = to_matrix(st.q);
    for (std::uint32_t c = lane; c < st.ns; c += lanes) {
      const Vec3 arm = R * (c == lane ? own_offset : rkd.s.offset[st.s0 + c]);
      set_motion(rkd.s, st.s0 + c, st.x + arm, st.v + cross(st.w, arm), st.w);
    }
  }
  BIODEM_HD void operator()(std::uint32_t k) const { run(k, OneLane{}); }
};

/// The rest of SumEntriesKickDrift once sphere k's sums (fs, ts, count) are known: they are
/// stored, then ReduceKickDrift of body k on them. The body's state and the sphere's centre are
/// loaded before the first store; the body sums take the sphere's sums from registers (body_sums
/// of a body of one sphere on the values just stored: the same operations on the same values,
/// so the same bits as the two kernels).
BIODEM_HD inline void finish_single_sphere(const ContactArgs& c, const ReduceKickDrift& rkd, std::uint32_t k,
                                           const Vec3& fs, const Vec3& ts, std::uint32_t count) {
  const BodyState st = load_body(rkd.b, k);
  const Vec3 p = c.s.position[k];
  c.s.force[k] = fs;
  c.s.torque[k] = ts;
  c.s.contacts[k] = count;
  Vec3 f = st.m * rkd.gravity, t{};
  f += fs;
  t += ts + cross(p - st.x, fs);
  rkd.finish(k, st, f, t);
}

/// In a scene of single-sphere bodies (glass beads), SumEntries of body k's sphere and
/// ReduceKickDrift of body k in one thread: one launch and one pass over the spheres fewer per
/// step. The same operations in the same order as the two kernels: the same bits. Only for
/// bodies of one sphere whose sphere k is body k's (the engine launches it only then).
struct SumEntriesKickDrift {
  ContactArgs c;
  ReduceKickDrift rkd;
  BIODEM_HD void operator()(std::uint32_t k) const {
    if (halted(rkd.halt)) return;
    // Body k's sphere is sphere k: the engine launches this kernel only when every body has one
    // sphere and body k's first sphere is k (checked at upload; a body sort keeps it, the first
    // spheres being the running sum of the counts), so no load of first_sphere before the row's.
    // The body's state is loaded after the sums (loaded with the entries it costs registers the
    // entry loads need: spills).
    Vec3 fs, ts;
    std::uint32_t count = 0;
    c.sum_entries(k, c.s.sid[k], c.rows.length[k], fs, ts, count);
    finish_single_sphere(c, rkd, k, fs, ts, count);
  }
};

/// In a scene of single-sphere bodies, the row walk (Forces) of sphere k and ReduceKickDrift of
/// body k in one thread (or lane 0 of the walk's group): one launch and one pass over the bodies
/// fewer per step (BIODEM_GPU_WALK_KICK). The walk reads the neighbours' centres, velocities and
/// spins, which the body update of another thread changes: so it reads them from one buffer
/// (the ContactArgs' spheres, the state the step's forces see) and the update writes them to
/// another (rkd.s: its position, velocity and omega arrays the other buffer, its other arrays
/// those of the ContactArgs), and the engine swaps the two every step (Engine::fused_unit). Every
/// other array a thread writes is its own sphere's or body's (its row's entries and wall slots,
/// its force, torque and contact count, its body's state). The same operations in the same order
/// as Forces then ReduceKickDrift (finish_single_sphere): the same bits. Only for bodies of one
/// sphere whose sphere k is body k's (as SumEntriesKickDrift).
template <bool Cohesion, bool Rolling>
struct ForcesKickDrift : Forces<Cohesion, Rolling> {
  ReduceKickDrift rkd;
  BIODEM_HD void walk_end(std::uint32_t, const WalkStart& st, const Vec3& f, const Vec3& t, std::uint32_t count) const {
    finish_single_sphere(*this, rkd, st.a, f, t, count);
  }
  BIODEM_HD void operator()(std::uint32_t a) const { Forces<Cohesion, Rolling>::walk_prefetched(*this, a); }
};
static_assert(WalksHeadsAhead<ForcesKickDrift<false, false>>::value && WalksHeadsAhead<Forces<true, true>>::value,
              "the row lanes of the walk load their heads ahead");

/// In a scene of clumps, ForcesKickDrift's fusion by a group of lanes per body
/// (BIODEM_GPU_WALK_KICK; the timed choice's fifth set there; on CUDA the lanes of one warp, at
/// least as many as the body's most spheres, on CPU threads one lane): lane l walks the rows of
/// the body's spheres l, l + lanes, ... in one thread each (walk(a): Forces' walk, which stores
/// sphere a's force, torque and contact count in walk.s), and after the group's sync the lanes
/// finish body k as ReduceKickDriftLanes does, with the body sums read from the walk's buffer
/// (walk.s: the centres the forces were computed at) and the spheres placed in the other
/// (out.rkd.s), the two swapped every step as for ForcesKickDrift. Against Forces then
/// ReduceKickDrift: one launch fewer per step, and the body update of a group starts as soon as
/// its own spheres' walks end instead of after the slowest walk of the grid. The same operations
/// on the same values: the same bits (BodyLanes.WalkAndBodyUpdateByGroupsGiveTheBitsOfTheTwoKernels
/// with groups of thread lanes; GpuEngine.WalkWithTheBodyUpdateGivesTheBitsOfTheWalkAndReduceKickDrift
/// in the engine; gpu_check 3i on a GPU).
template <class Walk>
struct WalkKickGroups {
  Walk walk;
  ReduceKickDriftLanes out;
  template <class Group>
  BIODEM_HD void run(std::uint32_t k, const Group& grp) const {
    if (halted(out.rkd.halt)) return;  // (the same flag for every lane of the group)
    const std::uint32_t s0 = out.rkd.b.first_sphere[k], ns = out.rkd.b.sphere_count[k];
    for (std::uint32_t c = grp.lane(); c < ns; c += grp.size()) walk(s0 + c);
    grp.sync();  // (every lane's sphere sums stored before any lane loads them)
    out.run_summing(k, grp, walk.s);
  }
  /// run with the walks of the whole warp's spheres sharing their touching contacts
  /// (walk_packed; BIODEM_GPU_WALK_PACK=1): every lane of the warp calls it, `valid` false for a
  /// group past the bodies; lane l of body k's group walks its spheres l, l + lanes, ... in
  /// rounds that the warp makes together (one round when the groups have as many lanes as the
  /// most spheres of a body, as the engine makes them), then the group finishes the body as in
  /// run. The same walks, so the same bits.
  template <class Group, class Warp, class Head>
  BIODEM_HD void run_packed(std::uint32_t k, bool valid, const Group& grp, const Warp& warp,
                            PackedWalkScratch<Head>& sc) const {
    if (halted(out.rkd.halt)) return;  // (the same flag for every lane of the warp)
    // (the body's first sphere and count loaded again each round rather than held across the
    // walk: with cohesion and rolling friction ptxas spilled 16 bytes holding them)
    for (std::uint32_t c = grp.lane();; c += grp.size()) {
      const bool mine = valid && c < out.rkd.b.sphere_count[k];
      if (warp.ballot(mine) == 0) break;
      walk_packed(walk, mine ? out.rkd.b.first_sphere[k] + c : 0u, mine, warp, sc);
    }
    grp.sync();  // (every lane's sphere sums stored before any lane loads them)
    if (valid) out.run_summing(k, grp, walk.s);
  }
  BIODEM_HD void operator()(std::uint32_t k) const { run(k, OneLane{}); }
};
/// Forces' one-thread walk without the own-sphere variant (BIODEM_GPU_OWN_SPHERE): compiled into
/// WalkKickGroups with the body update, that variant's registers made ptxas spill (sm_90: 36
/// bytes with cohesion and rolling friction; none without it).
template <bool Cohesion, bool Rolling>
struct ForcesWalkNoOwn : Forces<Cohesion, Rolling> {
  BIODEM_HD void operator()(std::uint32_t a) const {
    if (halted(this->halt)) return;
    OrderedWalkSums sums;
    Forces<Cohesion, Rolling>::template walk_heads<false>(*this, a, sums);
  }
};
template <bool Cohesion, bool Rolling>
using ForcesKickDriftGroups = WalkKickGroups<ForcesWalkNoOwn<Cohesion, Rolling>>;

/// The sphere motion that ForcesKickDrift wrote to the other buffer, copied back (after an odd
/// number of its steps, so that the engine's arrays hold the state between runs).
struct CopySphereMotion {
  const Vec3 *position, *velocity, *omega;
  Vec3 *position_to, *velocity_to, *omega_to;
  const SphereRecord* record = nullptr;  // and the records' (when there are records)
  SphereRecord* record_to = nullptr;
  // At the end of a run of steps: the run's halt words without the over flags (ignore 3): the
  // second buffer's, which the last unit's drift may have raised, does not stop the copy, and
  // is raised for the first, which holds that motion from here (a raised first-buffer flag
  // always stopped a kernel of the run before, which raised `stop`). Halt{}: always copies.
  Halt halt{};
  BIODEM_HD void operator()(std::uint32_t i) const {
    if (halted(halt)) return;
    if (i == 0 && halt.guard && flag_load(&halt.guard->over[1])) flag_raise(&halt.guard->over[0]);
    position_to[i] = position[i];
    velocity_to[i] = velocity[i];
    omega_to[i] = omega[i];
#ifndef BIODEM_GPU_NO_RECORD_PATHS
    if (record) record_to[i] = record[i];
#endif
  }
};

/// Contact v of a sphere's walk over the entry buffers that PairEntries wrote: v < st.len the
/// pair entry v's result (kind 1 when the walk's sphere is the pair's lower-id side, 2 when not),
/// then the walls (kind 3); kind 0 when not touching or past the walk's end. walk_add adds kind
/// 1, 2 and 3 with add_pair's and the walls' operations of sum_entries, in the same order (the
/// row's entries, then the walls), so a walk gives sum_entries' bits.
BIODEM_HD inline RowContact entry_result(const ContactArgs& c, const WalkStart& st, std::uint32_t v) {
  RowContact r;
  if (v < st.len) {
    const std::uint32_t k = v * c.n + st.a;
    const bool touching = c.rows.touching[k] != 0, low = st.sid_a < c.rows.sid[k];
    const Vec3 f = c.rows.entry_force[k], t = c.rows.entry_torque[k];
    if (touching) {
      r.force = f;
      r.torque = t;
      r.kind = low ? 1 : 2;
    }
  } else if (v < st.total) {
    const std::uint32_t slot = (v - st.len) * c.n + st.a;
    const bool touching = c.wall_touching[slot] != 0;
    const Vec3 f = c.rows.wall_force[slot], t = c.rows.wall_torque[slot];
    if (touching) {
      r.force = f;
      r.torque = t;
      r.kind = 3;
    }
  }
  return r;
}
BIODEM_HD inline bool entry_walk_begin(const ContactArgs& c, std::uint32_t a, WalkStart& st) {
  st.a = a;
  st.sid_a = c.s.sid[a];
  st.len = c.rows.length[a];
  st.total = st.len + c.n_walls;
  return true;
}

/// SumEntries as a row walk over the entry buffers (BIODEM_GPU_SUM_LANES): on CUDA a group of
/// row lanes per sphere (walk_row_lanes), whose lanes load their entries' results at once and
/// add them in walk order, instead of one thread loading the row's entries chunk by chunk; on CPU
/// threads one thread (walk_row). The same bits as SumEntries (entry_result).
struct SumEntriesWalk : ContactArgs {
  BIODEM_HD bool walk_begin(std::uint32_t a, WalkStart& st) const { return !halted(halt) && entry_walk_begin(*this, a, st); }
  BIODEM_HD RowContact walk_entry(const WalkStart& st, std::uint32_t v) const { return entry_result(*this, st, v); }
  BIODEM_HD void walk_end(std::uint32_t, const WalkStart& st, const Vec3& f, const Vec3& t, std::uint32_t count) const {
    s.force[st.a] = f;
    s.torque[st.a] = t;
    s.contacts[st.a] = count;
  }
  BIODEM_HD void operator()(std::uint32_t a) const { walk_row(*this, a); }
};

/// SumEntriesKickDrift with the sphere's sums as a row walk (as SumEntriesWalk); lane 0 of the
/// group then finishes the body (finish_single_sphere). The same bits as SumEntriesKickDrift.
struct SumEntriesKickDriftWalk {
  ContactArgs c;
  ReduceKickDrift rkd;
  BIODEM_HD bool walk_begin(std::uint32_t k, WalkStart& st) const { return !halted(rkd.halt) && entry_walk_begin(c, k, st); }
  BIODEM_HD RowContact walk_entry(const WalkStart& st, std::uint32_t v) const { return entry_result(c, st, v); }
  BIODEM_HD void walk_end(std::uint32_t k, const WalkStart&, const Vec3& f, const Vec3& t, std::uint32_t count) const {
    finish_single_sphere(c, rkd, k, f, t, count);
  }
  BIODEM_HD void operator()(std::uint32_t k) const { walk_row(*this, k); }
};

/// The per-sphere fixed-point sums of the order-free family (BIODEM_GPU_SUMS=fixed,
/// fixed_sums.hpp): eight 64-bit words per sphere, sums[8 i + c]: c = 0..2 the force and 3..5 the
/// torque in quanta of force_quantum and torque_quantum, 6 the contacts counted once (a pair by
/// its lower-id side, a wall by its sphere), 7 nonzero when a contribution was refused. One
/// sphere's words share 64 bytes (two 32-byte sectors), so a pair's additions to its other
/// sphere touch two sectors, not seven lines. All zero between steps: the kernel that takes a
/// sphere's sums zeroes them.
struct FixedSumArrays {
  long long* sums;
  double force_scale, force_quantum, torque_scale, torque_quantum;
  double limit;  // the largest |contribution| in quanta (fixed::limit_for of the row capacity and walls)
  static constexpr std::uint32_t kWords = 8;

  /// Adds force f and torque t to sphere i's sums (and one to its count when `counted`); a
  /// component beyond the limit (or not a number) adds nothing and flags the sphere.
  BIODEM_HD void add(std::uint32_t i, const Vec3& f, const Vec3& t, bool counted) const {
    bool ok = true;
    const long long q[6] = {fixed::to_fixed(f.x, force_scale, limit, ok),  fixed::to_fixed(f.y, force_scale, limit, ok),
                            fixed::to_fixed(f.z, force_scale, limit, ok),  fixed::to_fixed(t.x, torque_scale, limit, ok),
                            fixed::to_fixed(t.y, torque_scale, limit, ok), fixed::to_fixed(t.z, torque_scale, limit, ok)};
    long long* w = sums + static_cast<std::size_t>(kWords) * i;
    if (!ok) {
      fixed::atomic_add(w + 7, 1);
      return;
    }
    for (std::uint32_t c = 0; c < 6; ++c) fixed::atomic_add(w + c, q[c]);
    if (counted) fixed::atomic_add(w + 6, 1);
  }
  /// A pair's force on its lower-id sphere i (fl) and the torques on i (ti) and j (tj): the force
  /// is rounded once and added to i and, negated (exactly), to j; the pair is counted by i.
  BIODEM_HD void add_pair(std::uint32_t i, std::uint32_t j, const Vec3& fl, const Vec3& ti, const Vec3& tj) const {
    bool ok = true;
    const long long f[3] = {fixed::to_fixed(fl.x, force_scale, limit, ok), fixed::to_fixed(fl.y, force_scale, limit, ok),
                            fixed::to_fixed(fl.z, force_scale, limit, ok)};
    const long long a[3] = {fixed::to_fixed(ti.x, torque_scale, limit, ok), fixed::to_fixed(ti.y, torque_scale, limit, ok),
                            fixed::to_fixed(ti.z, torque_scale, limit, ok)};
    const long long b[3] = {fixed::to_fixed(tj.x, torque_scale, limit, ok), fixed::to_fixed(tj.y, torque_scale, limit, ok),
                            fixed::to_fixed(tj.z, torque_scale, limit, ok)};
    long long* wi = sums + static_cast<std::size_t>(kWords) * i;
    long long* wj = sums + static_cast<std::size_t>(kWords) * j;
    if (!ok) {
      fixed::atomic_add(wi + 7, 1);
      fixed::atomic_add(wj + 7, 1);
      return;
    }
    for (std::uint32_t c = 0; c < 3; ++c) {
      fixed::atomic_add(wi + c, f[c]);
      fixed::atomic_add(wj + c, -f[c]);
      fixed::atomic_add(wi + 3 + c, a[c]);
      fixed::atomic_add(wj + 3 + c, b[c]);
    }
    fixed::atomic_add(wi + 6, 1);
  }
  /// Sphere i's sums as loaded (load), zeroed for the next step (clear), as doubles (convert:
  /// not-a-number when a contribution was refused); take does the three.
  struct Raw {
    long long q[8];
  };
  BIODEM_HD Raw load(std::uint32_t i) const {
    Raw r;
    const long long* w = sums + static_cast<std::size_t>(kWords) * i;
    for (std::uint32_t c = 0; c < kWords; ++c) r.q[c] = w[c];
    return r;
  }
  BIODEM_HD void clear(std::uint32_t i) const {
    long long* w = sums + static_cast<std::size_t>(kWords) * i;
    for (std::uint32_t c = 0; c < kWords; ++c) w[c] = 0;
  }
  BIODEM_HD void convert(const Raw& r, Vec3& f, Vec3& t, std::uint32_t& contacts) const {
    f = Vec3{fixed::from_fixed(r.q[0], force_quantum), fixed::from_fixed(r.q[1], force_quantum),
             fixed::from_fixed(r.q[2], force_quantum)};
    t = Vec3{fixed::from_fixed(r.q[3], torque_quantum), fixed::from_fixed(r.q[4], torque_quantum),
             fixed::from_fixed(r.q[5], torque_quantum)};
    contacts = static_cast<std::uint32_t>(r.q[6]);
    if (r.q[7] != 0) {
      const double nan = std::numeric_limits<double>::quiet_NaN();
      f = Vec3{nan, nan, nan};
      t = f;
    }
  }
  BIODEM_HD void take(std::uint32_t i, Vec3& f, Vec3& t, std::uint32_t& contacts) const {
    const Raw r = load(i);
    clear(i);
    convert(r, f, t, contacts);
  }
};

/// The sums of a walk by one thread in the order-free family: each contact's force and torque
/// rounded to the grid (as FixedSumArrays::add_pair and add round them: the force on the pair's
/// lower-id sphere once, negated for the other side, each side's torque) and added as integers,
/// converted at the end as FixedSumArrays::convert does. Integer sums in any order are the same,
/// so the walk's sums are the bits of PairEntriesFixed's atomic additions, except where a
/// contribution is refused: add_pair flags both spheres when any of the pair's nine values is
/// out of range, the walk each sphere for its own six (the run stops either way, at the next
/// list check, but the first non-finite sphere it names may differ).
struct FixedWalkSums {
  FixedSumArrays fx;  // (its grid; its sums are not touched)
  long long q[8] = {};
  BIODEM_HD explicit FixedWalkSums(const FixedSumArrays& grid) : fx(grid) {}
  BIODEM_HD void add(const RowContact& r) {
    if (r.kind == 0) return;
    bool ok = true;
    const long long f[3] = {fixed::to_fixed(r.force.x, fx.force_scale, fx.limit, ok),
                            fixed::to_fixed(r.force.y, fx.force_scale, fx.limit, ok),
                            fixed::to_fixed(r.force.z, fx.force_scale, fx.limit, ok)};
    const long long t[3] = {fixed::to_fixed(r.torque.x, fx.torque_scale, fx.limit, ok),
                            fixed::to_fixed(r.torque.y, fx.torque_scale, fx.limit, ok),
                            fixed::to_fixed(r.torque.z, fx.torque_scale, fx.limit, ok)};
    if (!ok) {
      q[7] += 1;
      return;
    }
    const bool negate = r.kind == 2;  // the pair's higher-id side: the lower side's force, negated
    for (std::uint32_t c = 0; c < 3; ++c) {
      q[c] += negate ? -f[c] : f[c];
      q[3 + c] += t[c];
    }
    if (r.kind != 2) q[6] += 1;
  }
  BIODEM_HD void finish(Vec3& f, Vec3& t, std::uint32_t& count) const {
    FixedSumArrays::Raw raw;
    for (std::uint32_t c = 0; c < FixedSumArrays::kWords; ++c) raw.q[c] = q[c];
    fx.convert(raw, f, t, count);
  }
};

/// The row walk by one thread per sphere (Forces' walk, heads loaded one entry ahead) in the
/// order-free family: the sphere's contacts added as fixed-point integers (FixedWalkSums), so
/// its force, torque and contact count are those that PairEntriesFixed and the body kernel's
/// take give, bit for bit (each pair still evaluated in both rows, with the same arithmetic).
/// Then the ordered family's body kernels (ReduceKick, ReduceKickDrift) run on them.
template <bool Cohesion, bool Rolling>
struct ForcesFixed : Forces<Cohesion, Rolling> {
  FixedSumArrays fx;
  /// On CUDA shared by the row lanes (walk_row_lanes_fixed: the lanes' integer sums added once,
  /// at the end); one thread here.
  static constexpr bool kFixedSums = true;
  BIODEM_HD FixedWalkSums walk_sums() const { return FixedWalkSums(fx); }
  BIODEM_HD void operator()(std::uint32_t a) const {
    Forces<Cohesion, Rolling>::walk_prefetched(*this, a, FixedWalkSums(fx));
  }
};
static_assert(WalksFixedSums<ForcesFixed<true, true>>::value && !WalksFixedSums<Forces<true, true>>::value,
              "the order-free family's row walk adds the lanes' integer sums once");

/// PairEntries of the order-free family: one thread per row entry and wall slot, each pair
/// evaluated once by its lower-id side's entry (pair_entry, the same contact arithmetic), each
/// wall contact by its slot; their forces and torques added to both spheres' fixed-point sums
/// (FixedSumArrays::add_pair, add) instead of written to the entry buffers, so no per-sphere
/// pass over the rows follows. Touching flags and history as PairEntries.
template <bool Cohesion, bool Rolling>
struct PairEntriesFixed : ContactArgs {
  FixedSumArrays fx;
  BIODEM_HD void operator()(std::uint32_t t) const {
    if (halted(halt)) return;
    pair_pass(
        t,
        [this](std::uint32_t k, std::uint32_t a, std::uint32_t sid_a, std::uint32_t b) {
          const std::uint32_t m = rows.mirror[k];
          Vec3 fl, ta, tb;
          bool a_low = true;
          bool touching;
          if (b != kUnlisted) {
            touching = pair_entry_from<Cohesion, Rolling, true>(EntryHead{b, 0u, rows.touching[k] != 0}, a, sid_a, k,
                                                                 fl, ta, a_low, &tb);
          } else {
            const EntryHead e = entry_head(k);
            b = e.b;
            touching = pair_entry_from<Cohesion, Rolling>(e, a, sid_a, k, fl, ta, a_low, &tb);
          }
          rows.touching[m] = touching ? 1 : 0;
          if (touching) fx.add_pair(a, b, fl, ta, tb);
        },
        [this](std::uint32_t a, std::uint32_t w, bool listed) {
          Vec3 fw, tw;
          if (listed ? wall_entry<Cohesion, Rolling, true>(a, w, fw, tw) : wall_entry<Cohesion, Rolling>(a, w, fw, tw))
            fx.add(a, fw, tw, true);
        });
  }
};

/// The order-free family's per-sphere step outside the fused units: sphere i's sums taken from
/// the fixed-point sums into its force, torque and contact count (then ReduceKick).
struct TakeFixedSums {
  FixedSumArrays fx;
  SphereArrays s;
  Halt halt;
  BIODEM_HD void operator()(std::uint32_t i) const {
    if (halted(halt)) return;
    Vec3 f, t;
    std::uint32_t count = 0;
    fx.take(i, f, t, count);
    s.force[i] = f;
    s.torque[i] = t;
    s.contacts[i] = count;
  }
};

/// ReduceKickDrift of the order-free family: body k's spheres' sums taken from the fixed-point
/// sums (stored as their force, torque and contact count), summed into the body's force and
/// torque with body_sums' operations in template order, then the rest of ReduceKickDrift.
struct ReduceKickDriftFixed {
  ReduceKickDrift rkd;
  FixedSumArrays fx;
  /// Every body is one sphere, body k's sphere being sphere k (as SumEntriesKickDrift; the
  /// engine sets it only then): the sphere's sums and centre are loaded with the body's state, in
  /// one round, instead of after the body's first sphere is known. The same operations.
  bool single_spheres = false;
  /// Sphere i's sums r (loaded) taken: zeroed, stored as its force, torque and contact count, and
  /// added to the body's force f and torque t (body_sums' operations), p its centre.
  BIODEM_HD void add_sphere(std::uint32_t i, const FixedSumArrays::Raw& r, const Vec3& p, const BodyState& st, Vec3& f,
                            Vec3& t) const {
    Vec3 fs, ts;
    std::uint32_t count = 0;
    fx.clear(i);
    fx.convert(r, fs, ts, count);
    rkd.s.force[i] = fs;
    rkd.s.torque[i] = ts;
    rkd.s.contacts[i] = count;
    f += fs;
    t += ts + cross(p - st.x, fs);
  }
  BIODEM_HD void operator()(std::uint32_t k) const {
    if (halted(rkd.halt)) return;
    if (single_spheres) {
      const FixedSumArrays::Raw r = fx.load(k);
      const Vec3 p = rkd.s.position[k];
      const BodyState st = load_body(rkd.b, k);
      Vec3 f = st.m * rkd.gravity, t{};
      add_sphere(k, r, p, st, f, t);
      rkd.finish(k, st, f, t);
      return;
    }
    const BodyState st = load_body(rkd.b, k);
    Vec3 f = st.m * rkd.gravity, t{};
    // Two spheres at a time: every load of a chunk (sums, centres) before its first store, so
    // that a GPU thread waits for memory once per chunk, not once per sphere (a load cannot
    // move above a store it might alias). (Four spilled 152 bytes at 128 registers, sm_90.)
    constexpr std::uint32_t kChunk = 2;
    for (std::uint32_t c0 = 0; c0 < st.ns; c0 += kChunk) {
      FixedSumArrays::Raw r[kChunk];
      Vec3 p[kChunk];
      for (std::uint32_t c = 0; c < kChunk; ++c)
        if (c0 + c < st.ns) {
          r[c] = fx.load(st.s0 + c0 + c);
          p[c] = rkd.s.position[st.s0 + c0 + c];
        }
      for (std::uint32_t c = 0; c < kChunk && c0 + c < st.ns; ++c) add_sphere(st.s0 + c0 + c, r[c], p[c], st, f, t);
    }
    rkd.finish(k, st, f, t);
  }
};

/// Kinetic energy of body k (translation + rotation in the principal frame), as the CPU engine.
struct BodyKineticEnergy {
  BodyArrays b;
  BIODEM_HD double operator()(std::uint32_t k) const {
    const Vec3 wb = rotate_inverse(b.orientation[k], b.omega[k]);
    const Vec3 in = b.inertia[k];
    return 0.5 * b.mass[k] * norm2(b.velocity[k]) + 0.5 * (in.x * wb.x * wb.x + in.y * wb.y * wb.y + in.z * wb.z * wb.z);
  }
};

/// m v^2 / 2 of body k (the settle criterion on translational energy).
struct BodyTranslationalKineticEnergy {
  BodyArrays b;
  BIODEM_HD double operator()(std::uint32_t k) const { return 0.5 * b.mass[k] * norm2(b.velocity[k]); }
};

/// The settle criterion's state on the device (DeviceEngine::begin_settle): the phase step k,
/// the consecutive steps below the threshold, and whether the criterion is met (then `settled`
/// is the halt flag of the step kernels).
struct SettleState {
  std::uint64_t k = 0, below = 0;
  std::uint32_t settled = 0;
};

/// After each step of a criterion phase, one thread: the run driver's rule (SPEC 5) on the
/// kinetic energy that the preceding reduction left in *ke, with the same arithmetic as the
/// host (mean = total / bodies).
struct SettleUpdate {
  SettleState* st;
  const double* ke;
  double bodies;
  double threshold;
  std::uint64_t min_steps, hold_steps;
  Halt halt{};  // (the list guard's: a step it stopped is not counted)
  BIODEM_HD void operator()(std::uint32_t) const {
    if (st->settled || halted(halt)) return;
    const double mean = bodies > 0.0 ? *ke / bodies : 0.0;
    st->k += 1;
    st->below = mean < threshold ? st->below + 1 : 0;
    st->settled = st->k >= min_steps && st->below >= hold_steps ? 1u : 0u;
  }
};

/// A sum of f(0) + f(1) + ... + f(n - 1) in index order, into device memory, by one thread:
/// the order of Thrust's sequential reduction (what the host-threads engine's reductions run),
/// so the emulated criterion sees the same bits as the host-side reduction did.
template <class F>
struct SequentialSum {
  F f;
  std::uint32_t n;
  double* out;
  Halt halt;
  BIODEM_HD void operator()(std::uint32_t) const {
    if (halted(halt)) return;
    double r = 0.0;
    for (std::uint32_t i = 0; i < n; ++i) r = r + f(i);
    *out = r;
  }
};

}  // namespace biodem::gpu::BIODEM_GPU_NS
