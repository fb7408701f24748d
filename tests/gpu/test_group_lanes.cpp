// The GPU kernels that a group of lanes of a warp shares on CUDA, run with each lane a CPU
// thread (ballots, shuffles and syncs through a barrier, the group's scratch shared as a warp's
// shared memory is): the engine on CPU threads runs them as groups of one lane, so only these
// tests cover, without a GPU, what the lanes of a group do together (a missing sync shows as a
// mismatch here or a race under ThreadSanitizer).
//
// 1. The grouped list build (gpu/kernels.hpp, BuildRowsGrouped) with groups of 1, 4 and 32
// lanes: the slots taken by a ballot, the placement by rank, the old row's history handed over
// by several lanes. Against BuildRows (one thread per row): lengths, neighbours, stable ids,
// image shifts, touching flags and history bytes of every row must be equal. Scenes (8): random
// spheres (some bodies of two) in grids with every combination of periodic and bounded axes, 3
// to 6 cells along a periodic axis, positions up to two periods away, stable ids shuffled; old
// rows built at another skin with random touching flags and history, with and without a
// reordering of the old columns (a sort of the bodies); row capacities 16, 49, 128, rows that
// overflow included (their length only).
//
// (3, below, needs no lanes: the list from a stale box and non-finite positions.)
//
// 2. The row walk shared by lanes (walk_row_lanes, what for_each_walk runs on CUDA) with groups
// of 2, 4, 16 and 32 lanes: the same sums, bit for bit, as one thread walking the row
// (walk_row), over walks of 0 to 40 contacts whose values span six decades (so that any other
// order of the additions gives other bits), and the walk ended once, by lane 0.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <barrier>
#include <cmath>
#include <cstring>
#include <memory>
#include <numeric>
#include <random>
#include <thread>
#include <vector>

#define BIODEM_GPU_NS lanes_test
#include "gpu/kernels.hpp"

using namespace biodem;
using namespace biodem::gpu::lanes_test;

namespace {

/// A group of lanes, each a thread: ballot and sync over a barrier of the group.
struct GroupState {
  std::barrier<> bar;
  std::vector<std::uint8_t> votes;
  std::vector<RowContact> contacts;
  std::vector<long long> words;
  explicit GroupState(std::uint32_t lanes)
      : bar(static_cast<std::ptrdiff_t>(lanes)), votes(lanes), contacts(lanes), words(lanes) {}
};
struct ThreadLanes {
  GroupState* g;
  std::uint32_t me, count;
  std::uint32_t lane() const { return me; }
  std::uint32_t size() const { return count; }
  std::uint32_t ballot(bool b) const {
    g->votes[me] = b ? 1 : 0;
    g->bar.arrive_and_wait();
    std::uint32_t bits = 0;
    for (std::uint32_t l = 0; l < count; ++l) bits |= static_cast<std::uint32_t>(g->votes[l]) << l;
    g->bar.arrive_and_wait();  // (the votes are read before the next ballot writes them)
    return bits;
  }
  void sync() const { g->bar.arrive_and_wait(); }
  long long shuffle(long long v, std::uint32_t src) const {
    g->words[me] = v;
    g->bar.arrive_and_wait();
    const long long o = g->words[src];
    g->bar.arrive_and_wait();  // (read before the next shuffle writes)
    return o;
  }
  RowContact shuffle(const RowContact& r, std::uint32_t src) const {
    g->contacts[me] = r;
    g->bar.arrive_and_wait();
    const RowContact o = g->contacts[src];
    g->bar.arrive_and_wait();  // (read before the next shuffle writes)
    return o;
  }
};

/// f(item, lane) for items 0 .. items - 1 by one group of `lanes` lanes, each lane a thread (as a
/// CUDA kernel runs one group per item).
template <class F>
void in_thread_lanes(std::uint32_t items, std::uint32_t lanes, const F& f) {
  GroupState state(lanes);
  std::vector<std::thread> team;
  for (std::uint32_t l = 0; l < lanes; ++l)
    team.emplace_back([&, l] {
      const ThreadLanes me{&state, l, lanes};
      for (std::uint32_t i = 0; i < items; ++i) f(i, me);
    });
  for (auto& th : team) th.join();
}

/// Row arrays held in vectors, filled with a marker so that an entry left unwritten shows.
struct HostRows {
  std::vector<std::uint32_t> j, sid, length, mirror;
  std::vector<std::int32_t> image;
  std::vector<std::uint8_t> touching;
  std::vector<contact::ContactHistory> history;
  std::uint32_t cap = 0;
  void reset(std::uint32_t n, std::uint32_t c) {
    cap = c;
    const std::size_t m = static_cast<std::size_t>(n) * c;
    j.assign(m, 0xdeadbeefu);
    sid.assign(m, 0xdeadbeefu);
    image.assign(m, 0x5a5a5a5a);
    touching.assign(m, 7);
    contact::ContactHistory h;
    h.xi = Vec3{1e9, 1e9, 1e9};
    h.m_r = h.xi;
    history.assign(m, h);
    length.assign(n, 0xdeadbeefu);
    mirror.assign(m, 0);
  }
  RowArrays arrays() {
    return {j.data(), sid.data(), image.data(), touching.data(), history.data(), length.data(), cap, mirror.data(),
            nullptr, nullptr, nullptr, nullptr};
  }
};

/// One random scene, its cell order and packed data, and old rows with random history.
struct Scene {
  std::uint32_t n = 0;
  GridParams g;
  std::vector<Vec3> pos, zero3;
  std::vector<double> radius, zero1;
  std::vector<std::uint32_t> body, sid, zero_u, sorted, cell_start;
  std::vector<Int3> wrap, cell;
  std::vector<Vec3> p_pos;
  std::vector<double> p_radius;
  std::vector<std::uint32_t> p_body, p_sid;
  std::vector<Int3> p_wrap;
  HostRows old_rows;
  std::vector<std::uint32_t> old_of;
  bool reordered = false;
  double skin = 0.0;

  SphereArrays spheres() {
    return SphereArrays{pos.data(),    zero3.data(), zero3.data(),  zero3.data(), zero3.data(),
                        zero3.data(),  zero3.data(), radius.data(), zero1.data(), body.data(),
                        zero_u.data(), sid.data(),   zero_u.data()};
  }
  RowBuildArgs args(HostRows& rows, RowArrays old) {
    return RowBuildArgs{spheres(), g, sorted.data(), cell_start.data(),
                        CellPacked{p_pos.data(), p_radius.data(), p_body.data(), p_sid.data(), p_wrap.data()},
                        wrap.data(), cell.data(), old, rows.arrays(), n, skin,
                        reordered ? old_of.data() : nullptr};
  }
};

double uniform(std::mt19937_64& gen) { return static_cast<double>(gen() >> 11) * 0x1.0p-53; }

Scene make_scene(std::uint64_t seed) {
  Scene s;
  std::mt19937_64 gen(seed);
  s.n = 250 + static_cast<std::uint32_t>(gen() % 250);
  const std::uint32_t n = s.n;
  const double rmax = 0.5;
  s.skin = 0.1 + 1.2 * uniform(gen);
  const double cut = 2.0 * rmax + s.skin;
  bool periodic[3];
  double len[3];
  for (int k = 0; k < 3; ++k) {
    periodic[k] = (seed >> k) & 1u;  // every combination over the 8 seeds
    len[k] = static_cast<double>(3 + gen() % 4) * cut * (1.0 + 0.2 * uniform(gen));
  }
  s.pos.resize(n);
  s.radius.resize(n);
  s.body.resize(n);
  s.sid.resize(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k)
      s.pos[i][k] = (1.4 * uniform(gen) - 0.2) * len[k] +
                    (periodic[k] ? static_cast<double>(static_cast<int>(gen() % 5) - 2) * len[k] : 0.0);
    s.radius[i] = rmax * (0.3 + 0.7 * uniform(gen));
    s.body[i] = (i % 3 == 1) ? i - 1 : i;  // every third sphere shares its body with the one before
  }
  std::iota(s.sid.begin(), s.sid.end(), 0u);
  std::shuffle(s.sid.begin(), s.sid.end(), gen);
  s.zero3.assign(n, Vec3{});
  s.zero1.assign(n, 0.0);
  s.zero_u.assign(n, 0u);
  // The grid as Engine::build_list makes it (cells at least the cut-off wide, periodic axes in
  // a whole number of at least 3 cells).
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (const Vec3& p : s.pos)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], p[k]);
      hi[k] = std::max(hi[k], p[k]);
    }
  int nn[3];
  s.g.cell = cut;
  for (int k = 0; k < 3; ++k) {
    s.g.periodic[k] = periodic[k];
    if (periodic[k]) {
      s.g.lo[k] = 0.0;
      s.g.period[k] = len[k];
      nn[k] = static_cast<int>(std::floor(len[k] / cut));
    } else {
      s.g.lo[k] = lo[k];
      nn[k] = std::max(1, static_cast<int>(std::floor((hi[k] - lo[k]) / cut)) + 1);
    }
  }
  s.g.n = Int3{nn[0], nn[1], nn[2]};
  const std::uint32_t ncell = static_cast<std::uint32_t>(nn[0] * nn[1] * nn[2]);
  std::vector<std::uint32_t> key(n);
  s.wrap.resize(n);
  s.cell.resize(n);
  const CellOf cell_of{s.spheres(), s.g, key.data(), s.wrap.data(), s.cell.data()};
  for (std::uint32_t i = 0; i < n; ++i) cell_of(i);
  s.sorted.resize(n);
  std::iota(s.sorted.begin(), s.sorted.end(), 0u);
  std::stable_sort(s.sorted.begin(), s.sorted.end(), [&](std::uint32_t a, std::uint32_t b) { return key[a] < key[b]; });
  std::vector<std::uint32_t> sorted_key(n);
  for (std::uint32_t p = 0; p < n; ++p) sorted_key[p] = key[s.sorted[p]];
  s.cell_start.resize(ncell + 1);
  for (std::uint32_t c = 0; c <= ncell; ++c)
    s.cell_start[c] = static_cast<std::uint32_t>(std::lower_bound(sorted_key.begin(), sorted_key.end(), c) - sorted_key.begin());
  s.p_pos.resize(n);
  s.p_radius.resize(n);
  s.p_body.resize(n);
  s.p_sid.resize(n);
  s.p_wrap.resize(n);
  const PackByCell pack{s.spheres(), s.sorted.data(), s.wrap.data(),
                        CellPacked{s.p_pos.data(), s.p_radius.data(), s.p_body.data(), s.p_sid.data(), s.p_wrap.data()}};
  for (std::uint32_t p = 0; p < n; ++p) pack(p);
  // Old rows: BuildRows at another skin (from empty rows), then random touching and history.
  HostRows none;
  none.reset(n, 1);
  std::fill(none.length.begin(), none.length.end(), 0u);
  s.old_rows.reset(n, 400);
  {
    RowBuildArgs a = s.args(s.old_rows, none.arrays());
    a.skin = s.skin * (0.6 + 0.8 * uniform(gen));
    a.old_of = nullptr;
    const BuildRows build{a};
    for (std::uint32_t i = 0; i < n; ++i) build(i);
  }
  for (auto& t : s.old_rows.touching) t = static_cast<std::uint8_t>(gen() % 2);
  for (auto& h : s.old_rows.history) {
    h.xi = Vec3{uniform(gen), uniform(gen), uniform(gen)};
    h.m_r = Vec3{uniform(gen), uniform(gen), uniform(gen)};
  }
  s.reordered = seed % 3 == 1;
  s.old_of.resize(n);
  std::iota(s.old_of.begin(), s.old_of.end(), 0u);
  if (s.reordered) {  // old column old_of[i] holds sphere i's old row (a sort of the bodies)
    std::shuffle(s.old_of.begin(), s.old_of.end(), gen);
    HostRows moved = s.old_rows;
    for (std::uint32_t i = 0; i < n; ++i) {
      moved.length[s.old_of[i]] = s.old_rows.length[i];
      for (std::uint32_t q = 0; q < s.old_rows.cap; ++q) {
        const std::size_t from = static_cast<std::size_t>(q) * n + i, to = static_cast<std::size_t>(q) * n + s.old_of[i];
        moved.j[to] = s.old_rows.j[from];
        moved.sid[to] = s.old_rows.sid[from];
        moved.image[to] = s.old_rows.image[from];
        moved.touching[to] = s.old_rows.touching[from];
        moved.history[to] = s.old_rows.history[from];
      }
    }
    s.old_rows = moved;
  }
  return s;
}

}  // namespace

TEST(RowBuildLanes, GroupsOfThreadLanesGiveTheRowsOfBuildRows) {
  std::size_t rows = 0, overflowing = 0, touching = 0, across = 0, mismatches = 0;
  for (std::uint64_t seed = 0; seed < 8; ++seed) {
    Scene s = make_scene(seed);
    const std::uint32_t n = s.n;
    for (const std::uint32_t cap : {16u, 49u, 128u}) {
      HostRows ref;
      ref.reset(n, cap);
      {
        const BuildRows build{s.args(ref, s.old_rows.arrays())};
        for (std::uint32_t i = 0; i < n; ++i) build(i);
      }
      for (const std::uint32_t lanes : {1u, 4u, 32u}) {
        HostRows got;
        got.reset(n, cap);
        const BuildRowsGrouped grouped{s.args(got, s.old_rows.arrays())};
        if (lanes == 1) {
          for (std::uint32_t i = 0; i < n; ++i) grouped(i);  // as the engine on CPU threads
        } else {
          GroupState state(lanes);
          std::vector<unsigned char> scratch(BuildRowsGrouped::scratch_bytes(cap) + 16);
          unsigned char* base = scratch.data() + (16 - reinterpret_cast<std::uintptr_t>(scratch.data()) % 16) % 16;
          std::vector<std::thread> team;
          for (std::uint32_t l = 0; l < lanes; ++l)
            team.emplace_back([&, l] {
              const ThreadLanes me{&state, l, lanes};
              for (std::uint32_t i = 0; i < n; ++i) {
                grouped.build(i, me, RowScratch::at(base, cap));
                state.bar.arrive_and_wait();  // (on a GPU each row has a scratch of its own)
              }
            });
          for (auto& t : team) t.join();
        }
        for (std::uint32_t i = 0; i < n; ++i) {
          ++rows;
          bool same = ref.length[i] == got.length[i];
          if (ref.length[i] > cap) {
            ++overflowing;
          } else {
            for (std::uint32_t q = 0; q < ref.length[i] && same; ++q) {
              const std::size_t k = static_cast<std::size_t>(q) * n + i;
              same = ref.j[k] == got.j[k] && ref.sid[k] == got.sid[k] && ref.image[k] == got.image[k] &&
                     ref.touching[k] == got.touching[k] &&
                     std::memcmp(&ref.history[k], &got.history[k], sizeof(contact::ContactHistory)) == 0;
              if (lanes == 32) {
                touching += ref.touching[k] == 1;
                across += ref.image[k] != 0;
              }
            }
          }
          if (!same && mismatches++ < 5)
            ADD_FAILURE() << "seed " << seed << ", capacity " << cap << ", " << lanes << " lanes: row " << i
                          << " differs (length " << ref.length[i] << " vs " << got.length[i] << ")";
        }
      }
    }
  }
  std::printf("[measured] grouped row build with 1, 4, 32 lanes vs BuildRows: %zu rows (%zu overflowing), %zu "
              "mismatches; in the rows of 32 lanes %zu entries took an old history, %zu had an image shift\n",
              rows, overflowing, mismatches, touching, across);
  EXPECT_EQ(mismatches, 0u);
  EXPECT_GT(overflowing, 100u) << "rows must overflow the capacity for the test to mean anything";
  EXPECT_GT(touching, 1000u) << "old contacts must hand their history over for the test to mean anything";
  EXPECT_GT(across, 1000u) << "rows must cross periodic boundaries for the test to mean anything";
}

namespace {

/// A walk with made-up contacts: item i's walk has (i * 7) % 41 contacts (none for every 11th
/// item, whose walk_begin says there is nothing to do), each of kind 0-3 with a force and torque
/// from a hash of (item, contact), magnitudes from 1e-3 to 1e3.
struct MadeUpWalk {
  Vec3* force;
  Vec3* torque;
  std::uint32_t* count;
  std::uint32_t* ends;  // walk_end calls per item
  static std::uint64_t hash(std::uint64_t x) {
    x += 0x9e3779b97f4a7c15ull;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
    return x ^ (x >> 31);
  }
  static double value(std::uint64_t h) {
    return std::ldexp(static_cast<double>(h >> 11) * 0x1.0p-53 - 0.5, static_cast<int>(h % 21) - 10);
  }
  bool walk_begin(std::uint32_t item, WalkStart& st) const {
    if (item % 11 == 10) return false;
    st.a = item;
    st.total = (item * 7) % 41;
    st.len = st.total * 2 / 3;
    return true;
  }
  RowContact walk_entry(const WalkStart& st, std::uint32_t v) const {
    RowContact r;
    if (v >= st.total) return r;  // (past the walk's end, as Forces)
    const std::uint64_t h = hash((static_cast<std::uint64_t>(st.a) << 32) | v);
    r.kind = static_cast<std::uint32_t>(h % 4);
    r.force = Vec3{value(hash(h + 1)), value(hash(h + 2)), value(hash(h + 3))};
    r.torque = Vec3{value(hash(h + 4)), value(hash(h + 5)), value(hash(h + 6))};
    return r;
  }
  void walk_end(std::uint32_t item, const WalkStart&, const Vec3& f, const Vec3& t, std::uint32_t c) const {
    force[item] = f;
    torque[item] = t;
    count[item] = c;
    ++ends[item];
  }
};

/// MadeUpWalk as a walker that loads its entries' heads ahead (kHeadsAhead, as Forces): each
/// lane's contact v < len comes from the head loaded for it before; a head of the wrong entry,
/// or a load at or past head_limit(), gives a contact that changes the sums (and is counted).
struct MadeUpWalkAhead : MadeUpWalk {
  std::atomic<std::uint32_t>* wrong;
  std::atomic<std::uint32_t>* from_heads;  // walk_entry_from calls
  static constexpr bool kHeadsAhead = true;
  struct Head {
    std::uint32_t item = ~0u, v = ~0u;
  };
  std::uint32_t head_limit() const { return 26; }  // (the longest row: a load at or past it is wrong)
  Head walk_head(std::uint32_t item, std::uint32_t v) const {
    if (v >= head_limit()) ++*wrong;
    return Head{item, v};
  }
  RowContact walk_entry_from(const WalkStart& st, std::uint32_t v, const Head& h) const {
    ++*from_heads;
    if (h.item != st.a || h.v != v || v >= st.len) {
      ++*wrong;
      RowContact r;
      r.kind = 1;
      r.force = Vec3{1e30, 1e30, 1e30};
      return r;
    }
    return walk_entry(st, v);
  }
};

}  // namespace

namespace {

/// walk_row_lanes(w, i, lane) for items 0 .. items - 1 by a group of `lanes` lanes, each lane a
/// thread (as for_each_walk runs one group per item on CUDA).
template <class W>
void walk_rows_in_thread_lanes(const W& w, std::uint32_t items, std::uint32_t lanes) {
  in_thread_lanes(items, lanes, [&](std::uint32_t i, const ThreadLanes& me) { walk_row_lanes(w, i, me); });
}

}  // namespace

TEST(RowWalkLanes, GroupsOfThreadLanesGiveTheSumsOfOneThread) {
  constexpr std::uint32_t kItems = 300;
  std::vector<Vec3> f1(kItems, Vec3{-1, -1, -1}), t1(kItems, Vec3{-1, -1, -1});  // (untouched where nothing to do)
  std::vector<std::uint32_t> c1(kItems, 12345), e1(kItems, 0);
  const MadeUpWalk one{f1.data(), t1.data(), c1.data(), e1.data()};
  for (std::uint32_t i = 0; i < kItems; ++i) walk_row(one, i);
  std::size_t contacts = 0;
  for (std::uint32_t i = 0; i < kItems; ++i) contacts += e1[i] ? c1[i] : 0;
  for (const std::uint32_t lanes : {2u, 4u, 16u, 32u}) {
    std::vector<Vec3> f(kItems, Vec3{-1, -1, -1}), t(kItems, Vec3{-1, -1, -1});
    std::vector<std::uint32_t> c(kItems, 12345), e(kItems, 0);
    const MadeUpWalk grouped{f.data(), t.data(), c.data(), e.data()};
    walk_rows_in_thread_lanes(grouped, kItems, lanes);
    std::size_t differ = 0;
    for (std::uint32_t i = 0; i < kItems; ++i) {
      const bool same = std::memcmp(&f[i], &f1[i], sizeof(Vec3)) == 0 && std::memcmp(&t[i], &t1[i], sizeof(Vec3)) == 0 &&
                        c[i] == c1[i] && e[i] == e1[i];
      differ += !same;
    }
    EXPECT_EQ(differ, 0u) << lanes << " lanes";
    std::printf("[measured] row walk with %u lanes vs one thread: %u walks, %zu contacts counted, %zu walks differ\n",
                lanes, kItems, contacts, differ);
  }
  EXPECT_GT(contacts, 1000u);
  EXPECT_EQ(e1[10], 0u);  // (walk_begin said nothing to do)
  EXPECT_EQ(e1[11], 1u);
}

// The same with a walker whose lanes load their next entry's head ahead (kHeadsAhead: the path
// Forces takes on CUDA): each lane evaluates entries l, l + lanes, ... from the heads it loaded
// one round before, and loads none at or past head_limit(). Groups of 1, 2, 4, 16 and 32 thread
// lanes give the sums of one thread walking the plain MadeUpWalk, and no wrong head is used.
TEST(RowWalkLanes, LanesLoadingTheirHeadsAheadGiveTheSumsOfOneThread) {
  constexpr std::uint32_t kItems = 300;
  std::vector<Vec3> f1(kItems, Vec3{-1, -1, -1}), t1(kItems, Vec3{-1, -1, -1});
  std::vector<std::uint32_t> c1(kItems, 12345), e1(kItems, 0);
  const MadeUpWalk one{f1.data(), t1.data(), c1.data(), e1.data()};
  for (std::uint32_t i = 0; i < kItems; ++i) walk_row(one, i);
  for (const std::uint32_t lanes : {1u, 2u, 4u, 16u, 32u}) {
    std::vector<Vec3> f(kItems, Vec3{-1, -1, -1}), t(kItems, Vec3{-1, -1, -1});
    std::vector<std::uint32_t> c(kItems, 12345), e(kItems, 0);
    std::atomic<std::uint32_t> wrong{0}, from_heads{0};
    MadeUpWalkAhead ahead;
    static_cast<MadeUpWalk&>(ahead) = MadeUpWalk{f.data(), t.data(), c.data(), e.data()};
    ahead.wrong = &wrong;
    ahead.from_heads = &from_heads;
    static_assert(WalksHeadsAhead<MadeUpWalkAhead>::value && !WalksHeadsAhead<MadeUpWalk>::value);
    walk_rows_in_thread_lanes(ahead, kItems, lanes);
    std::size_t differ = 0;
    for (std::uint32_t i = 0; i < kItems; ++i)
      differ += !(std::memcmp(&f[i], &f1[i], sizeof(Vec3)) == 0 && std::memcmp(&t[i], &t1[i], sizeof(Vec3)) == 0 &&
                  c[i] == c1[i] && e[i] == e1[i]);
    EXPECT_EQ(differ, 0u) << lanes << " lanes";
    EXPECT_EQ(wrong.load(), 0u) << lanes << " lanes";
    // every pair entry came from its head (none through walk_entry)
    std::uint32_t entries = 0;
    for (std::uint32_t i = 0; i < kItems; ++i) {
      WalkStart st;
      if (ahead.walk_begin(i, st)) entries += st.len;
    }
    EXPECT_EQ(from_heads.load(), entries) << lanes << " lanes";
    std::printf("[measured] row walk with %u lanes loading heads ahead vs one thread: %zu walks differ, %u wrong heads\n",
                lanes, differ, wrong.load());
  }
}

namespace {
/// MadeUpWalkAhead as a walker for walk_packed (as Forces): the cut-off tests alone
/// (walk_touches_from with the entry's head, walk_touches for the walls) say whether the made-up
/// contact touches (kind != 0), and every test and evaluation is counted per entry. A wrong head,
/// or an evaluation of a contact apart, gives a contact that changes the sums (and is counted).
struct MadeUpWalkPacked : MadeUpWalkAhead {
  static constexpr std::uint32_t kMostEntries = 41;
  std::atomic<std::uint32_t>* tested;     // [item * kMostEntries + v]
  std::atomic<std::uint32_t>* evaluated;  // likewise
  bool touches(const WalkStart& st, std::uint32_t v) const { return MadeUpWalk::walk_entry(st, v).kind != 0; }
  bool walk_touches_from(const WalkStart& st, std::uint32_t v, const Head& h) const {
    ++tested[st.a * kMostEntries + v];
    if (h.item != st.a || h.v != v || v >= st.len) ++*wrong;
    return touches(st, v);
  }
  bool walk_touches(const WalkStart& st, std::uint32_t v) const {
    ++tested[st.a * kMostEntries + v];
    if (v < st.len || v >= st.total) ++*wrong;  // (walls only)
    return touches(st, v);
  }
  RowContact checked(const WalkStart& st, std::uint32_t v, RowContact r) const {
    ++evaluated[st.a * kMostEntries + v];
    if (r.kind == 0) {  // (a contact apart: walk_packed must not evaluate it)
      ++*wrong;
      r.kind = 1;
      r.force = Vec3{1e30, 1e30, 1e30};
    }
    return r;
  }
  RowContact walk_entry_from(const WalkStart& st, std::uint32_t v, const Head& h) const {
    return checked(st, v, MadeUpWalkAhead::walk_entry_from(st, v, h));
  }
  RowContact walk_entry(const WalkStart& st, std::uint32_t v) const {
    if (v < st.len) ++*wrong;  // (pair entries come from their heads)
    return checked(st, v, MadeUpWalk::walk_entry(st, v));
  }
};
}  // namespace

// The row walks of a warp's spheres with their touching contacts shared by its lanes
// (walk_packed, what for_each_packed_walk runs on CUDA with BIODEM_GPU_WALK_PACK=1) by groups of
// 1, 2, 4, 8 and 32 thread lanes, each walk of 0 to 40 contacts (two thirds pair entries, a
// third walls; about three quarters touching) whose values span six decades, by one lane each
// or shared by 2, 4 or 32 lanes (BIODEM_GPU_PACK_SPLIT; lane p of a walk tests its entries p,
// p + 2, ...): the sums of one thread walking each row (walk_row), bit for bit; every contact
// tested once, every touching one evaluated once and no other; each walk ended once; no wrong
// head. (It fails when the owners add a round's results in another order, or without the sync
// before the results are read, and with split walks when the owner takes only its own lane's
// contacts or when every lane of a walk ends it: checked.)
TEST(RowWalkLanes, WarpsSharingTheirTouchingContactsGiveTheSumsOfOneThread) {
  constexpr std::uint32_t kItems = 300;
  constexpr std::uint32_t kN = MadeUpWalkPacked::kMostEntries;
  std::vector<Vec3> f1(kItems, Vec3{-1, -1, -1}), t1(kItems, Vec3{-1, -1, -1});
  std::vector<std::uint32_t> c1(kItems, 12345), e1(kItems, 0);
  const MadeUpWalk one{f1.data(), t1.data(), c1.data(), e1.data()};
  for (std::uint32_t i = 0; i < kItems; ++i) walk_row(one, i);
  std::size_t touching = 0, apart = 0;
  for (std::uint32_t i = 0; i < kItems; ++i) {
    WalkStart st;
    if (one.walk_begin(i, st))
      for (std::uint32_t v = 0; v < st.total; ++v) (one.walk_entry(st, v).kind ? touching : apart) += 1;
  }
  struct Shape {
    std::uint32_t lanes, split_log2;
  };
  for (const Shape shape : {Shape{1, 0}, Shape{2, 0}, Shape{4, 0}, Shape{8, 0}, Shape{32, 0}, Shape{2, 1}, Shape{8, 1},
                            Shape{32, 1}, Shape{8, 2}, Shape{32, 5}}) {
    const std::uint32_t lanes = shape.lanes, split_log2 = shape.split_log2, per_group = lanes >> split_log2;
    SCOPED_TRACE(std::to_string(lanes) + " lanes, " + std::to_string(1u << split_log2) + " per walk");
    std::vector<Vec3> f(kItems, Vec3{-1, -1, -1}), t(kItems, Vec3{-1, -1, -1});
    std::vector<std::uint32_t> c(kItems, 12345), e(kItems, 0);
    std::atomic<std::uint32_t> wrong{0}, from_heads{0};
    std::vector<std::atomic<std::uint32_t>> tested(kItems * kN), evaluated(kItems * kN);
    MadeUpWalkPacked packed;
    static_cast<MadeUpWalk&>(packed) = MadeUpWalk{f.data(), t.data(), c.data(), e.data()};
    packed.wrong = &wrong;
    packed.from_heads = &from_heads;
    packed.tested = tested.data();
    packed.evaluated = evaluated.data();
    static_assert(WalksPacked<MadeUpWalkPacked>::value && !WalksPacked<MadeUpWalkAhead>::value);
    PackedWalkScratch<MadeUpWalkAhead::Head> scratch;  // (one group at a time: one scratch)
    const std::uint32_t groups = (kItems + per_group - 1) / per_group;
    in_thread_lanes(groups, lanes, [&](std::uint32_t g, const ThreadLanes& me) {
      const std::uint32_t item = g * per_group + (me.lane() >> split_log2);
      if (split_log2)
        walk_packed<true>(packed, item, item < kItems, me, scratch, split_log2);
      else
        walk_packed(packed, item, item < kItems, me, scratch);
    });
    std::size_t differ = 0, tests_off = 0, evaluations_off = 0;
    for (std::uint32_t i = 0; i < kItems; ++i) {
      differ += !(std::memcmp(&f[i], &f1[i], sizeof(Vec3)) == 0 && std::memcmp(&t[i], &t1[i], sizeof(Vec3)) == 0 &&
                  c[i] == c1[i] && e[i] == e1[i]);
      WalkStart st;
      const bool walks = one.walk_begin(i, st);
      for (std::uint32_t v = 0; v < kN; ++v) {
        const bool in_walk = walks && v < st.total;
        tests_off += tested[i * kN + v] != (in_walk ? 1u : 0u);
        evaluations_off += evaluated[i * kN + v] != (in_walk && one.walk_entry(st, v).kind ? 1u : 0u);
      }
    }
    EXPECT_EQ(differ, 0u) << lanes << " lanes";
    EXPECT_EQ(wrong.load(), 0u) << lanes << " lanes";
    EXPECT_EQ(tests_off, 0u) << lanes << " lanes";
    EXPECT_EQ(evaluations_off, 0u) << lanes << " lanes";
    std::printf("[measured] row walks of %u lanes (%u per walk) sharing their touching contacts vs one thread per "
                "row: %u walks, %zu contacts touching, %zu apart; %zu walks differ, %u wrong, %zu tests and %zu "
                "evaluations off\n",
                lanes, 1u << split_log2, kItems, touching, apart, differ, wrong.load(), tests_off, evaluations_off);
  }
  EXPECT_GT(touching, 2000u);
  EXPECT_GT(apart, 500u);
}

namespace {
/// MadeUpWalkAhead as a walker of the order-free family (kFixedSums, as ForcesFixed): its
/// contacts rounded to a grid that holds the made-up values and added as integers.
struct MadeUpWalkFixed : MadeUpWalkAhead {
  FixedSumArrays fx{nullptr, gpu::fixed::scale_for(1024.0), 1.0 / gpu::fixed::scale_for(1024.0), gpu::fixed::scale_for(1024.0),
                    1.0 / gpu::fixed::scale_for(1024.0), gpu::fixed::limit_for(64)};
  static constexpr bool kFixedSums = true;
  FixedWalkSums walk_sums() const { return FixedWalkSums(fx); }
};
}  // namespace

// The order-free family's row walk shared by lanes (walk_row_lanes_fixed, the path ForcesFixed
// takes on CUDA): each lane adds its contacts l, l + lanes, ... (from the heads it loaded ahead)
// to integer sums, and the lanes' sums are added once, by a butterfly of shuffles. Groups of 1,
// 2, 4, 8, 16 and 32 thread lanes give, bit for bit, the sums of one thread adding the walk's
// contacts as integers (FixedWalkSums in walk order), over walks of 0 to 40 contacts whose
// values span six decades; no wrong head is used, every walk ends once. (With the butterfly's
// last level left out it fails: checked.)
TEST(RowWalkLanes, FixedSumsByLanesGiveTheSumsOfOneThread) {
  constexpr std::uint32_t kItems = 300;
  std::vector<Vec3> f1(kItems, Vec3{-1, -1, -1}), t1(kItems, Vec3{-1, -1, -1});
  std::vector<std::uint32_t> c1(kItems, 12345), e1(kItems, 0);
  std::atomic<std::uint32_t> wrong1{0}, heads1{0};
  MadeUpWalkFixed one;
  static_cast<MadeUpWalk&>(one) = MadeUpWalk{f1.data(), t1.data(), c1.data(), e1.data()};
  one.wrong = &wrong1;
  one.from_heads = &heads1;
  std::size_t contacts = 0;
  for (std::uint32_t i = 0; i < kItems; ++i) {  // one thread, in walk order
    WalkStart st;
    if (!one.walk_begin(i, st)) continue;
    FixedWalkSums sums = one.walk_sums();
    for (std::uint32_t v = 0; v < st.total; ++v) sums.add(one.walk_entry(st, v));
    Vec3 f, t;
    std::uint32_t c = 0;
    sums.finish(f, t, c);
    one.walk_end(i, st, f, t, c);
    contacts += c;
  }
  for (const std::uint32_t lanes : {1u, 2u, 4u, 8u, 16u, 32u}) {
    std::vector<Vec3> f(kItems, Vec3{-1, -1, -1}), t(kItems, Vec3{-1, -1, -1});
    std::vector<std::uint32_t> c(kItems, 12345), e(kItems, 0);
    std::atomic<std::uint32_t> wrong{0}, from_heads{0};
    MadeUpWalkFixed grouped;
    static_cast<MadeUpWalk&>(grouped) = MadeUpWalk{f.data(), t.data(), c.data(), e.data()};
    grouped.wrong = &wrong;
    grouped.from_heads = &from_heads;
    walk_rows_in_thread_lanes(grouped, kItems, lanes);
    std::size_t differ = 0;
    for (std::uint32_t i = 0; i < kItems; ++i)
      differ += !(std::memcmp(&f[i], &f1[i], sizeof(Vec3)) == 0 && std::memcmp(&t[i], &t1[i], sizeof(Vec3)) == 0 &&
                  c[i] == c1[i] && e[i] == e1[i]);
    EXPECT_EQ(differ, 0u) << lanes << " lanes";
    EXPECT_EQ(wrong.load(), 0u) << lanes << " lanes";
    std::printf("[measured] fixed-point row walk with %u lanes vs one thread: %zu walks differ, %u wrong heads\n",
                lanes, differ, wrong.load());
  }
  EXPECT_GT(contacts, 1000u);
  // the integer sums are not the double sums in walk order (the values span six decades)
  std::vector<Vec3> fd(kItems), td(kItems);
  std::vector<std::uint32_t> cd(kItems), ed(kItems, 0);
  const MadeUpWalk dbl{fd.data(), td.data(), cd.data(), ed.data()};
  std::size_t other_bits = 0;
  for (std::uint32_t i = 0; i < kItems; ++i) {
    walk_row(dbl, i);
    other_bits += ed[i] && std::memcmp(&fd[i], &f1[i], sizeof(Vec3)) != 0;
  }
  EXPECT_GT(other_bits, 10u);
}

// 3. A list built with the box of the list check's motion, one step old (Engine::check_list), on
// spheres that have moved since, some outside that box, and some with non-finite or huge
// coordinates (a run becoming unstable): CellOf puts every sphere in a cell of the grid (no cell
// key out of range), and BuildRows and BuildRowsGrouped both give exactly the brute-force rows
// of the finite spheres (periodic minimum image), with no non-finite sphere in any row. Scenes:
// 160 random ones, every combination of periodic and bounded axes, spheres moved since the box
// by up to 0, 0.5, 1 or 1.5 cut-offs.
TEST(RowBuild, StaleBoxAndNonFinitePositionsGiveTheBruteForceRows) {
  std::size_t rows = 0, pairs = 0, outside = 0, out_of_range = 0, bad = 0;
  for (std::uint64_t seed = 0; seed < 160; ++seed) {
    std::mt19937_64 gen(1000 + seed);
    const std::uint32_t n = 60 + static_cast<std::uint32_t>(gen() % 160);
    const double rmax = 0.5, skin = 0.05 + 0.6 * uniform(gen), cut = 2.0 * rmax + skin;
    bool periodic[3];
    double len[3], lo[3];
    for (int k = 0; k < 3; ++k) {
      periodic[k] = (seed >> k) & 1u;
      len[k] = static_cast<double>(3 + gen() % 5) * cut * (1.0 + 0.3 * uniform(gen));
      lo[k] = -3.0 + 6.0 * uniform(gen);
    }
    const double moved = static_cast<double>(seed % 4) * 0.5 * cut;  // since the box was taken
    std::vector<Vec3> pos(n), then(n), zero3(n);
    std::vector<double> radius(n), zero1(n);
    std::vector<std::uint32_t> body(n), sid(n), zero_u(n);
    for (std::uint32_t i = 0; i < n; ++i) {
      for (int k = 0; k < 3; ++k) {
        then[i][k] = lo[k] + uniform(gen) * len[k] +
                     (periodic[k] ? static_cast<double>(static_cast<int>(gen() % 7) - 3) * len[k] : 0.0);
        pos[i][k] = then[i][k] + (2.0 * uniform(gen) - 1.0) * moved;
      }
      radius[i] = rmax * (0.3 + 0.7 * uniform(gen));
      body[i] = i % 4 == 1 ? i - 1 : i;
    }
    if (seed % 5 == 0) {  // a run becoming unstable
      pos[3] = Vec3{std::nan(""), 0.0, 0.0};
      pos[5] = Vec3{HUGE_VAL, HUGE_VAL, -HUGE_VAL};
      pos[7] = Vec3{0.0, -HUGE_VAL, std::nan("")};
      pos[9] = Vec3{1e300, -1e300, 1e200};
    }
    std::iota(sid.begin(), sid.end(), 0u);
    std::shuffle(sid.begin(), sid.end(), gen);
    // The box of the positions `then` (the motion read) and the grid as Engine::build_list.
    Vec3 blo{1e300, 1e300, 1e300}, bhi{-1e300, -1e300, -1e300};
    for (const Vec3& p : then)
      for (int k = 0; k < 3; ++k) {
        blo[k] = std::min(blo[k], p[k]);
        bhi[k] = std::max(bhi[k], p[k]);
      }
    double cell = cut;
    for (int it = 0; it < 64; ++it) {
      double cells = 1.0;
      for (int k = 0; k < 3; ++k) cells *= std::max(1.0, std::floor((periodic[k] ? len[k] : bhi[k] - blo[k]) / cell));
      if (cells <= 4.0 * n + 27.0) break;
      cell *= 1.26;
    }
    GridParams g;
    g.cell = cell;
    int nn[3];
    bool too_short = false;
    for (int k = 0; k < 3; ++k) {
      g.periodic[k] = periodic[k];
      if (periodic[k]) {
        g.lo[k] = lo[k];
        g.period[k] = len[k];
        nn[k] = static_cast<int>(std::floor(len[k] / cell));
        too_short = too_short || nn[k] < 3;  // (the engine refuses these)
      } else {
        g.lo[k] = blo[k];
        nn[k] = std::max(1, static_cast<int>(std::floor((bhi[k] - blo[k]) / cell)) + 1);
      }
    }
    if (too_short) continue;
    g.n = Int3{nn[0], nn[1], nn[2]};
    const std::uint32_t ncell = static_cast<std::uint32_t>(nn[0] * nn[1] * nn[2]);
    const SphereArrays s{pos.data(),    zero3.data(), zero3.data(),  zero3.data(), zero3.data(),
                         zero3.data(),  zero3.data(), radius.data(), zero1.data(), body.data(),
                         zero_u.data(), sid.data(),   zero_u.data()};
    std::vector<std::uint32_t> key(n);
    std::vector<Int3> wrap(n), cells(n);
    const CellOf cell_of{s, g, key.data(), wrap.data(), cells.data()};
    for (std::uint32_t i = 0; i < n; ++i) {
      cell_of(i);
      out_of_range += key[i] >= ncell;
      for (int k = 0; k < 3; ++k)
        outside += !periodic[k] && std::isfinite(pos[i][k]) && (pos[i][k] < blo[k] || pos[i][k] > bhi[k]);
    }
    if (out_of_range) break;
    std::vector<std::uint32_t> sorted(n), sorted_key(n), cell_start(ncell + 1);
    std::iota(sorted.begin(), sorted.end(), 0u);
    std::stable_sort(sorted.begin(), sorted.end(), [&](std::uint32_t a, std::uint32_t b) { return key[a] < key[b]; });
    for (std::uint32_t p = 0; p < n; ++p) sorted_key[p] = key[sorted[p]];
    for (std::uint32_t c = 0; c <= ncell; ++c)
      cell_start[c] = static_cast<std::uint32_t>(std::lower_bound(sorted_key.begin(), sorted_key.end(), c) - sorted_key.begin());
    std::vector<Vec3> p_pos(n);
    std::vector<double> p_radius(n);
    std::vector<std::uint32_t> p_body(n), p_sid(n);
    std::vector<Int3> p_wrap(n);
    const CellPacked packed{p_pos.data(), p_radius.data(), p_body.data(), p_sid.data(), p_wrap.data()};
    const PackByCell pack{s, sorted.data(), wrap.data(), packed};
    for (std::uint32_t p = 0; p < n; ++p) pack(p);
    HostRows none, serial, grouped;
    none.reset(n, 1);
    std::fill(none.length.begin(), none.length.end(), 0u);
    serial.reset(n, 128);
    grouped.reset(n, 128);
    const RowBuildArgs a{s, g, sorted.data(), cell_start.data(), packed, wrap.data(), cells.data(), none.arrays(),
                         serial.arrays(), n, skin, nullptr};
    RowBuildArgs b = a;
    b.rows = grouped.arrays();
    const BuildRows build_serial{a};
    const BuildRowsGrouped build_grouped{b};
    for (std::uint32_t i = 0; i < n; ++i) {
      build_serial(i);
      build_grouped(i);
    }
    auto sane = [&](std::uint32_t q) {
      return std::abs(pos[q].x) < 1e10 && std::abs(pos[q].y) < 1e10 && std::abs(pos[q].z) < 1e10;
    };
    for (std::uint32_t i = 0; i < n; ++i) {
      std::vector<std::uint32_t> want;
      for (std::uint32_t j = 0; j < n && sane(i); ++j) {
        if (body[j] == body[i] || !sane(j)) continue;
        Vec3 dv = pos[i] - pos[j];
        for (int k = 0; k < 3; ++k)
          if (periodic[k]) dv[k] -= len[k] * std::round(dv[k] / len[k]);
        const double c = radius[i] + radius[j] + skin;
        if (norm2(dv) < c * c) want.push_back(j);
      }
      std::sort(want.begin(), want.end());
      auto row = [&](const HostRows& r) {
        std::vector<std::uint32_t> got;
        for (std::uint32_t q = 0; q < r.length[i] && q < r.cap; ++q) got.push_back(r.j[static_cast<std::size_t>(q) * n + i]);
        std::sort(got.begin(), got.end());
        return got;
      };
      ++rows;
      pairs += want.size();
      const bool ok = serial.length[i] <= 128 && row(serial) == want && row(grouped) == want &&
                      grouped.length[i] == serial.length[i];
      if (!ok && bad++ < 5)
        ADD_FAILURE() << "seed " << seed << " row " << i << ": " << want.size() << " neighbours by brute force, "
                      << serial.length[i] << " and " << grouped.length[i] << " in the rows";
    }
  }
  std::printf("[measured] lists from a stale box: %zu rows, %zu neighbours, %zu sphere coordinates outside the box, "
              "%zu cell keys out of range, %zu rows unlike brute force\n",
              rows, pairs, outside, out_of_range, bad);
  EXPECT_EQ(out_of_range, 0u);
  EXPECT_EQ(bad, 0u);
  EXPECT_GT(outside, 500u) << "spheres must have left the box for the test to mean anything";
  EXPECT_GT(pairs, 10000u);
}

// 4. The entry kernels' per-sphere sums as a row walk (SumEntriesWalk, BIODEM_GPU_SUM_LANES; on
// CUDA a group of row lanes per sphere) against SumEntries (one thread loading the row's entries
// eight at a time): force, torque and contact count of every sphere bit for bit, with groups of
// 1 (walk_row), 4, 16 and 32 lanes. Random entry buffers: rows of 0 to 40 entries (capacity 40),
// random touching flags and stable ids (so both sides of pairs), three walls with random
// touching flags, values spanning six decades (any other order of the additions gives other
// bits), entries past a row's length and untouched slots filled with values that must not count.
TEST(RowWalkLanes, EntrySumsByLanesGiveTheBitsOfSumEntries) {
  constexpr std::uint32_t n = 257, cap = 40, walls = 3;
  std::mt19937_64 gen(20261126);
  std::uniform_int_distribution<std::uint32_t> len_of(0, cap), sid_of(0, 100000), coin(0, 1);
  auto value = [&gen] {
    std::uniform_real_distribution<double> u(-0.5, 0.5);
    std::uniform_int_distribution<int> e(-10, 10);
    return std::ldexp(u(gen), e(gen));
  };
  std::vector<std::uint32_t> sid(n), length(n), row_sid(n * cap), contacts(n, 12345), zero_u(n, 0);
  std::vector<std::uint8_t> touching(n * cap), wall_touching(n * walls);
  std::vector<Vec3> ef(n * cap), et(n * cap), wf(n * walls), wt(n * walls), zero3(n), force(n), torque(n);
  std::vector<double> zero1(n, 0.0);
  for (std::uint32_t a = 0; a < n; ++a) {
    sid[a] = sid_of(gen);
    length[a] = len_of(gen);
  }
  std::size_t counted = 0;
  for (std::uint32_t k = 0; k < n * cap; ++k) {
    row_sid[k] = sid_of(gen);
    touching[k] = static_cast<std::uint8_t>(coin(gen));
    ef[k] = Vec3{value(), value(), value()};
    et[k] = Vec3{value(), value(), value()};
    counted += touching[k] && k / n < length[k % n];
  }
  for (std::uint32_t k = 0; k < n * walls; ++k) {
    wall_touching[k] = static_cast<std::uint8_t>(coin(gen));
    wf[k] = Vec3{value(), value(), value()};
    wt[k] = Vec3{value(), value(), value()};
  }
  auto args = [&](std::vector<Vec3>& f, std::vector<Vec3>& t, std::vector<std::uint32_t>& c) {
    ContactArgs a{};
    a.s = SphereArrays{zero3.data(), zero3.data(), zero3.data(), zero3.data(), f.data(),   t.data(),     zero3.data(),
                       zero1.data(), zero1.data(), zero_u.data(), zero_u.data(), sid.data(), c.data()};
    a.rows = RowArrays{nullptr,   row_sid.data(), nullptr,   touching.data(), nullptr,   length.data(),
                       cap,       nullptr,        ef.data(), et.data(),       wf.data(), wt.data()};
    a.wall_touching = wall_touching.data();
    a.n_walls = walls;
    a.n = n;
    a.halt = Halt{};
    return a;
  };
  std::vector<Vec3> f1(n), t1(n);
  std::vector<std::uint32_t> c1(n, 12345);
  const SumEntries<false, false> one{args(f1, t1, c1)};
  for (std::uint32_t a = 0; a < n; ++a) one(a);
  for (const std::uint32_t lanes : {1u, 4u, 16u, 32u}) {
    std::vector<Vec3> f(n, Vec3{-1, -1, -1}), t(n, Vec3{-1, -1, -1});
    std::vector<std::uint32_t> c(n, 12345);
    const SumEntriesWalk walk{args(f, t, c)};
    if (lanes == 1) {
      for (std::uint32_t a = 0; a < n; ++a) walk(a);
    } else {
      walk_rows_in_thread_lanes(walk, n, lanes);
    }
    std::size_t differ = 0;
    for (std::uint32_t a = 0; a < n; ++a)
      differ += !(std::memcmp(&f[a], &f1[a], sizeof(Vec3)) == 0 && std::memcmp(&t[a], &t1[a], sizeof(Vec3)) == 0 &&
                  c[a] == c1[a]);
    EXPECT_EQ(differ, 0u) << lanes << " lanes";
    std::printf("[measured] entry sums by %u lanes vs SumEntries: %u spheres, %zu touching entries, %zu differ\n", lanes,
                n, counted, differ);
  }
  std::size_t counts = 0;
  for (std::uint32_t a = 0; a < n; ++a) counts += c1[a];
  EXPECT_GT(counted, 2000u);
  EXPECT_GT(counts, counted / 4);  // (pairs counted by their lower-id side, walls always)
}

namespace {

/// Bodies of 1 to 11 spheres (some single spheres at their centre, some off it) with random
/// state, inertia, sphere offsets, forces, torques and centres, in flat arrays as the engine
/// holds them, with or without sphere records.
struct MadeUpClumps {
  std::vector<Vec3> bx, bv, bw, bl, bf, bt, bi;
  std::vector<Quat> bq;
  std::vector<double> bm;
  std::vector<std::uint32_t> first, count;
  std::vector<Vec3> sx, sv, sw, so, sf, st, sb;
  std::vector<double> sr, smass;
  std::vector<std::uint32_t> sbody, smat, ssid, scont;
  std::vector<SphereRecord> rec;
  explicit MadeUpClumps(std::uint32_t bodies, bool records) {
    std::mt19937_64 g(77);
    auto u = [&g] { return static_cast<double>(g() >> 11) * 0x1.0p-53 - 0.5; };
    auto v3 = [&u](double s) { return Vec3{s * u(), s * u(), s * u()}; };
    for (std::uint32_t k = 0; k < bodies; ++k) {
      const std::uint32_t n = k % 5 == 0 ? 1u : 1u + static_cast<std::uint32_t>(g() % 11);
      first.push_back(static_cast<std::uint32_t>(sx.size()));
      count.push_back(n);
      bx.push_back(v3(0.1));
      bv.push_back(v3(1.0));
      bw.push_back(v3(50.0));
      bl.push_back(v3(1e-6));
      bf.push_back(v3(1e-3));
      bt.push_back(v3(1e-6));
      bi.push_back(n == 1 ? Vec3{2e-9, 2e-9, 2e-9} : Vec3{1e-9 + 1e-9 * std::abs(u()), 2e-9, 3e-9 + 1e-9 * std::abs(u())});
      bq.push_back(normalized(Quat{u(), u(), u(), u()}));
      bm.push_back(1e-5 * (1.0 + std::abs(u())));
      for (std::uint32_t c = 0; c < n; ++c) {
        sx.push_back(bx.back() + v3(1e-3));
        sv.push_back(v3(1.0));
        sw.push_back(v3(50.0));
        so.push_back(n == 1 && k % 10 == 0 ? Vec3{} : v3(2e-3));
        sf.push_back(v3(1e-2));
        st.push_back(v3(1e-5));
        sb.push_back(Vec3{});
        sr.push_back(5e-4);
        smass.push_back(bm.back());
        sbody.push_back(k);
        smat.push_back(0);
        ssid.push_back(static_cast<std::uint32_t>(ssid.size()));
        scont.push_back(0);
      }
    }
    if (records)
      for (std::size_t i = 0; i < sx.size(); ++i) rec.push_back(SphereRecord{sx[i], sr[i], sv[i], smass[i], sw[i], 0u, 0u});
  }
  ReduceKickDrift kernel() {
    ReduceKickDrift r{};
    r.b = BodyArrays{bx.data(), bv.data(), bw.data(), bl.data(), bf.data(), bt.data(), bi.data(), bq.data(), bm.data(),
                     first.data(), count.data()};
    r.s = SphereArrays{sx.data(), sv.data(),   sw.data(),    so.data(),   sf.data(),   st.data(),   sb.data(),
                       sr.data(), smass.data(), sbody.data(), smat.data(), ssid.data(), scont.data(),
                       rec.empty() ? nullptr : rec.data()};
    r.gravity = Vec3{0, -9.81, 0};
    r.h = 0.5e-5;
    r.dt = 1e-5;
    r.halt = Halt{};
    r.centred = false;
    return r;
  }
  std::string first_difference(const MadeUpClumps& o) const {
    auto same = [](const auto& a, const auto& b) {
      return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(a[0])) == 0;
    };
    const std::pair<const char*, bool> checks[] = {
        {"body centre", same(bx, o.bx)},      {"body velocity", same(bv, o.bv)}, {"body spin", same(bw, o.bw)},
        {"angular momentum", same(bl, o.bl)}, {"orientation", same(bq, o.bq)},  {"body force", same(bf, o.bf)},
        {"body torque", same(bt, o.bt)},      {"sphere centre", same(sx, o.sx)}, {"sphere velocity", same(sv, o.sv)},
        {"sphere spin", same(sw, o.sw)},      {"records", same(rec, o.rec)}};
    for (const auto& [what, ok] : checks)
      if (!ok) return what;
    return "";
  }
};

}  // namespace

// The clumps' fused body kernel by a group of lanes per body (ReduceKickDriftLanes, what
// BIODEM_GPU_BODY_LANES runs on CUDA) with groups of 1, 2, 4, 8 and 32 thread lanes: bodies of 1
// to 11 spheres stepped three times give the bits of ReduceKickDrift in one thread per body,
// in every body and sphere array and in the spheres' records. (It fails without the group's
// sync before the stores, when the lanes take the first sphere's offset for their own, and when
// they skip every other round of spheres: checked, each in three runs.)
TEST(BodyLanes, GroupsOfThreadLanesGiveTheBitsOfReduceKickDrift) {
  constexpr std::uint32_t kBodies = 120;
  for (const bool records : {false, true}) {
    MadeUpClumps one(kBodies, records);
    const ReduceKickDrift r1 = one.kernel();
    for (int step = 0; step < 3; ++step)
      for (std::uint32_t k = 0; k < kBodies; ++k) r1(k);
    std::size_t spheres = one.sx.size(), turned = 0;
    for (std::uint32_t k = 0; k < kBodies; ++k) turned += one.count[k] > 1;
    for (const std::uint32_t lanes : {1u, 2u, 4u, 8u, 32u}) {
      MadeUpClumps grouped(kBodies, records);
      const ReduceKickDriftLanes rl{grouped.kernel()};
      for (int step = 0; step < 3; ++step)
        in_thread_lanes(kBodies, lanes, [&](std::uint32_t k, const ThreadLanes& me) { rl.run(k, me); });
      EXPECT_EQ(grouped.first_difference(one), "") << lanes << " lanes" << (records ? ", records" : "");
      std::printf("[measured] clumps' body kernel by %u lanes vs one thread%s: %u bodies (%zu turning), %zu spheres, "
                  "3 steps: %s\n",
                  lanes, records ? " (records)" : "", kBodies, turned, spheres,
                  grouped.first_difference(one).empty() ? "bit-identical" : "differ");
    }
    // (the bodies moved and turned: the comparison is of changed state)
    MadeUpClumps start(kBodies, records);
    EXPECT_NE(start.first_difference(one), "");
    EXPECT_GT(turned, kBodies / 2);
  }
}

namespace {

/// A made-up walk for WalkKickGroups: sphere a's force, torque and contact count from its own
/// motion and a far sphere's centre (another body's, so that a placement into the buffer the
/// walks read would show), stored in s as Forces' walk stores them.
struct SpringWalk {
  SphereArrays s;
  std::uint32_t n = 0;
  void operator()(std::uint32_t a) const {
    const Vec3 d = s.position[a] - s.position[(7 * a + 3) % n];
    s.force[a] = 1e-2 * d + 1e-4 * s.velocity[a];
    s.torque[a] = 1e-6 * cross(d, s.omega[a]);
    s.contacts[a] = a % 4;
  }
};

}  // namespace

namespace {

/// Three steps of a walk with the body update in two buffers of the sphere motion, as the engine
/// runs ForcesKickDriftGroups: step s reads the motion of `fused` (even s) or `other` (odd s),
/// with fused's body arrays, forces and offsets, and places the spheres in the other buffer;
/// `step(walk_s, rk)` runs one step from the walk's sphere arrays and the body kernel. Afterwards
/// the motion (in the second buffer after three steps) is copied into `fused`.
template <class Step>
void three_steps_in_two_buffers(MadeUpClumps& fused, MadeUpClumps& other, bool records, const Step& step) {
  for (int s = 0; s < 3; ++s) {
    MadeUpClumps& from = s % 2 == 0 ? fused : other;
    MadeUpClumps& to = s % 2 == 0 ? other : fused;
    ReduceKickDrift rk = fused.kernel();
    SphereArrays walk_s = rk.s;
    walk_s.position = from.sx.data();
    walk_s.velocity = from.sv.data();
    walk_s.omega = from.sw.data();
    walk_s.record = records ? from.rec.data() : nullptr;
    rk.s.position = to.sx.data();
    rk.s.velocity = to.sv.data();
    rk.s.omega = to.sw.data();
    rk.s.record = records ? to.rec.data() : nullptr;
    step(walk_s, rk);
  }
  fused.sx = other.sx;
  fused.sv = other.sv;
  fused.sw = other.sw;
  fused.rec = other.rec;
}

/// The spheres' forces, torques and contact counts of a and b: bit-identical?
bool same_sphere_sums(const MadeUpClumps& a, const MadeUpClumps& b) {
  const std::size_t n = a.sx.size();
  return std::memcmp(a.sf.data(), b.sf.data(), n * sizeof(Vec3)) == 0 &&
         std::memcmp(a.st.data(), b.st.data(), n * sizeof(Vec3)) == 0 && a.scont == b.scont;
}

}  // namespace

// The clumps' row walk with the body update by a group of lanes per body (WalkKickGroups, what
// ForcesKickDriftGroups runs on CUDA; the walk here a made-up one) with groups of 1, 2, 4, 8 and
// 16 thread lanes: bodies of 1 to 11 spheres stepped three times, the walks reading one buffer
// of the sphere motion and the spheres placed in the other (swapped every step), give the bits
// of the walk over every sphere then ReduceKickDrift in one thread per body in place, in every
// body and sphere array, the spheres' forces and the records. (It fails without the group's sync
// between the walks and the sums, and when the sums read the buffer the spheres are placed in:
// checked.)
TEST(BodyLanes, WalkAndBodyUpdateByGroupsGiveTheBitsOfTheTwoKernels) {
  constexpr std::uint32_t kBodies = 120;
  for (const bool records : {false, true}) {
    MadeUpClumps one(kBodies, records);
    const std::uint32_t n = static_cast<std::uint32_t>(one.sx.size());
    const ReduceKickDrift r1 = one.kernel();
    const SpringWalk w1{r1.s, n};
    for (int step = 0; step < 3; ++step) {
      for (std::uint32_t a = 0; a < n; ++a) w1(a);
      for (std::uint32_t k = 0; k < kBodies; ++k) r1(k);
    }
    for (const std::uint32_t lanes : {1u, 2u, 4u, 8u, 16u}) {
      MadeUpClumps fused(kBodies, records), other(kBodies, records);  // (other: the second buffer's motion)
      three_steps_in_two_buffers(fused, other, records, [&](const SphereArrays& walk_s, const ReduceKickDrift& rk) {
        const WalkKickGroups<SpringWalk> g{SpringWalk{walk_s, n}, ReduceKickDriftLanes{rk}};
        in_thread_lanes(kBodies, lanes, [&](std::uint32_t k, const ThreadLanes& me) { g.run(k, me); });
      });
      EXPECT_EQ(fused.first_difference(one), "") << lanes << " lanes" << (records ? ", records" : "");
      const bool same_forces = same_sphere_sums(fused, one);
      EXPECT_TRUE(same_forces) << lanes << " lanes: the spheres' sums";
      std::printf("[measured] clumps' walk with the body update by %u lanes vs the walk then ReduceKickDrift%s: "
                  "%u bodies, %u spheres, 3 steps: %s\n",
                  lanes, records ? " (records)" : "", kBodies, n,
                  fused.first_difference(one).empty() && same_forces ? "bit-identical" : "differ");
    }
    MadeUpClumps start(kBodies, records);
    EXPECT_NE(start.first_difference(one), "");  // (the comparison is of changed state)
  }
}

namespace {

/// A made-up row walk for WalkKickGroups::run_packed (the interface of Forces that walk_packed
/// uses): sphere a's walk has a % 6 contacts, the last a wall when there are more than two; pair
/// entry v's neighbour is sphere (7 a + 3 + 5 v) mod n, a contact touching unless (a + v) is a
/// multiple of 3, its force from the two centres (read from the walk's buffer) and a's velocity
/// and spin; a touching contact evaluated apart, or the head of another entry, gives a force
/// that changes the sums (and is counted). walk_end stores a's sums as Forces does.
struct SpringRowWalk {
  SphereArrays s;
  std::uint32_t n = 0;
  std::atomic<std::uint32_t>* wrong = nullptr;
  struct Head {
    std::uint32_t b = ~0u, v = ~0u;
  };
  bool walk_begin(std::uint32_t a, WalkStart& st) const {
    st.a = a;
    st.sid_a = a;
    st.total = a % 6;
    st.len = st.total > 2 ? st.total - 1 : st.total;
    return true;
  }
  std::uint32_t head_limit() const { return 8; }
  Head walk_head(std::uint32_t a, std::uint32_t v) const { return Head{(7 * a + 3 + 5 * v) % n, v}; }
  bool touching(const WalkStart& st, std::uint32_t v) const { return (st.a + v) % 3 != 0; }
  RowContact contact(const WalkStart& st, std::uint32_t v, std::uint32_t b) const {
    RowContact r;
    if (v >= st.total || !touching(st, v)) return r;
    const Vec3 d = s.position[st.a] - (v < st.len ? s.position[b] : Vec3{0.01, -0.02, 0.03});
    r.force = static_cast<double>(v + 1) * 1e-2 * d + 1e-4 * s.velocity[st.a];
    r.torque = 1e-6 * cross(d, s.omega[st.a]);
    r.kind = v >= st.len ? 3u : (st.a < b ? 1u : 2u);
    return r;
  }
  RowContact walk_entry(const WalkStart& st, std::uint32_t v) const {
    return contact(st, v, v < st.len ? walk_head(st.a, v).b : 0u);
  }
  bool walk_touches_from(const WalkStart& st, std::uint32_t v, const Head& h) const {
    if (h.v != v || h.b != walk_head(st.a, v).b) ++*wrong;
    return touching(st, v);
  }
  bool walk_touches(const WalkStart& st, std::uint32_t v) const { return touching(st, v); }
  RowContact walk_entry_from(const WalkStart& st, std::uint32_t v, const Head& h) const {
    if (!touching(st, v)) {
      ++*wrong;
      RowContact r;
      r.kind = 1;
      r.force = Vec3{1e30, 1e30, 1e30};
      return r;
    }
    return contact(st, v, h.b);
  }
  void walk_end(std::uint32_t a, const WalkStart&, const Vec3& f, const Vec3& t, std::uint32_t c) const {
    s.force[a] = f;
    s.torque[a] = t;
    s.contacts[a] = c;
  }
};

}  // namespace

// The clumps' row walk with the body update by a group of lanes per body whose walks share the
// warp's touching contacts (WalkKickGroups::run_packed, what for_each_packed_group runs on CUDA
// with BIODEM_GPU_WALK_PACK=1; the walk here a made-up one with pair entries and a wall), with
// warps of 32 thread lanes in groups of 1, 2, 4, 8 and 16 lanes per body (bodies of 1 to 11
// spheres: with fewer lanes than spheres the warp walks in several rounds; the last warp partly
// past the bodies), stepped three times with the two buffers swapped, give the bits of the walk
// by one thread per sphere then ReduceKickDrift in one thread per body, in every body and sphere
// array, the spheres' sums and the records. (It fails when the rounds stop after the groups'
// first round of spheres: checked. The group's sync after the walks it cannot check: here the
// warp's last ballot of the rounds, a barrier of the thread lanes, orders the walks' stores
// before the body sums' loads; on a GPU a ballot does not order memory, the sync does.)
TEST(BodyLanes, WalkWithTheWarpsTouchingContactsSharedAndBodyUpdateGiveTheBitsOfTheTwoKernels) {
  constexpr std::uint32_t kBodies = 120;
  for (const bool records : {false, true}) {
    MadeUpClumps one(kBodies, records);
    const std::uint32_t n = static_cast<std::uint32_t>(one.sx.size());
    std::atomic<std::uint32_t> wrong{0};
    {
      const ReduceKickDrift r1 = one.kernel();
      const SpringRowWalk w1{r1.s, n, &wrong};
      for (int step = 0; step < 3; ++step) {
        for (std::uint32_t a = 0; a < n; ++a) walk_row(w1, a);
        for (std::uint32_t k = 0; k < kBodies; ++k) r1(k);
      }
    }
    for (const std::uint32_t lanes : {1u, 2u, 4u, 8u, 16u}) {
      MadeUpClumps fused(kBodies, records), other(kBodies, records);  // (other: the second buffer's motion)
      const std::uint32_t per_warp = 32 / lanes, warps = (kBodies + per_warp - 1) / per_warp;
      three_steps_in_two_buffers(fused, other, records, [&](const SphereArrays& walk_s, const ReduceKickDrift& rk) {
        const WalkKickGroups<SpringRowWalk> g{SpringRowWalk{walk_s, n, &wrong}, ReduceKickDriftLanes{rk}};
        // a warp of 32 thread lanes, each group of `lanes` of them a body's
        GroupState warp_state(32);
        std::vector<std::unique_ptr<GroupState>> group_state;
        for (std::uint32_t q = 0; q < per_warp; ++q) group_state.push_back(std::make_unique<GroupState>(lanes));
        PackedWalkScratch<SpringRowWalk::Head> scratch;
        std::vector<std::thread> team;
        for (std::uint32_t t = 0; t < 32; ++t)
          team.emplace_back([&, t] {
            const ThreadLanes warp{&warp_state, t, 32}, grp{group_state[t / lanes].get(), t % lanes, lanes};
            for (std::uint32_t w = 0; w < warps; ++w) {
              const std::uint32_t k = w * per_warp + t / lanes;
              g.run_packed(k, k < kBodies, grp, warp, scratch);
              warp.sync();  // (on a GPU each warp has a scratch of its own)
            }
          });
        for (auto& th : team) th.join();
      });
      EXPECT_EQ(fused.first_difference(one), "") << lanes << " lanes" << (records ? ", records" : "");
      const bool same_forces = same_sphere_sums(fused, one);
      EXPECT_TRUE(same_forces) << lanes << " lanes: the spheres' sums";
      std::printf("[measured] clumps' walk sharing the warp's touching contacts, with the body update by %u lanes, vs the "
                  "walk then ReduceKickDrift%s: %u bodies, %u spheres, 3 steps: %s\n",
                  lanes, records ? " (records)" : "", kBodies, n,
                  fused.first_difference(one).empty() && same_forces ? "bit-identical" : "differ");
    }
    EXPECT_EQ(wrong.load(), 0u) << (records ? "records" : "arrays");
    std::uint32_t contacts = 0;
    for (std::uint32_t a = 0; a < n; ++a) contacts += one.scont[a];
    EXPECT_GT(contacts, 100u);
    MadeUpClumps start(kBodies, records);
    EXPECT_NE(start.first_difference(one), "");  // (the comparison is of changed state)
  }
}
