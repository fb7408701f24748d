// A sink (SPEC 10, [[sink]]): a region whose bodies are removed from the run, below a plane or
// outside a box. The test is one host-device function, used by the CPU engine after each drift
// and by the GPU engine at its list checks.
#pragma once
#include "core/hd.hpp"
#include "core/vec3.hpp"

namespace biodem::sim {

/// A region that removes the bodies whose centre of mass enters it (issue 9: particles that
/// fall off a heap's base plate or out of a shear box). Removed bodies are counted with their mass.
struct SinkSpec {
  enum class Kind { BelowPlane, OutsideBox };
  Kind kind = Kind::BelowPlane;
  Vec3 point_m;          // below_plane: a point on the plane
  Vec3 normal{0, 1, 0};  // below_plane: unit normal; bodies on the -normal side are removed
  Vec3 min_m, max_m;     // outside_box: bodies outside [min, max] are removed
  BIODEM_HD bool contains(const Vec3& x) const {
    if (kind == Kind::BelowPlane) return dot(x - point_m, normal) < 0.0;
    return x.x < min_m.x || x.y < min_m.y || x.z < min_m.z || x.x > max_m.x || x.y > max_m.y || x.z > max_m.z;
  }
};

}  // namespace biodem::sim
