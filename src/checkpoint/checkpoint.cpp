#include "checkpoint/checkpoint.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <type_traits>

#include "core/error.hpp"

namespace biodem::checkpoint {
namespace {

constexpr char kMagic[8] = {'B', 'I', 'O', 'D', 'E', 'M', 'C', 'K'};

class Out {
 public:
  template <class T>
  void pod(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* p = reinterpret_cast<const char*>(&v);
    buf_.insert(buf_.end(), p, p + sizeof(T));
  }
  template <class T>
  void vec(const std::vector<T>& v) {
    pod<std::uint64_t>(v.size());
    if (v.empty()) return;
    const auto* p = reinterpret_cast<const char*>(v.data());
    buf_.insert(buf_.end(), p, p + sizeof(T) * v.size());
  }
  void str(const std::string& s) {
    pod<std::uint64_t>(s.size());
    buf_.insert(buf_.end(), s.begin(), s.end());
  }
  std::vector<char>& bytes() { return buf_; }

 private:
  std::vector<char> buf_;
};

class In {
 public:
  In(const char* p, std::size_t n, std::string name) : p_(p), n_(n), name_(std::move(name)) {}
  template <class T>
  T pod() {
    T v;
    need(sizeof(T));
    std::memcpy(&v, p_ + off_, sizeof(T));
    off_ += sizeof(T);
    return v;
  }
  template <class T>
  void vec(std::vector<T>& v) {
    const auto n = pod<std::uint64_t>();
    if (n > n_) throw Error(name_ + ": corrupt checkpoint (array length)");
    need(n * sizeof(T));
    v.resize(n);
    if (n) std::memcpy(v.data(), p_ + off_, n * sizeof(T));
    off_ += n * sizeof(T);
  }
  std::string str() {
    const auto n = pod<std::uint64_t>();
    need(n);
    std::string s(p_ + off_, n);
    off_ += n;
    return s;
  }
  bool done() const { return off_ == n_; }

 private:
  void need(std::size_t k) const {
    if (k > n_ - off_) throw Error(name_ + ": truncated checkpoint");  // not off_ + k: it can wrap
  }
  const char* p_;
  std::size_t n_, off_ = 0;
  std::string name_;
};

template <class Stream, class Store>
void body_fields(Stream& s, Store& b) {
  s.vec(b.position_m);
  s.vec(b.velocity_m_s);
  s.vec(b.angular_velocity_rad_s);
  s.vec(b.angular_momentum_kg_m2_s);
  s.vec(b.orientation);
  s.vec(b.mass_kg);
  s.vec(b.inertia_kg_m2);
  s.vec(b.shape);
  s.vec(b.id);
  s.vec(b.first_sphere);
  s.vec(b.sphere_count);
  s.vec(b.force_n);
  s.vec(b.torque_n_m);
}
template <class Stream, class Store>
void sphere_fields(Stream& s, Store& p) {
  s.vec(p.position_m);
  s.vec(p.velocity_m_s);
  s.vec(p.angular_velocity_rad_s);
  s.vec(p.radius_m);
  s.vec(p.offset_body_m);
  s.vec(p.body);
  s.vec(p.material);
  s.vec(p.body_mass_kg);
  s.vec(p.force_n);
  s.vec(p.torque_n_m);
}
template <class Stream, class List>
void list_fields(Stream& s, List& l) {
  s.vec(l.row_start);
  s.vec(l.j);
  s.vec(l.image);
  s.vec(l.history);
  s.vec(l.touching);
  s.vec(l.force_i);
  s.vec(l.torque_j);
  s.vec(l.rev_start);
  s.vec(l.rev_entry);
}

/// A checkpoint with a valid checksum may still not fit this case (edited, or written by a
/// different build): check that the arrays fit together before anything indexes with them.
/// Issue 10, item 8 (checkpoint fuzzing); each failure is one line naming the file and the part.
void check_consistency(sim::Simulation& sim, const std::string& path) {
  auto bad = [&](const std::string& what) { throw Error(path + ": corrupt checkpoint (" + what + ")"); };
  const auto& b = sim.bodies();
  const std::size_t nb = b.mass_kg.size();
  for (std::size_t n : {b.position_m.size(), b.velocity_m_s.size(), b.angular_velocity_rad_s.size(),
                        b.angular_momentum_kg_m2_s.size(), b.orientation.size(), b.inertia_kg_m2.size(),
                        b.shape.size(), b.id.size(), b.first_sphere.size(), b.sphere_count.size(), b.force_n.size(),
                        b.torque_n_m.size()})
    if (n != nb) bad("body arrays of different lengths");
  const auto& s = sim.spheres_mut();
  const std::size_t ns = s.radius_m.size();
  for (std::size_t n : {s.position_m.size(), s.velocity_m_s.size(), s.angular_velocity_rad_s.size(),
                        s.offset_body_m.size(), s.body.size(), s.material.size(), s.body_mass_kg.size(),
                        s.force_n.size(), s.torque_n_m.size()})
    if (n != ns) bad("sphere arrays of different lengths");
  std::size_t next = 0;
  for (std::size_t k = 0; k < nb; ++k) {
    if (b.shape[k] >= sim.templates().size()) bad("body shape index");
    if (b.first_sphere[k] != next || b.sphere_count[k] != sim.templates()[b.shape[k]].sphere_count())
      bad("body sphere ranges");
    next += b.sphere_count[k];
    if (!(b.mass_kg[k] > 0.0) || !(b.inertia_kg_m2[k].x > 0.0) || !(b.inertia_kg_m2[k].y > 0.0) ||
        !(b.inertia_kg_m2[k].z > 0.0))
      bad("body mass or inertia");
    const Quat& q = b.orientation[k];
    for (const Vec3& v : {b.position_m[k], b.velocity_m_s[k], b.angular_velocity_rad_s[k], b.angular_momentum_kg_m2_s[k],
                          Vec3{q.w, q.x, q.y}, Vec3{q.z, b.mass_kg[k], 0.0}})
      if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) bad("non-finite body state");
    if (!(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z > 0.5)) bad("body orientation");
  }
  if (next != ns) bad("sphere count");
  for (std::size_t i = 0; i < ns; ++i) {
    if (s.body[i] >= nb || i < b.first_sphere[s.body[i]] || i >= b.first_sphere[s.body[i]] + b.sphere_count[s.body[i]])
      bad("sphere body index");
    if (s.material[i] >= sim.pair_table().materials()) bad("sphere material index");
    if (!(s.radius_m[i] > 0.0) || !(s.body_mass_kg[i] > 0.0)) bad("sphere radius or mass");
  }
  const auto& wc = sim.wall_contacts();
  if (wc.history.size() != wc.wall.size() || wc.touching.size() != wc.wall.size()) bad("wall contact table");
  for (std::size_t i = 0; i < ns; ++i)
    if (wc.start[i] > wc.start[i + 1]) bad("wall contact table");
  for (std::uint32_t w : wc.wall)
    if (w >= sim.walls().size()) bad("wall contact table");
  const auto& l = sim.neighbor_list();
  const std::size_t m = l.j.size();
  if (!l.row_start.empty()) {
    if (l.row_start.size() != ns + 1 || l.row_start[0] != 0 || l.row_start[ns] != m) bad("neighbour list rows");
    for (std::size_t i = 0; i < ns; ++i)  // monotone first: then every row lies within [0, m)
      if (l.row_start[i] > l.row_start[i + 1]) bad("neighbour list rows");
    for (std::size_t i = 0; i < ns; ++i)
      for (std::uint32_t k = l.row_start[i]; k < l.row_start[i + 1]; ++k)
        if (l.j[k] <= i || l.j[k] >= ns) bad("neighbour list entries");
  } else if (m != 0) {
    bad("neighbour list rows");
  }
  if (l.image.size() != m || l.history.size() != m || l.touching.size() != m || l.force_i.size() != m ||
      l.torque_j.size() != m || l.rev_entry.size() != m)
    bad("neighbour list entry arrays");
  if (!l.rev_start.empty() || m != 0) {
    if (l.rev_start.size() != ns + 1 || l.rev_start[0] != 0 || l.rev_start[ns] != m) bad("neighbour list reverse index");
    for (std::size_t i = 0; i < ns; ++i)
      if (l.rev_start[i] > l.rev_start[i + 1]) bad("neighbour list reverse index");
    for (std::uint32_t k : l.rev_entry)
      if (k >= m) bad("neighbour list reverse index");
  }
  if (!l.built_at().empty() && l.built_at().size() != ns) bad("neighbour list positions");
}

}  // namespace

std::uint64_t fnv1a(const void* data, std::size_t n, std::uint64_t h) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < n; ++i) {
    h ^= p[i];
    h *= 1099511628211ull;
  }
  return h;
}

void save_checkpoint(const std::string& path, const sim::Simulation& sim_c, const RunProgress& rp) {
  auto& sim = const_cast<sim::Simulation&>(sim_c);  // the field helpers take non-const stores; nothing is modified
  Out o;
  o.pod(rp.case_hash);
  o.pod(rp.phase_index);
  o.pod(rp.phase_step);
  o.pod(rp.settle_counter);
  o.pod(rp.rotation_time_s);
  o.pod(rp.snapshot_index);
  o.pod(rp.series_bytes);
  o.pod(rp.trace_bytes);
  for (const auto* pvd : {&rp.pvd_spheres, &rp.pvd_bodies}) {
    o.pod<std::uint64_t>(pvd->size());
    for (const auto& [t, f] : *pvd) {
      o.pod(t);
      o.str(f);
    }
  }
  o.pod(sim.time_s());
  o.pod<std::uint64_t>(sim.step_count());
  o.pod<std::uint8_t>(sim.drum_rotating() ? 1 : 0);
  o.pod<std::uint64_t>(sim.walls().size());
  o.pod<std::uint64_t>(sim.templates().size());
  body_fields(o, sim.bodies_mut());
  sphere_fields(o, sim.spheres_mut());
  o.vec(sim.wall_contacts().start);
  o.vec(sim.wall_contacts().wall);
  o.vec(sim.wall_contacts().history);
  o.vec(sim.wall_contacts().touching);
  list_fields(o, sim.neighbor_list_mut());
  o.vec(sim.neighbor_list().built_at());
  o.pod<std::uint64_t>(sim.neighbor_list().builds());
  o.pod<double>(sim.skin_m());
  o.pod<std::uint64_t>(sim.removed_bodies());
  o.pod<double>(sim.removed_mass_kg());
  o.pod<std::uint64_t>(sim.lost_bodies());
  for (std::size_t k = 0; k < sim.walls().size(); ++k) {  // wall motion schedules (started at run time)
    const auto& w = sim.walls()[k];
    o.pod(sim.wall_initial_point_m(k));
    o.pod(w.translation_velocity_m_s);
    o.pod(w.move_start_s);
    o.pod(w.move_end_s);
  }
  // Version 5: the contact count of the last force evaluation (a sample taken right after a
  // resume reports it), where the outputs and the insertion were.
  o.pod<std::uint64_t>(sim.contact_count());
  o.pod(rp.last_sample_step);
  o.pod(rp.last_snapshot_step);
  o.pod<std::uint8_t>(rp.last_settled ? 1 : 0);
  const auto& ins = rp.insertion;
  o.pod<std::uint8_t>(ins.active ? 1 : 0);
  o.pod(ins.placed);
  o.pod(ins.waves);
  o.pod(ins.empty_waves);
  o.pod(ins.fall_step);
  std::string rng_text;
  if (ins.active) {
    std::ostringstream t;
    t << ins.rng;  // the engine's textual state ([rand.req.eng]): restores the same sequence
    rng_text = t.str();
  }
  o.str(rng_text);
  o.str(rp.engine);  // version 6
  o.str(rp.contact_sums);

  const auto& payload = o.bytes();
  const std::uint64_t sum = fnv1a(payload.data(), payload.size());
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f) throw OutputError(path + ": cannot write checkpoint");
    f.write(kMagic, sizeof kMagic);
    const std::uint32_t version = kCheckpointVersion;
    const std::uint64_t size = payload.size();
    f.write(reinterpret_cast<const char*>(&version), sizeof version);
    f.write(reinterpret_cast<const char*>(&size), sizeof size);
    f.write(payload.data(), static_cast<std::streamsize>(payload.size()));
    f.write(reinterpret_cast<const char*>(&sum), sizeof sum);
    f.flush();
    if (!f) throw OutputError(path + ": checkpoint write failed (disk full?)");
  }
  if (int fd = ::open(tmp.c_str(), O_RDONLY); fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) throw OutputError(path + ": cannot rename checkpoint: " + ec.message());
}

namespace {

std::vector<char> read_checkpoint_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec))
    throw Error(path + ": not a regular file, so not a checkpoint");
  std::ifstream f(path, std::ios::binary);
  if (!f) throw Error(path + ": no checkpoint to resume from");
  return std::vector<char>((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

/// The header's checks (magic, version, size, checksum); returns the version.
std::uint32_t checked_version(const std::vector<char>& all, const std::string& path) {
  const std::size_t head = sizeof kMagic + sizeof(std::uint32_t) + sizeof(std::uint64_t);
  if (all.size() < head + sizeof(std::uint64_t) || std::memcmp(all.data(), kMagic, sizeof kMagic) != 0)
    throw Error(path + ": not a biodem checkpoint");
  std::uint32_t version;
  std::uint64_t size, sum;
  std::memcpy(&version, all.data() + sizeof kMagic, sizeof version);
  std::memcpy(&size, all.data() + sizeof kMagic + sizeof version, sizeof size);
  if (version < kOldestReadableCheckpointVersion || version > kCheckpointVersion)
    throw Error(path + ": checkpoint format version " + std::to_string(version) + ", this biodem reads versions " +
                std::to_string(kOldestReadableCheckpointVersion) + " to " + std::to_string(kCheckpointVersion));
  if (all.size() != head + size + sizeof sum) throw Error(path + ": truncated checkpoint");
  std::memcpy(&sum, all.data() + head + size, sizeof sum);
  if (fnv1a(all.data() + head, size) != sum) throw Error(path + ": checkpoint checksum mismatch (corrupt file)");
  return version;
}

}  // namespace

RunProgress load_checkpoint(const std::string& path, sim::Simulation& sim) {
  return load_checkpoint_bytes(read_checkpoint_file(path), path, sim);
}

std::uint64_t checkpoint_case_hash(const std::string& path) {
  const std::vector<char> all = read_checkpoint_file(path);
  (void)checked_version(all, path);
  std::uint64_t hash = 0;  // (the payload's first field)
  std::memcpy(&hash, all.data() + sizeof kMagic + sizeof(std::uint32_t) + sizeof(std::uint64_t), sizeof hash);
  return hash;
}

RunProgress load_checkpoint_bytes(const std::vector<char>& all, const std::string& path, sim::Simulation& sim) {
  const std::uint32_t version = checked_version(all, path);
  const std::size_t head = sizeof kMagic + sizeof(std::uint32_t) + sizeof(std::uint64_t);
  std::uint64_t size;
  std::memcpy(&size, all.data() + sizeof kMagic + sizeof version, sizeof size);
  In in(all.data() + head, size, path);
  RunProgress rp;
  rp.version = version;
  rp.case_hash = in.pod<std::uint64_t>();
  rp.phase_index = in.pod<std::uint64_t>();
  rp.phase_step = in.pod<std::uint64_t>();
  rp.settle_counter = in.pod<std::uint64_t>();
  rp.rotation_time_s = in.pod<double>();
  rp.snapshot_index = in.pod<std::uint64_t>();
  rp.series_bytes = in.pod<std::uint64_t>();
  rp.trace_bytes = in.pod<std::uint64_t>();
  for (auto* pvd : {&rp.pvd_spheres, &rp.pvd_bodies}) {
    const auto n = in.pod<std::uint64_t>();
    for (std::uint64_t k = 0; k < n; ++k) {
      const double t = in.pod<double>();
      pvd->emplace_back(t, in.str());
    }
  }
  const double time = in.pod<double>();
  const auto steps = in.pod<std::uint64_t>();
  const bool rotating = in.pod<std::uint8_t>() != 0;
  if (in.pod<std::uint64_t>() != sim.walls().size() || in.pod<std::uint64_t>() != sim.templates().size())
    throw Error(path + ": checkpoint does not match this case (walls or shapes differ)");
  body_fields(in, sim.bodies_mut());
  sphere_fields(in, sim.spheres_mut());
  in.vec(sim.wall_contacts().start);
  in.vec(sim.wall_contacts().wall);
  in.vec(sim.wall_contacts().history);
  in.vec(sim.wall_contacts().touching);
  if (sim.wall_contacts().start.size() != sim.spheres().size() + 1 ||
      sim.wall_contacts().wall.size() != sim.wall_contacts().start.back())
    throw Error(path + ": corrupt checkpoint (wall contact table)");
  list_fields(in, sim.neighbor_list_mut());
  std::vector<Vec3> built_at;
  in.vec(built_at);
  const auto builds = in.pod<std::uint64_t>();
  const double skin = in.pod<double>();
  const auto removed = in.pod<std::uint64_t>();
  const double removed_mass = in.pod<double>();
  sim.set_removed(removed, removed_mass);
  sim.set_lost_bodies(in.pod<std::uint64_t>());
  struct Schedule {
    Vec3 p, v;
    double t0, t1;
  };
  std::vector<Schedule> schedules;
  for (std::size_t k = 0; k < sim.walls().size(); ++k) {
    Schedule q;
    q.p = in.pod<Vec3>();
    q.v = in.pod<Vec3>();
    q.t0 = in.pod<double>();
    q.t1 = in.pod<double>();
    schedules.push_back(q);
  }
  std::uint64_t contacts = 0;
  if (version >= 5) {
    contacts = in.pod<std::uint64_t>();
    rp.last_sample_step = in.pod<std::uint64_t>();
    rp.last_snapshot_step = in.pod<std::uint64_t>();
    rp.last_settled = in.pod<std::uint8_t>() != 0;
    auto& ins = rp.insertion;
    ins.active = in.pod<std::uint8_t>() != 0;
    ins.placed = in.pod<std::uint64_t>();
    ins.waves = in.pod<std::uint64_t>();
    ins.empty_waves = in.pod<std::uint64_t>();
    ins.fall_step = in.pod<std::uint64_t>();
    const std::string rng_text = in.str();
    if (ins.active) {
      std::istringstream t(rng_text);
      t >> ins.rng;
      if (t.fail()) throw Error(path + ": corrupt checkpoint (insertion random state)");
    }
  }
  if (version >= 6) {
    rp.engine = in.str();
    rp.contact_sums = in.str();
    // "" when written by other code than a run (tools, tests): nothing recorded.
    const bool gpu = rp.engine == "gpu" || rp.engine == "gpu-emulated";
    const bool engine_ok = gpu || rp.engine == "cpu" || rp.engine.empty();
    const bool sums_ok = gpu ? rp.contact_sums == "ordered" || rp.contact_sums == "fixed" : rp.contact_sums.empty();
    if (!engine_ok || !sums_ok) throw Error(path + ": corrupt checkpoint (engine or GPU contact sums)");
  }
  if (!in.done()) throw Error(path + ": corrupt checkpoint (trailing data)");
  if (!std::isfinite(time) || !std::isfinite(rp.rotation_time_s) || !(skin >= 0.0 && skin < 1e300))
    throw Error(path + ": corrupt checkpoint (time or skin)");
  sim.set_time_s(time);
  for (std::size_t k = 0; k < schedules.size(); ++k)
    if (schedules[k].t1 > schedules[k].t0)
      sim.set_wall_translation(k, schedules[k].p, schedules[k].v, schedules[k].t0, schedules[k].t1);
  sim.restore_after_checkpoint(time, steps, rotating, skin, std::move(built_at), builds);
  sim.set_contact_count(static_cast<std::size_t>(contacts));
  check_consistency(sim, path);
  sim.neighbor_list_mut().index_rows();  // derived from the rows, not stored
  return rp;
}

}  // namespace biodem::checkpoint
