#include "scenario/drum.hpp"

namespace biodem::scenario {

void add_drum(sim::Simulation& sim, const DrumGeometry& d) {
  sim::WallSpec mantle;
  mantle.geometry.kind = walls::Kind::Cylinder;
  mantle.geometry.point_m = {0, 0, 0};
  mantle.geometry.normal = {0, 0, 1};
  mantle.geometry.radius_m = d.radius_m();
  mantle.material = d.mantle_material;
  mantle.drum_wall = true;
  mantle.drum_sign = 1.0;
  sim.add_wall(mantle);
  if (!d.periodic_axis) {
    sim::WallSpec front;  // z = 0, normal +z
    front.geometry.kind = walls::Kind::Disc;
    front.geometry.point_m = {0, 0, 0};
    front.geometry.normal = {0, 0, 1};
    front.geometry.radius_m = d.radius_m();
    front.material = d.endplate_material;
    front.drum_wall = true;
    front.drum_sign = 1.0;
    sim.add_wall(front);
    sim::WallSpec back = front;  // z = W, normal -z: same lab angular velocity -> opposite sign about its normal
    back.geometry.point_m = {0, 0, d.width_m};
    back.geometry.normal = {0, 0, -1};
    back.drum_sign = -1.0;
    sim.add_wall(back);
  } else {
    neighbor::Domain dom;
    dom.periodic = {false, false, true};
    dom.lo_m = {-d.radius_m(), -d.radius_m(), 0.0};
    dom.hi_m = {d.radius_m(), d.radius_m(), d.width_m};
    sim.set_domain(dom);
  }
  sim.set_drum_angular_velocity(d.angular_velocity_rad_s());
}

}  // namespace biodem::scenario
