// The Verlet list against brute force (SPEC 10; neighbor/verlet_list.hpp): on random
// polydisperse packings with and without periodic axes and with clumps (spheres of one body
// never interact), the set of list entries whose spheres overlap equals the set of overlapping
// pairs found by brute force; the list stays complete while no sphere has moved more than half
// the skin, is complete again after a rebuild, and carries the contact history of pairs that
// stay in contact over a rebuild. Exact comparisons (sets of index pairs): no tolerance.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "core/error.hpp"
#include "neighbor/candidate_scan.hpp"
#include "neighbor/verlet_list.hpp"
#include "state/particle_store.hpp"

using namespace biodem;
using namespace biodem::neighbor;

namespace {

using PairList = std::vector<std::pair<std::uint32_t, std::uint32_t>>;

constexpr double kL = 20e-3;     // box edge
constexpr double kSkin = 0.3e-3;

double uniform(std::mt19937_64& g) { return static_cast<double>(g() >> 11) * 0x1.0p-53; }

/// Random polydisperse packing (radii 0.3-1.0 mm, overlaps allowed: ~200 overlapping pairs)
/// of `n_bodies` bodies of 1-4 spheres each (clump members overlap each other). On periodic
/// axes some spheres are placed one or two box lengths outside [0, L): positions are never
/// wrapped in the engine, so the list must handle them.
state::SphereStore make_packing(std::uint64_t seed, std::size_t n_bodies, const Domain& dom, bool clumps) {
  std::mt19937_64 g(seed);
  state::SphereStore s;
  for (std::uint32_t b = 0; b < n_bodies; ++b) {
    const std::size_t members = clumps ? 1 + g() % 4 : 1;
    Vec3 c{kL * uniform(g), kL * uniform(g), kL * uniform(g)};
    for (int a = 0; a < 3; ++a)
      if (dom.periodic[a] && g() % 5 == 0) c[a] += kL * (static_cast<int>(g() % 5) - 2);
    for (std::size_t k = 0; k < members; ++k) {
      const double r = 0.3e-3 + 0.7e-3 * uniform(g);
      const Vec3 off = k == 0 ? Vec3{} : Vec3{uniform(g) - 0.5, uniform(g) - 0.5, uniform(g) - 0.5} * 1.0e-3;
      s.position_m.push_back(c + off);
      s.velocity_m_s.push_back({});
      s.angular_velocity_rad_s.push_back({});
      s.radius_m.push_back(r);
      s.offset_body_m.push_back(off);
      s.body.push_back(b);
      s.material.push_back(0);
      s.body_mass_kg.push_back(1.0);
      s.force_n.push_back({});
      s.torque_n_m.push_back({});
    }
  }
  return s;
}

/// Independent brute force: smallest separation over all 27 images on periodic axes.
PairList brute_force_within(const state::SphereStore& s, const Domain& dom, double extra) {
  PairList out;
  for (std::uint32_t i = 0; i < s.size(); ++i)
    for (std::uint32_t j = i + 1; j < s.size(); ++j) {
      if (s.body[i] == s.body[j]) continue;
      const Vec3 d0 = s.position_m[i] - s.position_m[j];
      double best = 1e300;
      for (int ix = -1; ix <= 1; ++ix)
        for (int iy = -1; iy <= 1; ++iy)
          for (int iz = -1; iz <= 1; ++iz) {
            const int im[3] = {ix, iy, iz};
            Vec3 d = d0;
            bool ok = true;
            for (int a = 0; a < 3; ++a) {
              if (!dom.periodic[a]) {
                if (im[a] != 0) ok = false;
                continue;
              }
              d[a] -= kL * std::round(d[a] / kL) + im[a] * kL;
            }
            if (ok) best = std::min(best, norm2(d));
          }
      const double c = s.radius_m[i] + s.radius_m[j] + extra;
      if (best < c * c) out.emplace_back(i, j);
    }
  return out;
}

/// Entries of the list whose spheres overlap (with the entry's own image shift).
PairList list_overlaps(const VerletList& L, const state::SphereStore& s) {
  PairList out;
  for (std::uint32_t i = 0; i < s.size(); ++i)
    for (std::uint32_t k = L.row_start[i]; k < L.row_start[i + 1]; ++k) {
      const std::uint32_t j = L.j[k];
      const Vec3 d = s.position_m[i] - s.position_m[j] - L.shift(k);
      const double c = s.radius_m[i] + s.radius_m[j];
      if (norm2(d) < c * c) out.emplace_back(i, j);
    }
  std::sort(out.begin(), out.end());
  return out;
}

PairList list_pairs(const VerletList& L, std::size_t n) {
  PairList out;
  for (std::uint32_t i = 0; i < n; ++i)
    for (std::uint32_t k = L.row_start[i]; k < L.row_start[i + 1]; ++k) out.emplace_back(i, L.j[k]);
  std::sort(out.begin(), out.end());
  return out;
}

Domain make_domain(std::array<bool, 3> periodic) {
  Domain d;
  d.periodic = periodic;
  d.lo_m = {0, 0, 0};
  d.hi_m = {kL, kL, kL};
  return d;
}

/// row_of names each entry's row (the pair pass walks the entries with it).
void check_row_of(const VerletList& L) {
  ASSERT_EQ(L.row_of.size(), L.j.size());
  std::size_t wrong = 0;
  for (std::size_t i = 0; i + 1 < L.row_start.size(); ++i)
    for (std::uint32_t k = L.row_start[i]; k < L.row_start[i + 1]; ++k) wrong += L.row_of[k] != i;
  EXPECT_EQ(wrong, 0u);
}

void check_list(const VerletList& L, const state::SphereStore& s, const Domain& dom) {
  check_row_of(L);
  const PairList brute = brute_force_overlaps(s, dom);
  // The engine's reference agrees with the independent 27-image brute force.
  EXPECT_EQ(brute, brute_force_within(s, dom, 0.0));
  EXPECT_EQ(list_overlaps(L, s), brute);
  // Every pair within r_i + r_j + skin is listed, once, never within one body, j > i.
  const PairList listed = list_pairs(L, s.size());
  EXPECT_TRUE(std::adjacent_find(listed.begin(), listed.end()) == listed.end()) << "duplicate entry";
  for (const auto& p : brute_force_within(s, dom, 0.999 * kSkin))
    EXPECT_TRUE(std::binary_search(listed.begin(), listed.end(), p)) << p.first << "-" << p.second;
  for (const auto& [i, j] : listed) {
    EXPECT_LT(i, j);
    EXPECT_NE(s.body[i], s.body[j]);
  }
  // Reverse index: every entry appears exactly once, under its j.
  std::size_t rev = 0;
  for (std::uint32_t j = 0; j < s.size(); ++j)
    for (std::uint32_t q = L.rev_start[j]; q < L.rev_start[j + 1]; ++q, ++rev) EXPECT_EQ(L.j[L.rev_entry[q]], j);
  EXPECT_EQ(rev, L.entries());
}

struct Variant {
  const char* name;
  std::array<bool, 3> periodic;
  bool clumps;
};

const Variant kVariants[] = {
    {"open, spheres", {false, false, false}, false},
    {"open, clumps", {false, false, false}, true},
    {"periodic x, clumps", {true, false, false}, true},
    {"periodic y z, spheres", {false, true, true}, false},
    {"periodic xyz, spheres", {true, true, true}, false},
    {"periodic xyz, clumps", {true, true, true}, true},
};

}  // namespace

TEST(VerletList, OverlapsEqualBruteForceOnRandomPackings) {
  std::uint64_t seed = 1;
  for (const Variant& v : kVariants) {
    SCOPED_TRACE(v.name);
    const Domain dom = make_domain(v.periodic);
    state::SphereStore s = make_packing(seed++, v.clumps ? 250 : 600, dom, v.clumps);
    ASSERT_GT(s.size(), 500u);
    VerletList L;
    L.configure(dom, kSkin);
    L.build(s);
    const std::size_t n_overlaps = brute_force_overlaps(s, dom).size();
    EXPECT_GT(n_overlaps, 100u);  // the packing must actually contain contacts
    std::printf("[measured] %s: %zu spheres, %zu entries, %zu overlapping pairs\n", v.name, s.size(), L.entries(),
                n_overlaps);
    check_list(L, s, dom);
  }
}

TEST(VerletList, StaysCompleteWithinHalfSkinAndAfterRebuild) {
  std::uint64_t seed = 100;
  for (const Variant& v : kVariants) {
    SCOPED_TRACE(v.name);
    const Domain dom = make_domain(v.periodic);
    state::SphereStore s = make_packing(seed++, v.clumps ? 250 : 600, dom, v.clumps);
    VerletList L;
    L.configure(dom, kSkin);
    L.build(s);
    std::mt19937_64 g(seed);
    // Small moves (each sphere by < skin/2): no rebuild needed and every new overlap is listed.
    for (auto& x : s.position_m) {
      Vec3 dir{uniform(g) - 0.5, uniform(g) - 0.5, uniform(g) - 0.5};
      x += normalized(dir) * (0.49 * kSkin * uniform(g));
    }
    EXPECT_FALSE(L.needs_rebuild(s));
    EXPECT_EQ(list_overlaps(L, s), brute_force_overlaps(s, dom));
    // Large moves (up to 2 mm, across periodic boundaries): a rebuild is needed and correct.
    for (auto& x : s.position_m) x += Vec3{uniform(g) - 0.5, uniform(g) - 0.5, uniform(g) - 0.5} * 4e-3;
    EXPECT_TRUE(L.needs_rebuild(s));
    L.build(s);
    EXPECT_EQ(L.builds(), 2u);
    check_list(L, s, dom);
  }
}

// The rebuild trigger is half the skin: two spheres approaching each other by up to skin/2 each
// close a gap of at most one skin, so a pair outside the list cannot touch before the rebuild.
// One sphere moved by 0.49 skin needs no rebuild, by 0.51 skin it does (a trigger at the full
// skin would let two spheres starting 1.5 skins apart overlap unlisted).
TEST(VerletList, RebuildTriggerIsHalfTheSkin) {
  const Domain dom = make_domain({false, false, false});
  for (const double frac : {0.49, 0.51}) {
    state::SphereStore s = make_packing(7, 100, dom, false);
    VerletList L;
    L.configure(dom, kSkin);
    L.build(s);
    s.position_m[17] += normalized(Vec3{1, -2, 0.5}) * (frac * kSkin);
    EXPECT_EQ(L.needs_rebuild(s), frac > 0.5) << "moved by " << frac << " skin";
  }
  VerletList L;
  L.configure(dom, kSkin);
  EXPECT_EQ(L.rebuild_limit2(), 0.25 * kSkin * kSkin);
}

TEST(VerletList, HistoryOfPairsThatStayInContactSurvivesRebuild) {
  for (const Variant& v : kVariants) {
    SCOPED_TRACE(v.name);
    const Domain dom = make_domain(v.periodic);
    state::SphereStore s = make_packing(7, v.clumps ? 250 : 600, dom, v.clumps);
    VerletList L;
    L.configure(dom, kSkin);
    L.build(s);
    // Mark the overlapping entries as touching, with a history that names the pair.
    std::map<std::pair<std::uint32_t, std::uint32_t>, contact::ContactHistory> expected;
    for (std::uint32_t i = 0; i < s.size(); ++i)
      for (std::uint32_t k = L.row_start[i]; k < L.row_start[i + 1]; ++k) {
        const std::uint32_t j = L.j[k];
        contact::ContactHistory h{{1e-9 * i, 1e-9 * j, 1.0}, {double(i), double(j), -1.0}};
        const Vec3 d = s.position_m[i] - s.position_m[j] - L.shift(k);
        const bool overlap = norm(d) < s.radius_m[i] + s.radius_m[j];
        L.history[k] = h;  // set on every entry: only touching ones may carry it over
        L.touching[k] = overlap ? 1 : 0;
        if (overlap) expected[{i, j}] = h;
      }
    ASSERT_GT(expected.size(), 100u);
    // Translate everything by more than the skin (across periodic boundaries too): the
    // contacts are the same pairs, the list must be rebuilt with new cells and image shifts.
    for (auto& x : s.position_m) x += Vec3{7.3e-3, -5.1e-3, 11.9e-3};
    ASSERT_TRUE(L.needs_rebuild(s));
    L.build(s);
    std::size_t carried = 0;
    for (std::uint32_t i = 0; i < s.size(); ++i)
      for (std::uint32_t k = L.row_start[i]; k < L.row_start[i + 1]; ++k) {
        const auto it = expected.find({i, L.j[k]});
        if (it == expected.end()) {
          EXPECT_EQ(L.touching[k], 0);
          EXPECT_EQ(L.history[k].xi, Vec3{});
          EXPECT_EQ(L.history[k].m_r, Vec3{});
        } else {
          ++carried;
          EXPECT_EQ(L.touching[k], 1);
          EXPECT_EQ(L.history[k].xi, it->second.xi);
          EXPECT_EQ(L.history[k].m_r, it->second.m_r);
        }
      }
    EXPECT_EQ(carried, expected.size());
    // A pair pulled apart beyond the list cutoff (5 mm > r_i + r_j + skin <= 2.3 mm) leaves the
    // list, and its history with it.
    const auto [i0, j0] = expected.begin()->first;
    for (std::uint32_t q = 0; q < s.size(); ++q)
      if (s.body[q] == s.body[j0]) s.position_m[q] += Vec3{0, 0, 5e-3};
    L.build(s);
    for (std::uint32_t k = L.row_start[i0]; k < L.row_start[i0 + 1]; ++k) EXPECT_NE(L.j[k], j0);
  }
}

// The candidate scan of the list build: the AVX-512F scan (where the CPU has it) and the scalar
// one give the same lists, entry for entry, on every variant (exact; without AVX-512F both are
// the scalar scan and the test only checks that the switch works).
TEST(VerletList, VectorAndScalarCandidateScansGiveTheSameList) {
  std::uint64_t seed = 41;
  for (const Variant& v : kVariants) {
    SCOPED_TRACE(v.name);
    const Domain dom = make_domain(v.periodic);
    const state::SphereStore s = make_packing(seed++, v.clumps ? 250 : 600, dom, v.clumps);
    VerletList a, b;
    a.configure(dom, kSkin);
    b.configure(dom, kSkin);
    force_scalar_candidate_scan(false);
    a.build(s);
    force_scalar_candidate_scan(true);
    EXPECT_EQ(best_candidate_scan(), &scan_candidates_scalar);
    b.build(s);
    force_scalar_candidate_scan(false);
    EXPECT_GT(a.j.size(), 300u);
    EXPECT_EQ(a.row_start, b.row_start);
    EXPECT_EQ(a.j, b.j);
    EXPECT_EQ(a.image, b.image);
    check_list(b, s, dom);
  }
}

// The engine renumbers spheres when it sorts bodies spatially (VerletList::renumber): the
// history of every touching pair follows it to its new indices, negated when the pair's order
// flips (history is stored from the lower index's side), and the rebuilt list is again exact.
TEST(VerletList, RenumberKeepsHistoryUnderNewIndices) {
  for (const Variant& v : kVariants) {
    SCOPED_TRACE(v.name);
    const Domain dom = make_domain(v.periodic);
    const state::SphereStore s = make_packing(11, v.clumps ? 250 : 600, dom, v.clumps);
    VerletList L;
    L.configure(dom, kSkin);
    L.build(s);
    std::map<std::pair<std::uint32_t, std::uint32_t>, contact::ContactHistory> old_hist;
    for (std::uint32_t i = 0; i < s.size(); ++i)
      for (std::uint32_t k = L.row_start[i]; k < L.row_start[i + 1]; ++k) {
        const std::uint32_t j = L.j[k];
        const Vec3 d = s.position_m[i] - s.position_m[j] - L.shift(k);
        L.touching[k] = norm(d) < s.radius_m[i] + s.radius_m[j] ? 1 : 0;
        L.history[k] = {{1e-9 * i, 2e-9 * j, 0.5}, {double(i), -double(j), 2.0}};
        if (L.touching[k]) old_hist[{i, j}] = L.history[k];
      }
    // A random permutation of the spheres.
    std::vector<std::uint32_t> new_of_old(s.size());
    for (std::uint32_t i = 0; i < s.size(); ++i) new_of_old[i] = i;
    std::shuffle(new_of_old.begin(), new_of_old.end(), std::mt19937_64(99));
    state::SphereStore p = s;
    for (std::uint32_t i = 0; i < s.size(); ++i) {
      p.position_m[new_of_old[i]] = s.position_m[i];
      p.radius_m[new_of_old[i]] = s.radius_m[i];
      p.body[new_of_old[i]] = s.body[i];
    }
    L.renumber(new_of_old);
    check_row_of(L);  // the renumbered rows (touching pairs only) until the rebuild
    EXPECT_GT(L.j.size(), 0u);
    EXPECT_TRUE(L.needs_rebuild(p));
    L.build(p);
    check_list(L, p, dom);
    std::size_t flipped = 0;
    for (const auto& [pair, h] : old_hist) {
      std::uint32_t a = new_of_old[pair.first], b = new_of_old[pair.second];
      const bool flip = a > b;
      if (flip) std::swap(a, b), ++flipped;
      bool found = false;
      for (std::uint32_t k = L.row_start[a]; k < L.row_start[a + 1]; ++k)
        if (L.j[k] == b) {
          found = true;
          EXPECT_EQ(L.touching[k], 1);
          EXPECT_EQ(L.history[k].xi, flip ? -h.xi : h.xi);
          EXPECT_EQ(L.history[k].m_r, flip ? -h.m_r : h.m_r);
        }
      EXPECT_TRUE(found) << pair.first << "-" << pair.second;
    }
    EXPECT_GT(flipped, 10u);
    EXPECT_LT(flipped, old_hist.size());
  }
}

// Issue 10 item 1: a second insertion wave appends spheres (indices >= the old count). Before
// the fix, build() dropped the history and touching flag of every pair when the sphere count
// changed; now the pairs of the old spheres keep them, and the pairs that involve a new sphere
// start fresh (even where the new sphere overlaps an old one). Exact comparisons.
TEST(VerletList, HistoryOfTouchingPairsSurvivesAppendedSpheres) {
  for (const Variant& v : kVariants) {
    SCOPED_TRACE(v.name);
    const Domain dom = make_domain(v.periodic);
    state::SphereStore s = make_packing(13, v.clumps ? 250 : 600, dom, v.clumps);
    VerletList L;
    L.configure(dom, kSkin);
    L.build(s);
    std::map<std::pair<std::uint32_t, std::uint32_t>, contact::ContactHistory> expected;
    for (std::uint32_t i = 0; i < s.size(); ++i)
      for (std::uint32_t k = L.row_start[i]; k < L.row_start[i + 1]; ++k) {
        const std::uint32_t j = L.j[k];
        const Vec3 d = s.position_m[i] - s.position_m[j] - L.shift(k);
        L.touching[k] = norm(d) < s.radius_m[i] + s.radius_m[j] ? 1 : 0;
        L.history[k] = {{1e-9 * i, -1e-9 * j, 3.0}, {double(j), double(i), 4.0}};
        if (L.touching[k]) expected[{i, j}] = L.history[k];
      }
    ASSERT_GT(expected.size(), 100u);
    // A second wave: another packing appended with new body ids, overlapping the first.
    const std::uint32_t n_old = static_cast<std::uint32_t>(s.size());
    const std::uint32_t b_old = s.body.back() + 1;
    const state::SphereStore w = make_packing(14, 100, dom, v.clumps);
    for (std::size_t q = 0; q < w.size(); ++q) {
      s.position_m.push_back(w.position_m[q]);
      s.velocity_m_s.push_back({});
      s.angular_velocity_rad_s.push_back({});
      s.radius_m.push_back(w.radius_m[q]);
      s.offset_body_m.push_back(w.offset_body_m[q]);
      s.body.push_back(b_old + w.body[q]);
      s.material.push_back(0);
      s.body_mass_kg.push_back(1.0);
      s.force_n.push_back({});
      s.torque_n_m.push_back({});
    }
    ASSERT_TRUE(L.needs_rebuild(s));
    L.build(s);
    check_list(L, s, dom);
    std::size_t carried = 0, new_pairs = 0;
    for (std::uint32_t i = 0; i < s.size(); ++i)
      for (std::uint32_t k = L.row_start[i]; k < L.row_start[i + 1]; ++k) {
        const auto it = expected.find({i, L.j[k]});
        if (it == expected.end()) {
          if (L.j[k] >= n_old) ++new_pairs;
          EXPECT_EQ(L.touching[k], 0);
          EXPECT_EQ(L.history[k].xi, Vec3{});
        } else {
          ++carried;
          EXPECT_EQ(L.touching[k], 1);
          EXPECT_EQ(L.history[k].xi, it->second.xi);
          EXPECT_EQ(L.history[k].m_r, it->second.m_r);
        }
      }
    EXPECT_EQ(carried, expected.size());
    EXPECT_GT(new_pairs, 10u);  // the new wave does reach into the old spheres
  }
}

// Spheres appended and then renumbered before any build (e.g. bodies removed right after a
// wave): the map covers the new spheres too; the old pairs' history follows its spheres.
TEST(VerletList, RenumberAfterAppendKeepsHistory) {
  const Domain dom = make_domain({false, false, false});
  state::SphereStore s = make_packing(21, 400, dom, false);
  VerletList L;
  L.configure(dom, kSkin);
  L.build(s);
  std::map<std::pair<std::uint32_t, std::uint32_t>, contact::ContactHistory> old_hist;
  for (std::uint32_t i = 0; i < s.size(); ++i)
    for (std::uint32_t k = L.row_start[i]; k < L.row_start[i + 1]; ++k) {
      const std::uint32_t j = L.j[k];
      const Vec3 d = s.position_m[i] - s.position_m[j] - L.shift(k);
      L.touching[k] = norm(d) < s.radius_m[i] + s.radius_m[j] ? 1 : 0;
      L.history[k] = {{1e-9 * i, 2e-9 * j, 0.5}, {double(i), -double(j), 2.0}};
      if (L.touching[k]) old_hist[{i, j}] = L.history[k];
    }
  const std::uint32_t n_old = static_cast<std::uint32_t>(s.size());
  for (int q = 0; q < 50; ++q) {  // far-away appended spheres
    s.position_m.push_back({1.0 + 0.01 * q, 0, 0});
    s.velocity_m_s.push_back({});
    s.angular_velocity_rad_s.push_back({});
    s.radius_m.push_back(0.5e-3);
    s.offset_body_m.push_back({});
    s.body.push_back(1000 + q);
    s.material.push_back(0);
    s.body_mass_kg.push_back(1.0);
    s.force_n.push_back({});
    s.torque_n_m.push_back({});
  }
  // Reverse order: every old pair flips.
  const std::uint32_t n = static_cast<std::uint32_t>(s.size());
  std::vector<std::uint32_t> new_of_old(n);
  for (std::uint32_t i = 0; i < n; ++i) new_of_old[i] = n - 1 - i;
  state::SphereStore p = s;
  for (std::uint32_t i = 0; i < n; ++i) {
    p.position_m[new_of_old[i]] = s.position_m[i];
    p.radius_m[new_of_old[i]] = s.radius_m[i];
    p.body[new_of_old[i]] = s.body[i];
  }
  L.renumber(new_of_old);
  L.build(p);
  check_list(L, p, dom);
  ASSERT_GT(old_hist.size(), 50u);
  for (const auto& [pair, h] : old_hist) {
    ASSERT_LT(pair.second, n_old);
    const std::uint32_t a = new_of_old[pair.second], b = new_of_old[pair.first];  // flipped
    bool found = false;
    for (std::uint32_t k = L.row_start[a]; k < L.row_start[a + 1]; ++k)
      if (L.j[k] == b) {
        found = true;
        EXPECT_EQ(L.touching[k], 1);
        EXPECT_EQ(L.history[k].xi, -h.xi);
        EXPECT_EQ(L.history[k].m_r, -h.m_r);
      }
    EXPECT_TRUE(found) << pair.first << "-" << pair.second;
  }
}

// A sphere absurdly far away (a corrupt checkpoint, an exploded run; found by the checkpoint
// fuzzer): the cell grid must neither overflow an int (undefined behaviour before the fix, a
// cell count of 5e191) nor miss pairs; the list stays exact.
TEST(VerletList, FarAwaySphereKeepsTheGridBoundedAndTheListExact) {
  const Domain dom = make_domain({false, false, false});
  state::SphereStore s = make_packing(31, 300, dom, false);
  s.position_m[17] = {1e200, -3e150, 0.5};
  VerletList L;
  L.configure(dom, kSkin);
  L.build(s);
  check_list(L, s, dom);
}

// Image shifts are stored in 8 bits: a sphere more than 60 periodic lengths away is an error
// naming it, not a wrong pair (before: the shift silently wrapped).
TEST(VerletList, SphereTooManyPeriodsAwayIsAnError) {
  const Domain dom = make_domain({true, false, false});
  state::SphereStore s = make_packing(32, 100, dom, false);
  s.position_m[5].x += 200 * kL;
  VerletList L;
  L.configure(dom, kSkin);
  try {
    L.build(s);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("sphere 5 "), std::string::npos) << e.what();
  }
}

// pairs_missing_within_cutoff (the GPU engine's check of the touching pairs it hands to a new
// host list, neighbor/verlet_list.hpp): listed pairs and pairs beyond r_i + r_j + skin are not
// counted, in either order; a pair brought within the cut-off after the build is, also through
// a periodic image (minimum image), but not one period away on a bounded axis.
TEST(VerletList, PairsMissingWithinCutoffCountsOnlyGapsOfTheList) {
  const Domain dom = make_domain({false, false, true});
  state::SphereStore s = make_packing(41, 300, dom, false);
  VerletList L;
  L.configure(dom, kSkin);
  L.build(s);
  const PairList listed = list_pairs(L, s.size());
  ASSERT_GT(listed.size(), 50u);
  PairList reversed;
  for (const auto& [i, j] : listed) reversed.emplace_back(j, i);
  EXPECT_EQ(pairs_missing_within_cutoff(L, s, listed), 0u);
  EXPECT_EQ(pairs_missing_within_cutoff(L, s, reversed), 0u);
  // Every pair of sphere 0 beyond the cut-off: none counted.
  const PairList within = brute_force_within(s, dom, kSkin);
  PairList beyond;
  for (std::uint32_t j = 1; j < s.size(); ++j)
    if (!std::binary_search(within.begin(), within.end(), std::make_pair(0u, j))) beyond.emplace_back(j, 0u);
  ASSERT_GT(beyond.size(), 200u);
  EXPECT_EQ(pairs_missing_within_cutoff(L, s, beyond), 0u);
  // Sphere 0 moved next to a sphere q it is not listed with (no rebuild).
  const std::uint32_t q = beyond.front().first;
  const double cut = s.radius_m[0] + s.radius_m[q] + kSkin;
  const PairList one{{0u, q}}, one_reversed{{q, 0u}};
  auto place = [&](Vec3 shift) { s.position_m[0] = s.position_m[q] + shift; };
  place({0.99 * cut, 0.0, 0.0});
  EXPECT_EQ(pairs_missing_within_cutoff(L, s, one), 1u);
  EXPECT_EQ(pairs_missing_within_cutoff(L, s, one_reversed), 1u);
  place({1.01 * cut, 0.0, 0.0});
  EXPECT_EQ(pairs_missing_within_cutoff(L, s, one), 0u);
  place({0.0, 0.0, 0.99 * cut + kL});  // z periodic: within the cut-off through the image
  EXPECT_EQ(pairs_missing_within_cutoff(L, s, one), 1u);
  place({0.0, 0.0, 0.99 * cut - 2.0 * kL});
  EXPECT_EQ(pairs_missing_within_cutoff(L, s, one), 1u);
  place({0.99 * cut + kL, 0.0, 0.0});  // x bounded: one box length away is far
  EXPECT_EQ(pairs_missing_within_cutoff(L, s, one), 0u);
  // Spheres of one body are never listed: not a gap.
  place({0.5 * cut, 0.0, 0.0});
  s.body[0] = s.body[q];
  EXPECT_EQ(pairs_missing_within_cutoff(L, s, one), 0u);
}
