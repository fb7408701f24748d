// Plain configuration structs: what a case file means, after parsing and validation by
// src/io/case_parser. The engine is built from these and never sees TOML. All quantities SI.
// Indices (material, shape) refer to positions in the CaseConfig vectors.
#pragma once
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace biodem::config {

using Vec3d = std::array<double, 3>;

/// Which engine runs the case: the CPU engine (reference, default), the CUDA GPU engine, or the
/// GPU engine's kernels on CPU threads (for testing the GPU engine without a GPU).
enum class Device { Cpu, Gpu, GpuEmulated };

struct RunConfig {
  Device device = Device::Cpu;
  bool remove_lost_particles = false;   // [run] lost_particles = "remove" (default "stop")
  std::optional<std::array<double, 3>> bounds_min_m, bounds_max_m;  // explicit scenes: where bodies must stay
  double dt_s = 0.0;
  std::uint64_t seed = 1;
  Vec3d gravity_m_s2{0.0, -9.81, 0.0};
  bool allow_large_dt = false;         // dt may exceed 40 % of the Rayleigh time
  bool allow_initial_overlap = false;  // explicit particles may start overlapping
  std::optional<double> skin_m;        // Verlet skin; default: an eighth of the smallest sphere diameter
};

struct Material {
  std::string name;
  std::optional<double> density_kg_m3;  // required for particle materials, unused for walls
  double young_pa = 0.0;
  double poisson = 0.0;
};

/// Contact properties of a pair of materials (SPEC 2.1): symmetric.
struct PairTable {
  std::size_t material_a = 0, material_b = 0;
  double restitution = 0.0;
  double sliding_friction = 0.0;
  double rolling_friction = 0.0;              // EPSD2 coefficient; 0 disables
  double cohesion_energy_density_j_m3 = 0.0;  // SJKR; 0 disables
};

enum class ShapeKind { Sphere, Needle, Clump };

struct ClumpSphere {
  Vec3d center_m{};  // in the clump's own frame (the parser does not recentre)
  double radius_m = 0.0;
};

struct Shape {
  std::string name;
  ShapeKind kind = ShapeKind::Sphere;
  double diameter_m = 0.0;      // sphere
  double d50_m = 0.0;           // needle: sphere diameter (median minimum Feret diameter)
  double aspect_ratio = 1.0;    // needle: a50 = min/max Feret, in (0, 1]
  double overlap_factor = 0.2;  // needle: c in [0, 0.5]
  std::vector<ClumpSphere> spheres;  // clump
};

struct Population {
  std::size_t shape = 0;
  std::size_t material = 0;
  double volume_fraction = 1.0;
};

struct Insertion {
  std::optional<std::uint64_t> count;
  std::optional<double> fill_fraction;      // bed bulk volume / drum volume
  double bulk_solid_fraction = 0.6;         // converts fill_fraction to a count
  double coarse_grain = 1.0;                // multiplies every particle length
  std::uint64_t max_attempts_per_particle = 1000;
  std::optional<double> wave_fall_s;        // time between insertion waves; default: free fall over the drum diameter
  // Region (issue 9): the drum interior (default with [drum]), or a box / finite cylinder of
  // any scene. Pour: waves until all are placed (as in the drum); pack: all in one wave, else an error.
  enum class Region { Drum, Box, Cylinder };
  enum class Mode { Pour, Pack };
  Region region = Region::Drum;
  Mode mode = Mode::Pour;
  Vec3d region_min_m{}, region_max_m{};          // box
  Vec3d region_base_m{}, region_axis{0, 1, 0};   // cylinder: centre of its base circle, unit axis
  double region_radius_m = 0.0, region_height_m = 0.0;
};

enum class AxialBoundary { EndPlates, Periodic };

struct Drum {
  double diameter_m = 0.0;
  double width_m = 0.0;
  double rpm = 0.0;  // positive: counter-clockwise seen from +z (bed rises at +x)
  std::size_t mantle_material = 0;
  std::optional<std::size_t> endplate_material;  // absent when periodic
  AxialBoundary axial_boundary = AxialBoundary::EndPlates;
};

enum class WallKind { Plane, Disc, Cylinder, Rectangle };

struct Wall {
  WallKind kind = WallKind::Plane;
  std::size_t material = 0;
  Vec3d point_m{};        // plane/disc: a point on it (disc: its centre); cylinder: a point on the axis
  Vec3d normal{0, 0, 1};  // plane/disc: unit normal pointing to the particle side; cylinder: axis direction
  double radius_m = 0.0;  // disc and cylinder radius
  // Optional finite extent of a cylinder along its axis, measured from point_m (0 = infinite).
  double length_m = 0.0;
  // Prescribed rotation about the wall's own symmetry axis (through point_m, along normal/axis):
  // the geometry does not move, the surface velocity is omega x r. rad/s, sign: right-hand rule
  // about `normal`.
  double angular_velocity_rad_s = 0.0;
  // Rectangle: a finite thin plate centred on point_m, size_m[0] along the unit in-plane
  // direction u, size_m[1] along normal x u.
  Vec3d u{1, 0, 0};
  std::array<double, 2> size_m{0.0, 0.0};
  // Prescribed translation (any kind): constant velocity from move_start_s to move_end_s.
  Vec3d translation_velocity_m_s{};
  double move_start_s = 0.0, move_end_s = 0.0;
};

/// [[sink]]: bodies whose centre of mass enters the region are removed and counted.
enum class SinkKind { BelowPlane, OutsideBox };
struct Sink {
  SinkKind kind = SinkKind::BelowPlane;
  Vec3d point_m{};         // below_plane
  Vec3d normal{0, 1, 0};   // below_plane: bodies on the -normal side are removed
  Vec3d min_m{}, max_m{};  // outside_box
};

struct Particle {
  std::size_t shape = 0;
  std::size_t material = 0;
  Vec3d position_m{};
  Vec3d velocity_m_s{};
  Vec3d angular_velocity_rad_s{};
  std::array<double, 4> orientation{1, 0, 0, 0};  // w, x, y, z (normalised by the parser)
};

/// Optional periodic box for explicit scenes (and the drum's periodic axis is derived from [drum]).
struct Domain {
  Vec3d min_m{};
  Vec3d max_m{};
  std::array<bool, 3> periodic{false, false, false};
};

enum class PhaseLength { Steps, Duration, Revolutions };

struct Phase {
  std::string name;
  PhaseLength length = PhaseLength::Steps;
  std::uint64_t steps = 0;
  double duration_s = 0.0;
  double revolutions = 0.0;
  bool rotate = false;  // drum walls turn during this phase
  // Settle criterion: the phase ends early once the mean kinetic energy per body has stayed
  // below this value for `settle_hold_s` (after at least min_duration_s).
  std::optional<double> until_mean_kinetic_energy_j;
  std::optional<double> max_duration_s;  // cap for criterion phases
  double min_duration_s = 0.0;
  double settle_hold_s = 0.01;
  // Prescribed wall motion started by this phase (bulk tests): wall `move_wall` translates at
  // move_velocity_m_s for the whole phase.
  std::optional<std::size_t> move_wall;
  Vec3d move_velocity_m_s{};
  // [heap] lift: the wall moves by the height of the settled fill (highest sphere top) plus
  // move_margin_m, at most duration_s x speed (the cylinder's height); measured when the phase
  // starts, and the phase lasts as long as the move.
  bool move_by_fill_height = false;
  double move_margin_m = 0.0;
  // Bulk tests: the criterion uses the translational kinetic energy only (a sphere spinning about
  // the contact normal meets no resistance in this contact model and would never count as at rest).
  bool translational_criterion = false;
};

struct Output {
  double sample_hz = 50.0;
  std::optional<double> snapshot_every_s;    // absent: no snapshots except the final one
  std::optional<double> checkpoint_every_s;  // absent: no periodic checkpoints
  bool trace = false;
  std::optional<double> frame_every_s;       // back-lit cross-section frames
  std::uint32_t frame_size_px = 512;
  // The free-surface profile of each sample (surface_r2, surface_angle_deg): its bin width and
  // the zone along the mantle left out; absent: one pixel column of the frame raster, and 5 %
  // of the drum radius (docs/analysis.md, section 4).
  std::optional<double> surface_bin_m;
  std::optional<double> surface_wall_zone_m;
  // The drum seen from its end coloured by speed at each snapshot (speed_images/): absent, on in
  // drum cases of builds with images; the top of the colour scale, absent: derived
  // (case_file::speed_image_scale_m_s); the side of the drum's square in pixels.
  std::optional<bool> speed_images;
  std::optional<double> speed_image_max_m_s;
  std::uint32_t speed_image_size_px = 512;
  std::optional<double> speed_image_every_s;  // absent: at each snapshot
};

/// Model options of [contact] that apply to every pair.
enum class WallRollingReference { Wall, Lab };
struct ContactOptions {
  // EPSD2 at a wall: "wall" feeds it the particle's angular velocity relative to the (turning)
  // wall (SPEC 2.3, physically right); "lab" the particle's own, as LIGGGHTS 3.8.0 does.
  WallRollingReference wall_rolling_reference = WallRollingReference::Wall;
  // SJKR cohesion inside the Coulomb and EPSD2 limits? false (default): the limits take |Hertz +
  // damping| (SPEC 2.2, LIGGGHTS 3.8.0 `tangential_reduce off`); true: |Hertz + damping - cohesion|.
  bool tangential_reduce = false;
};

/// The bulk tests of SPEC 7 (issue 9): a case block [heap], [bulk_density] or [shear_box] that
/// the parser expands into walls, a sink, the insertion region and the phases; the run driver
/// measures the responses once the scene is at rest and writes responses.csv.
struct BulkTest {
  enum class Kind { Heap, BulkDensity, ShearBox };
  Kind kind = Kind::Heap;
  // [heap]: a hollow cylinder (axis +y) on a base disc, lifted after the fill settles.
  // The lift is the fill height plus lift_margin_m (default: two particle lengths); the surface
  // is fitted in `sectors` half-planes between fit_from and fit_to of the heap height.
  double cylinder_diameter_m = 0.0, cylinder_height_m = 0.0, lift_speed_m_s = 0.0, base_diameter_m = 0.0;
  std::optional<double> lift_margin_m;  // resolved by the parser
  std::size_t cylinder_material = 0, base_material = 0;
  double fit_from_fraction = 0.2, fit_to_fraction = 0.8;
  std::size_t sectors = 8;
  // [bulk_density]: a cylindrical container on its bottom disc, filled until it overflows.
  double container_diameter_m = 0.0, container_height_m = 0.0;
  std::size_t container_material = 0;
  // [shear_box]: a box x in [0, L], y in [0, H], z in [-W/2, W/2]; the gate is the side x = L.
  double length_m = 0.0, width_m = 0.0, height_m = 0.0, gate_lift_speed_m_s = 0.0;
  std::size_t material = 0;
  // Rest criterion (every test): mean kinetic energy per body below rest_fraction x m g d (m,
  // d: mean particle mass and volume-equivalent diameter) for rest_hold_s; caps max_fill_s and
  // max_rest_s.
  double rest_fraction = 1e-4;
  double rest_mean_kinetic_energy_j = 0.0;  // resolved by the parser
  double rest_hold_s = 0.02, max_fill_s = 3.0, max_rest_s = 3.0;
  double pour_height_factor = 1.5;  // bulk density: the pour region is this many container heights tall
};

struct CaseConfig {
  std::string source_path;
  RunConfig run;
  ContactOptions contact;
  std::vector<Material> materials;
  std::vector<PairTable> pairs;
  std::vector<Shape> shapes;
  std::vector<Population> populations;
  std::optional<Insertion> insertion;
  std::optional<Drum> drum;
  std::vector<Wall> walls;
  std::vector<Sink> sinks;
  std::optional<BulkTest> bulk_test;
  std::vector<Particle> particles;
  std::optional<Domain> domain;
  std::vector<Phase> phases;
  Output output;
};

}  // namespace biodem::config
