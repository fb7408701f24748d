// What a run writes while it runs: a sample (a row of series.csv, the rows of trace.csv), a
// snapshot (VTK files of the spheres and the bodies), a back-lit frame (PNG).
#include "driver/runner.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>
#include <vector>


#include "analysis/centroid_angle.hpp"
#if BIODEM_HAVE_OPENCV
#include "analysis/render_frame.hpp"
#endif
#include "core/error.hpp"
#if BIODEM_HAVE_OPENCV
#include "output/png_mat.hpp"
#include "output/speed_image.hpp"
#endif

namespace biodem::driver {

void Runner::sample() {
  if (last_sample_step_ == sim_.step_count()) return;  // already sampled at this step
  last_sample_step_ = sim_.step_count();
  sync(false);
  // The GPU engine: lost bodies checked at every sample when they stop the run; "remove" is the
  // engine's (every 10th step), which removes them from the device's state too.
  if (dev_ && device_current_ && !sim_.lost_region().remove) sim_.check_lost_bodies();
  const auto& b = sim_.bodies();
  double m = 0.0, xc = 0.0, yc = 0.0;
  for (std::size_t i = 0; i < b.size(); ++i) {
    m += b.mass_kg[i];
    xc += b.mass_kg[i] * b.position_m[i].x;
    yc += b.mass_kg[i] * b.position_m[i].y;
  }
  output::SeriesRow row;
  // The clock and the turn are sums of dt, one step at a time (the engines' own state); the
  // series gives them as whole steps times dt (every time in it is a whole number of steps), so
  // that they read 3.48 rather than the sum's 3.48000000001.
  row.time_s = config::whole_steps_time(sim_.time_s(), sim_.dt_s());
  row.revolution = revolution();
  const bool clockwise = cfg_.drum && cfg_.drum->rpm < 0.0;  // alpha rises with the bed for either direction
  // (a bulk test has no drum and no axis: its alpha would be an angle about the plate's centre,
  // meaningless, so the column is left empty)
  row.alpha_deg = m > 0.0 && !cfg_.bulk_test ? analysis::centroid_angle_deg(xc / m, yc / m, clockwise)
                                             : std::numeric_limits<double>::quiet_NaN();
#if BIODEM_HAVE_OPENCV  // the free surface is measured on the rendered cross-section (none in the lean build)
  if (built_.drum && sim_.spheres().size() > 0) {
    const auto& s = sim_.spheres();
    std::vector<double> x(s.size()), y(s.size());
    for (std::size_t i = 0; i < s.size(); ++i) {
      x[i] = s.position_m[i].x;
      y[i] = s.position_m[i].y;
    }
    const auto fit = analysis::fit_free_surface(x, y, s.radius_m, built_.drum->radius_m(), surface_params_);
    if (fit.valid) {
      row.surface_r2 = fit.r2;
      row.surface_angle_deg = fit.angle_deg;
    }
  }
#endif
  row.kinetic_energy_j = sim_.kinetic_energy_j();
  row.contacts = static_cast<std::int64_t>(sim_.contact_count());
  row.lost_bodies = static_cast<std::int64_t>(sim_.lost_bodies());
  series_->write(row);
  if (trace_) {
    char buf[512];
    const double time = row.time_s;  // (the series' time, whole steps times dt)
    // Rows in id order; ids are stable and have gaps once a sink removed bodies.
    std::vector<std::pair<std::uint32_t, std::uint32_t>> by_id(b.size());
    for (std::size_t i = 0; i < b.size(); ++i) by_id[i] = {b.id[i], static_cast<std::uint32_t>(i)};
    std::sort(by_id.begin(), by_id.end());
    for (const auto& [id32, i32] : by_id) {
      const std::size_t id = id32, i = i32;
      const Vec3 &x = b.position_m[i], &v = b.velocity_m_s[i], &w = b.angular_velocity_rad_s[i];
      std::snprintf(buf, sizeof buf, "%.9g,%zu,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n", time, id, x.x,
                    x.y, x.z, v.x, v.y, v.z, w.x, w.y, w.z);
      *trace_ << buf;
    }
    check_trace();
  }
}

void Runner::check_trace() const {
  if (trace_ && !*trace_)
    throw OutputError(opt_.out_dir + "/trace.csv: write failed (disk full, or a file size limit?)");
}

void Runner::check_log() {
  log_.flush();
  if (!log_) throw OutputError(opt_.out_dir + "/run.log: cannot be written (disk full, or a file size limit?)");
}

void Runner::snapshot() {
  last_snapshot_step_ = sim_.step_count();
  sync(false);
  const auto& s = sim_.spheres();
  const auto& b = sim_.bodies();
  char name[64];
  std::snprintf(name, sizeof name, "spheres_%06zu.vtu", snapshot_index_);
  output::PointCloud c;
  c.points = s.position_m;
  std::vector<double> speed(s.size());
  std::vector<std::int64_t> body(s.size()), material(s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    speed[i] = norm(s.velocity_m_s[i]);
    body[i] = b.id[s.body[i]];
    material[i] = s.material[i];
  }
  c.vectors = {{"velocity", s.velocity_m_s}, {"angular_velocity", s.angular_velocity_rad_s}, {"force", s.force_n}};
  c.scalars = {{"speed", speed}, {"radius", s.radius_m}};
  c.ints = {{"body_id", body}, {"material", material}};
  output::write_vtu(opt_.out_dir + "/snapshots/" + name, c);
  // (the time as the series gives it: whole steps times dt, without the rounding of the summed dt)
  pvd_->add(config::whole_steps_time(sim_.time_s(), sim_.dt_s()), std::string("snapshots/") + name);
  // the drum seen from its end coloured by speed, numbered as the snapshot (unless it has a cadence of its own)
  if (speed_images_ && !speed_image_every_) speed_image(snapshot_index_);

  std::snprintf(name, sizeof name, "bodies_%06zu.vtu", snapshot_index_);
  output::PointCloud cb;
  cb.points = b.position_m;
  std::vector<double> bspeed(b.size());
  std::vector<std::int64_t> id(b.size()), shape(b.size());
  std::vector<std::array<double, 4>> q(b.size());
  for (std::size_t i = 0; i < b.size(); ++i) {
    bspeed[i] = norm(b.velocity_m_s[i]);
    id[i] = b.id[i];
    shape[i] = b.shape[i];
    q[i] = {b.orientation[i].w, b.orientation[i].x, b.orientation[i].y, b.orientation[i].z};
  }
  cb.vectors = {{"velocity", b.velocity_m_s}, {"angular_velocity", b.angular_velocity_rad_s}};
  cb.scalars = {{"speed", bspeed}, {"mass", b.mass_kg}};
  cb.ints = {{"body_id", id}, {"shape", shape}};
  cb.quats = {{"orientation", q}};
  // (in a folder of their own: snapshots/ holds one file per snapshot, one point per sphere)
  output::write_vtu(opt_.out_dir + "/bodies/" + name, cb);
  pvd_bodies_->add(config::whole_steps_time(sim_.time_s(), sim_.dt_s()), std::string("bodies/") + name);
  ++snapshot_index_;
}

void Runner::speed_image(std::size_t index) {
#if BIODEM_HAVE_OPENCV
  sync(false);
  const auto& s = sim_.spheres();
  std::vector<double> x(s.size()), y(s.size()), z(s.size()), speed(s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    x[i] = s.position_m[i].x;
    y[i] = s.position_m[i].y;
    z[i] = s.position_m[i].z;
    speed[i] = norm(s.velocity_m_s[i]);
  }
  output::SpeedImageOptions so;
  so.drum_px = static_cast<int>(cfg_.output.speed_image_size_px);
  so.max_speed_m_s = speed_scale_m_s_;
  if (cfg_.drum->axial_boundary == config::AxialBoundary::Periodic) so.period_z_m = cfg_.drum->width_m;
  char text[128];
  std::snprintf(text, sizeof text, "t = %.4f s, revolution %.4f, %zu spheres",
                config::whole_steps_time(sim_.time_s(), sim_.dt_s()), revolution(), s.size());
  so.title = text;
  std::snprintf(text, sizeof text, "speed_%06zu.png", index);
  output::write_png(opt_.out_dir + "/speed_images/" + text,
                    output::render_speed_image(x, y, z, s.radius_m, speed, built_.drum->radius_m(), so));
#else
  (void)index;
#endif
}

void Runner::frame() {
#if BIODEM_HAVE_OPENCV
  if (!built_.drum || sim_.step_count() < frame_every_) return;
  sync(false);
  const auto& s = sim_.spheres();
  std::vector<double> x(s.size()), y(s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    x[i] = s.position_m[i].x;
    y[i] = s.position_m[i].y;
  }
  const cv::Mat img = analysis::render_backlit_frame(x, y, s.radius_m, built_.drum->radius_m(),
                                                     static_cast<int>(cfg_.output.frame_size_px));
  char name[64];
  // Frame k after step (k + 1) n, from the step: a resumed run, or a frame written after an
  // insertion wave made at its step, numbers it as the uninterrupted run does.
  std::snprintf(name, sizeof name, "%06llu.png",
                static_cast<unsigned long long>(sim_.step_count() / frame_every_ - 1));
  const std::string path = opt_.out_dir + "/frames/" + name;
  output::write_png(path, img);
#endif
}

}  // namespace biodem::driver
