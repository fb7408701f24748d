#include "shapes/clump_template.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/error.hpp"
#include "core/sym_eigen.hpp"
#include "shapes/mass_properties.hpp"

namespace biodem::shapes {

double ClumpTemplate::equivalent_diameter_m() const { return std::cbrt(6.0 * volume_m3 / std::numbers::pi); }

NeedleGeometry needle_geometry(double d, double a50, double c) {
  // SPEC 3: n_spb = round((1/a50 - c) / (1 - c)); l = n_spb (d - lambda) + lambda, lambda = c d;
  // V = n pi (d/2)^3 [4/3 - (n-1)/(12 n) (6 - 2c)(4 c^2)]; d_eq = (6 V / pi)^(1/3).
  NeedleGeometry g;
  g.sphere_diameter_m = d;
  g.n_spheres = std::max(1, static_cast<int>(std::lround((1.0 / a50 - c) / (1.0 - c))));
  const double n = g.n_spheres;
  g.length_m = n * (d - c * d) + c * d;
  g.volume_m3 = n * std::numbers::pi * std::pow(d / 2.0, 3) *
                (4.0 / 3.0 - (n - 1.0) / (12.0 * n) * (6.0 - 2.0 * c) * (4.0 * c * c));
  g.equivalent_diameter_m = std::cbrt(6.0 * g.volume_m3 / std::numbers::pi);
  return g;
}

ClumpTemplate make_template(const config::Shape& shape, double s) {
  std::vector<Vec3> centers;
  std::vector<double> radii;
  switch (shape.kind) {
    case config::ShapeKind::Sphere:
      centers.push_back({});
      radii.push_back(0.5 * shape.diameter_m * s);
      break;
    case config::ShapeKind::Needle: {
      const NeedleGeometry g = needle_geometry(shape.d50_m * s, shape.aspect_ratio, shape.overlap_factor);
      const double spacing = g.sphere_diameter_m * (1.0 - shape.overlap_factor);
      for (int i = 0; i < g.n_spheres; ++i) {
        centers.push_back({(i - 0.5 * (g.n_spheres - 1)) * spacing, 0.0, 0.0});
        radii.push_back(0.5 * g.sphere_diameter_m);
      }
      break;
    }
    case config::ShapeKind::Clump:
      if (shape.spheres.empty()) throw Error("shape '" + shape.name + "': a clump needs at least one sphere");
      for (const auto& sp : shape.spheres) {
        centers.push_back(Vec3{sp.center_m[0], sp.center_m[1], sp.center_m[2]} * s);
        radii.push_back(sp.radius_m * s);
      }
      break;
  }

  ClumpTemplate t;
  t.name = shape.name;
  const MassProperties mp = union_of_spheres(centers, radii);
  t.volume_m3 = mp.volume_m3;
  const Vec3 com = centers.size() == 1 ? centers[0] : mp.centroid_m();
  SymEigen eig;
  if (centers.size() == 1) {
    const double i = 0.4 * mp.volume_m3 * radii[0] * radii[0];  // exact sphere
    eig.values = {i, i, i};
    eig.vectors = Mat3::identity();
  } else {
    eig = sym_eigen(mp.inertia_about_centroid_m5());
  }
  t.principal_inertia_per_density_m5 = eig.values;
  // Columns of eig.vectors are the principal axes expressed in the given frame: that matrix
  // maps principal-frame coordinates to given-frame coordinates.
  t.principal_frame = from_matrix(eig.vectors);
  t.min_radius_m = *std::min_element(radii.begin(), radii.end());
  t.max_radius_m = *std::max_element(radii.begin(), radii.end());
  for (std::size_t i = 0; i < centers.size(); ++i) {
    const Vec3 off = transpose(eig.vectors) * (centers[i] - com);
    t.offsets_m.push_back(off);
    t.radii_m.push_back(radii[i]);
    t.bounding_radius_m = std::max(t.bounding_radius_m, norm(off) + radii[i]);
  }
  return t;
}

}  // namespace biodem::shapes
