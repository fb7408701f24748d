#!/usr/bin/env python3
"""Mutants for scripts/mutation_check.sh: small physics errors (a sign, a factor of 2, a wrong
radius or frame) injected one at a time, to show that the test suite fails on each.

Each entry: id -> (what the error is, [(file, exact text, replacement, expected count)]).
The texts are exact: when the code changes and an entry no longer matches, `apply` stops
with a message naming the mutant and the file (update the entry, do not drop it silently).

Usage: mutants.py list                 ids and descriptions
       mutants.py apply ID SRC_ROOT    applies mutant ID in the tree SRC_ROOT, prints file:line
"""
import os
import sys

M = {
 "01": ("Hertz k_n 4/3 -> 2/3", [("src/contact/hertz_normal.hpp", "return 4.0 / 3.0 * y_eff_pa * sqrt(r_eff_m * overlap_m);", "return 2.0 / 3.0 * y_eff_pa * sqrt(r_eff_m * overlap_m);", 1)]),
 "02": ("Hertz exponent: k_n ~ sqrt(R*R) (F ~ delta^1 instead of delta^1.5)", [("src/contact/hertz_normal.hpp", "return 4.0 / 3.0 * y_eff_pa * sqrt(r_eff_m * overlap_m);", "return 4.0 / 3.0 * y_eff_pa * sqrt(r_eff_m * r_eff_m);", 1)]),
 "03a": ("normal damping sign flipped", [("src/contact/contact_model.hpp", "R f_n = hertz_elastic_force(p.y_eff_pa, g.r_eff_m, g.overlap_m) -", "R f_n = hertz_elastic_force(p.y_eff_pa, g.r_eff_m, g.overlap_m) +", 1)]),
 "03b": ("S_n = 2 Y* sqrt(R d) -> Y* sqrt(R d) (gamma_n / sqrt2)", [("src/contact/viscous_damping.hpp", "R(2.0 * y_eff_pa * sqrt(r_eff_m * overlap_m))", "R(1.0 * y_eff_pa * sqrt(r_eff_m * overlap_m))", 1)]),
 "04": ("beta: ln e -> ln(e)/2", [("src/contact/viscous_damping.hpp", "const double l = std::log(restitution);", "const double l = 0.5 * std::log(restitution);", 1)]),
 "05a": ("Y*: drop (1 - nu^2)", [("src/contact/time_step.hpp", "return (1.0 - poisson * poisson) / young_pa;", "return 1.0 / young_pa;", 1)]),
 "05b": ("G*: 2(2-nu)(1+nu) -> (2-nu)(1+nu)", [("src/contact/time_step.hpp", "return 2.0 * (2.0 - poisson) * (1.0 + poisson) / young_pa;", "return (2.0 - poisson) * (1.0 + poisson) / young_pa;", 1)]),
 "06a": ("R* = r_i r_j/(r_i+r_j) -> (r_i+r_j)/4 (same for equal radii)", [("src/contact/contact_geometry.hpp", "g.r_eff_m = r_i * r_j / (r_i + r_j);", "g.r_eff_m = 0.25 * (r_i + r_j);", 1)]),
 "06b": ("m* -> m_i (pair)", [("src/contact/contact_geometry.hpp", "g.m_eff_kg = m_i * m_j / (m_i + m_j);", "g.m_eff_kg = m_i + 0.0 * m_j;", 1)]),
 "07": ("k_t = 8 G* sqrt(R d) -> 4 G* sqrt(R d)", [("src/contact/mindlin_tangential.hpp", "return 8.0 * g_eff_pa * sqrt(r_eff_m * overlap_m);", "return 4.0 * g_eff_pa * sqrt(r_eff_m * overlap_m);", 1)]),
 "08a": ("Coulomb limit mu F_n -> 2 mu F_n", [("src/contact/mindlin_tangential.hpp", "const R limit = friction * normal_force_abs;", "const R limit = 2.0 * friction * normal_force_abs;", 1)]),
 "08b": ("cohesion always in friction+rolling limits (tangential_reduce ignored)", [("src/contact/contact_model.hpp", "if (p.tangential_reduce) f_limit = f_n;", "f_limit = f_n;", 1)]),
 "09a": ("tangential damping sign flipped (scalar and lane branches)", [("src/contact/mindlin_tangential.hpp", "spring - gamma_t * v_t", "spring + gamma_t * v_t", 2)]),
 "09b": ("S_t = 8 G* sqrt(R d) -> 4 G* (gamma_t / sqrt2)", [("src/contact/viscous_damping.hpp", "R(8.0 * g_eff_pa * sqrt(r_eff_m * overlap_m))", "R(4.0 * g_eff_pa * sqrt(r_eff_m * overlap_m))", 1)]),
 "10a": ("no projection of xi onto the tangent plane", [("src/contact/mindlin_tangential.hpp", "  xi -= dot(xi, n) * n;", "  // xi -= dot(xi, n) * n;", 1)]),
 "10b": ("no rescaling of xi when sliding (scalar and lanes)", [("src/contact/mindlin_tangential.hpp", "      xi = r.force * (-1.0 / k_t);", "      // xi = r.force * (-1.0 / k_t);", 1), ("src/contact/mindlin_tangential.hpp", "    xi = lane_select(r.sliding, slide * (-1.0 / k_t), xi);", "    // xi = lane_select(r.sliding, slide * (-1.0 / k_t), xi);", 1)]),
 "11a": ("EPSD2 k_r = k_t R*^2 -> 0.5 k_t R*^2", [("src/contact/epsd2_rolling.hpp", "m_r += (k_t * r_eff_m * r_eff_m * dt) * w_t;", "m_r += (0.5 * k_t * r_eff_m * r_eff_m * dt) * w_t;", 1)]),
 "11b": ("EPSD2 torque sign (+M_r on i)", [("src/contact/epsd2_rolling.hpp", "  return -m_r;", "  return m_r;", 1)]),
 "12a": ("EPSD2 limit mu_r R* F_n -> 2x", [("src/contact/epsd2_rolling.hpp", "const R limit = rolling_friction * r_eff_m * normal_force_abs;", "const R limit = 2.0 * rolling_friction * r_eff_m * normal_force_abs;", 1)]),
 "12b": ("EPSD2 limit uses cohesion-reduced F_n (rolling only)", [("src/contact/contact_model.hpp", "epsd2_rolling_torque(h.m_r, g.w_rel, n, k_t, g.r_eff_m, p.rolling_friction, abs_f_n, dt)", "epsd2_rolling_torque(h.m_r, g.w_rel, n, k_t, g.r_eff_m, p.rolling_friction, lane_abs(f_n), dt)", 1)]),
 "13a": ("SJKR force CED*A -> 2 CED*A", [("src/contact/sjkr_cohesion.hpp", "return cohesion_energy_density_j_m3 * area_m2;", "return 2.0 * cohesion_energy_density_j_m3 * area_m2;", 1)]),
 "13b": ("SJKR sign (repulsive)", [("src/contact/contact_model.hpp", "f_n -= sjkr_force(", "f_n += sjkr_force(", 1)]),
 "14a": ("SJKR pair area -> pi R* delta (about half the lens area)", [("src/contact/sjkr_cohesion.hpp", "return std::numbers::pi * (r_i + r_j - d) * (d + r_i - r_j) * (d - r_i + r_j) * (d + r_i + r_j) / (4.0 * d * d);", "return std::numbers::pi * r_i * r_j / (r_i + r_j) * (r_i + r_j - d);", 1)]),
 "14b": ("SJKR wall area pi (R^2 - d^2) -> pi R (R - d)", [("src/contact/sjkr_cohesion.hpp", "return std::numbers::pi * (r_i * r_i - d * d);", "return std::numbers::pi * r_i * (r_i - d);", 1)]),
 "15": ("Rayleigh time sqrt(rho/G) -> sqrt(rho/Y)", [("src/contact/time_step.hpp", "std::sqrt(density_kg_m3 / shear_modulus_pa(young_pa, poisson))", "std::sqrt(density_kg_m3 / young_pa)", 1)]),
 "16a": ("Verlet half step h = dt/2 -> dt (advance_bodies)", [("src/sim/simulation_step.cpp", "const double h = 0.5 * dt_s_, dt = dt_s_;", "const double h = dt_s_, dt = dt_s_;", 1)]),
 "16b": ("gravity sign", [("src/sim/simulation.cpp", "gravity_(gravity_m_s2) {", "gravity_(-1.0 * gravity_m_s2) {", 1)]),
 "17a": ("free-rotor sub-step quaternion half angle 0.5 -> 1.0", [("src/integrate/rigid_rotation.hpp", "const double half = 0.5 * hk * pi[n][k] * inv_i[n][k];", "const double half = 1.0 * hk * pi[n][k] * inv_i[n][k];", 1)]),
 "17b": ("omega from body frame with the inverse rotation (wrong frame)", [("src/integrate/rigid_rotation.hpp", "omega[n] = rotate(q[n], Vec3{pi[n].x * inv_i[n].x", "omega[n] = rotate_inverse(q[n], Vec3{pi[n].x * inv_i[n].x", 1)]),
 "18a": ("clump inertia: parallel-axis sign", [("src/shapes/mass_properties.cpp", "second_moment_m5 + (-volume_m3) * outer(g, g);", "second_moment_m5 + volume_m3 * outer(g, g);", 1)]),
 "18b": ("clump volume: lens overlap not removed", [("src/shapes/mass_properties.cpp", "add_cap(mp, c[i], r[i], u, a_i, -1.0);", "add_cap(mp, c[i], r[i], u, a_i, 0.0);", 1), ("src/shapes/mass_properties.cpp", "add_cap(mp, c[j], r[j], -u, d - a_i, -1.0);", "add_cap(mp, c[j], r[j], -u, d - a_i, 0.0);", 1)]),
 "19a": ("sphere-wall R* = R -> R/2", [("src/contact/contact_geometry.hpp", "  g.r_eff_m = r_i;", "  g.r_eff_m = 0.5 * r_i;", 1)]),
 "19b": ("wall surface velocity omega x r -> r x omega", [("src/walls/wall_geometry.hpp", "cross(w.angular_velocity_rad_s * w.normal, p - w.point_m)", "cross(p - w.point_m, w.angular_velocity_rad_s * w.normal)", 1)]),
 "20": ("drum angular velocity sign (rpm -> -rpm)", [("src/scenario/drum.hpp", "return rpm * 2.0 * std::numbers::pi / 60.0;", "return -rpm * 2.0 * std::numbers::pi / 60.0;", 1)]),
 "21": ("sphere-sphere contact normal sign", [("src/contact/contact_geometry.hpp", "g.normal = d_ij / dist;", "g.normal = -d_ij / dist;", 1)]),
 "22a": ("contact torque r x F -> F x r (i and j)", [("src/contact/contact_model.hpp", "out.torque_i = cross(g.lever_i, t_force);", "out.torque_i = cross(t_force, g.lever_i);", 1), ("src/contact/contact_model.hpp", "out.torque_j = cross(g.lever_j, -t_force);", "out.torque_j = cross(-t_force, g.lever_j);", 1)]),
 "22b": ("wall contact lever arm r - delta/2 -> r/2", [("src/contact/contact_geometry.hpp", "g.lever_i = -(r_i - 0.5 * g.overlap_m) * normal;", "g.lever_i = -(0.5 * r_i) * normal;", 1)]),
 "23": ("clump sphere uses mass/n_spheres instead of clump mass in m*", [("src/sim/simulation.cpp", "spheres_.body_mass_kg.push_back(mass);", "spheres_.body_mass_kg.push_back(mass / static_cast<double>(t.sphere_count()));", 1)]),
 "24a": ("centroid angle sign (ccw branch)", [("src/analysis/centroid_angle.hpp", "return clockwise ? 90.0 - a : 90.0 + a;", "return clockwise ? 90.0 - a : 90.0 - a;", 1)]),
 "24b": ("centroid angle in radians+90", [("src/analysis/centroid_angle.hpp", "const double a = std::atan2(x_c, -y_c) * 180.0 / std::numbers::pi;", "const double a = std::atan2(x_c, -y_c);", 1)]),
 "24c": ("event drop threshold v <= max - h -> v < max - h (rising state)", [("src/analysis/events.cpp", "        } else if (v <= a[imax] - h) {\n          open_event = true;", "        } else if (v < a[imax] - h) {\n          open_event = true;", 1)]),
 "25": ("damping gamma: drop sqrt(5/6)", [("src/contact/viscous_damping.hpp", "return -2.0 * std::sqrt(5.0 / 6.0) * beta * sqrt(s_modulus * m_eff_kg);", "return -2.0 * beta * sqrt(s_modulus * m_eff_kg);", 1)]),
 "26": ("wall rolling 'lab' convention ignored (lanes + scalar wall pass)", [("src/sim/simulation_step.cpp", "wall_rolling_lab_ ? Vec3{} : ws.geometry.angular_velocity_rad_s * ws.geometry.normal", "ws.geometry.angular_velocity_rad_s * ws.geometry.normal", 2)]),
 "27": ("clump torque about COM: r x F -> F x r (scalar advance_bodies clump branch)", [("src/sim/simulation_step.cpp", "t += spheres_.torque_n_m[s] + cross(spheres_.position_m[s] - x, spheres_.force_n[s]);", "t += spheres_.torque_n_m[s] + cross(spheres_.force_n[s], spheres_.position_m[s] - x);", 1)]),
 "28": ("dt refusal limit 40 % of T_R -> 80 %", [("src/case_file/cross_checks.cpp", "constexpr double kDtErrorFraction = 0.40;", "constexpr double kDtErrorFraction = 0.80;", 1)]),
 "29": ("Rayleigh check uses the largest sphere radius of a shape instead of the smallest", [("src/case_file/cross_checks.cpp", "contact::rayleigh_time_s(templates_.at(s).min_radius_m,", "contact::rayleigh_time_s(templates_.at(s).max_radius_m,", 1)]),
 "30": ("centroid angle sign (clockwise branch)", [("src/analysis/centroid_angle.hpp", "return clockwise ? 90.0 - a : 90.0 + a;", "return clockwise ? 90.0 + a : 90.0 + a;", 1)]),
 "31": ("drum omega = rpm 2pi/60 -> rpm pi/60", [("src/scenario/drum.hpp", "return rpm * 2.0 * std::numbers::pi / 60.0;", "return rpm * std::numbers::pi / 60.0;", 1)]),
 "32": ("reduce_and_kick (plain step path) h = dt/2 -> dt", [("src/sim/simulation_step.cpp", "  // Body force (with gravity) and torque about the centre of mass, then the second half kick.\n  const double h = 0.5 * dt_s_;", "  // Body force (with gravity) and torque about the centre of mass, then the second half kick.\n  const double h = dt_s_;", 1)]),
 "33": ("make_pair_table: Y* of the pair from material a twice (b ignored)", [("src/driver/build_simulation.cpp", "contact::inverse_effective_young_term(b.young_pa, b.poisson));", "contact::inverse_effective_young_term(a.young_pa, a.poisson));", 1)]),
 "34": ("make_pair_table: beta from sqrt(e) instead of e", [("src/driver/build_simulation.cpp", "q.beta = contact::damping_beta(p.restitution);", "q.beta = contact::damping_beta(std::sqrt(p.restitution));", 1)]),
 "35": ("a run's free surface of a clockwise drum not mirrored (surface angle of the lab)", [("src/analysis/free_surface.cpp", "fp.rotation = params.image.mirror_x ? Rotation::cw : Rotation::ccw;", "fp.rotation = Rotation::ccw;", 1)]),
 "36": ("heap: lifted bodies counted from the heap's top, without the particle size", [("src/scenario/bulk_measures.cpp", "low[b] > out.height_m + o.bin_m", "low[b] > out.height_m", 1)]),
 # 37-39: the GPU engine's translating walls and sinks (gpu tier: MUTATION_TIERS=gpu).
 "37": ("GPU: translating walls not moved on the device", [("src/gpu/engine_impl.hpp", "    if (n_moving_walls_)\n      launch(1, MoveWalls", "    if (false)\n      launch(1, MoveWalls", 1)]),
 "38": ("GPU: a translating wall not every sphere's wall slot", [("src/gpu/kernels.hpp", "wall_touching[slot] != 0 || walls[w].translates != 0 ||", "wall_touching[slot] != 0 ||", 1)]),
 "39": ("GPU: the walls' device clock not kept across a sink's upload", [("src/gpu/engine_impl.hpp", "  if (n_moving_walls_) to_device(wall_clock_, clock);", "  (void)clock;", 1)]),
 "40": ("GPU: a sink's upload writes back a stale settle state (regression tier)", [("src/gpu/engine_impl.hpp", "  if (settle_active_) {\n    poll_settle();", "  if (false) {\n    poll_settle();", 1)]),
 "41": ("GPU: lost bodies not removed in remove mode (regression tier)", [("src/gpu/engine_impl.hpp", "  if (removes_lost()) host_.check_lost_bodies();  // (removes and counts them)", "", 1)]),
 "42": ("GPU without the list guard: a sphere past half the skin never stops the run", [("src/gpu/engine_impl.hpp", "  if (!guard_on_ && moved > half_skin && (lag > 0 || forces_on_list_ > 1))", "  if (!guard_on_ && moved > half_skin && false)", 1)]),
 "43": ("GPU: a removal's upload counted as forces at the new list's positions", [("src/gpu/engine_impl.hpp", "  forces_on_list_ = 0;  // (the host's forces are of the step before", "  // (the host's forces are of the step before", 1)]),
 "44": ("CPU: a body drifted into a sink does not leave the one-region step (regression tier)", [("src/sim/simulation_step.cpp", "        if (k.contains(bodies_.position_m[b])) moved = 1;", "        if (k.contains(bodies_.position_m[b])) moved = 0;", 1)]),
 "45": ("GPU: a removal's upload times the kernel sets again (regression tier)", [("src/gpu/engine_impl.hpp", "  if (timed_choice() && !kept.under_way()) {", "  if (false && !kept.under_way()) {", 1)]),
 "46": ("GPU without the list guard: an upload's new list hides a sphere past half the skin", [("src/gpu/engine_impl.hpp", "  if (ns() && builds_) check_motion(motion_now(), 0);", "  if (false) check_motion(motion_now(), 0);", 1)]),
 "47": ("the GPU engine's check of dropped touching pairs ignores the skin (unit tier)", [("src/neighbor/verlet_list.cpp", "    const double cut = s.radius_m[a] + s.radius_m[b] + L.skin_m();", "    const double cut = s.radius_m[a] + s.radius_m[b];", 1)]),
 "48": ("GPU without the list guard: a checkpoint's or the run end's download hides a sphere past half the skin", [("src/gpu/engine_impl.hpp", "  if (history && !mid_step && n && builds_) check_motion(motion_now(), 0);", "  if (false) check_motion(motion_now(), 0);", 1)]),
 "50": ("GPU: the list guard's test in a drift never raises its flag", [("src/gpu/kernels.hpp", "    if (!(norm2(x - s.built_at[i]) <= s.half_skin2)) flag_raise(&s.guard->over[s.buffer]);", "    if (false) flag_raise(&s.guard->over[s.buffer]);", 1)]),
 "51": ("GPU: the steps launched after a guard's stop are not taken back", [("src/gpu/engine_impl.hpp", "    cur -= back;\n", "    (void)back;\n", 1)]),
 "52": ("GPU: after a guard's stop, a drift into the second motion buffer is not copied back", [("src/gpu/engine_impl.hpp", "      copy = r.two_buffers && j % 2 == 0", "      copy = false && j % 2 == 0", 1)]),
 "53": ("GPU: the end of an advance does not read the list guard", [("src/gpu/engine_impl.hpp", "      if (guard_stopped_now()) {\n        recover();", "      if (false) {\n        recover();", 1)]),
 "54": ("GPU: translating walls move during the steps the list guard stopped", [("src/gpu/kernels.hpp", "  BIODEM_HD void operator()(std::uint32_t) const {\n    if (halted(halt)) return;\n    const double t = *clock + dt;", "  BIODEM_HD void operator()(std::uint32_t) const {\n    if (halt.settled && *halt.settled) return;\n    const double t = *clock + dt;", 1)]),
 "55": ("GPU: the second buffer's copy does not move the list guard's flag to the first", [("src/gpu/kernels.hpp", "    if (i == 0 && halt.guard && flag_load(&halt.guard->over[1])) flag_raise(&halt.guard->over[0]);\n", "", 1)]),
 "49": ("CPU: a sink removes a body whose position is infinite (regression tier)", [("src/sim/simulation_step.cpp", "    check_finite_bodies();  // (before a sink could take", "    // (before a sink could take", 1)]),
}


def apply(mid, root):
    if mid not in M:
        sys.exit(f"mutants.py: no mutant {mid!r} (see: mutants.py list)")
    _, edits = M[mid]
    where = []
    for f, old, new, count in edits:
        path = os.path.join(root, f)
        text = open(path).read()
        found = text.count(old)
        if found != count:
            sys.exit(f"mutants.py: mutant {mid}: {f}: expected the text {count} time(s), found it {found} time(s)")
        where.append(f"{f}:{text[:text.index(old)].count(chr(10)) + 1}")
        open(path, "w").write(text.replace(old, new))
    print(" ".join(where))


if __name__ == "__main__":
    if len(sys.argv) == 2 and sys.argv[1] == "list":
        for k, (d, _) in M.items():
            print(f"{k}\t{d}")
    elif len(sys.argv) == 4 and sys.argv[1] == "apply":
        apply(sys.argv[2], sys.argv[3])
    else:
        sys.exit(__doc__)
