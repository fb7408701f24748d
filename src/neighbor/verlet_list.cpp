#include "neighbor/verlet_list.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <omp.h>

#include "core/error.hpp"
#include "core/parallel.hpp"
#include "core/spin_team.hpp"
#include "neighbor/candidate_scan.hpp"

namespace biodem::neighbor {
namespace {

struct Grid {
  std::array<int, 3> n{1, 1, 1};
  Vec3 lo;
  double cell = 1.0;
  std::vector<std::uint32_t> start;  // cell -> first item
  std::vector<std::uint32_t> items;  // sphere indices sorted by cell
  std::vector<std::array<int, 3>> cell_of;
  std::vector<std::array<int, 3>> wrap_of;  // periodic image index of each sphere (floor((x-lo)/L))
  std::size_t index(int x, int y, int z) const {
    return (static_cast<std::size_t>(z) * n[1] + y) * n[0] + x;
  }
};

Grid make_grid(const state::SphereStore& s, const Domain& dom, double cutoff) {
  Grid g;
  const std::size_t n = s.size();
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (std::size_t i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) {
      const double x = s.position_m[i][k];
      if (!std::isfinite(x))
        throw Error("sphere " + std::to_string(i) +
                    " has a non-finite position: the simulation became unstable (is [run].dt_s too large?)");
      lo[k] = std::min(lo[k], x);
      hi[k] = std::max(hi[k], x);
    }
  const Vec3 len = dom.length_m();
  // Cap the number of cells at ~4 per sphere (sparse scenes) by enlarging the cell if needed.
  double cell = cutoff;
  // (Up to 4096 enlargements: enough for any finite extent, so a far-away sphere cannot make the
  // grid, or a cell index, exceed what an int holds.)
  // Cells along a periodic axis: a whole number of at least the cut-off, as many as cells of the
  // other axes' size fit, but never fewer than 3 while the period holds 3 cut-offs (so that a
  // sparse bed, or a sphere far away on another axis, coarsening the cells does not make the
  // period too short for the list).
  auto periodic_cells = [&](int k, double c) {
    return std::max(std::min(3.0, std::floor(len[k] / cutoff)), std::floor(len[k] / c));
  };
  for (int iter = 0; iter < 4096; ++iter) {
    double cells = 1.0;
    for (int k = 0; k < 3; ++k)
      cells *= std::max(1.0, dom.periodic[k] ? periodic_cells(k, cell) : std::floor((hi[k] - lo[k]) / cell));
    if (cells <= 4.0 * static_cast<double>(std::max<std::size_t>(n, 1)) + 27.0) break;
    cell *= 1.26;
  }
  g.cell = cell;
  for (int k = 0; k < 3; ++k) {
    if (dom.periodic[k]) {
      g.lo[k] = dom.lo_m[k];
      g.n[k] = static_cast<int>(periodic_cells(k, cell));
      if (g.n[k] < 3)
        throw Error("periodic length along axis " + std::to_string(k) +
                    " is shorter than 3 neighbour cells (largest sphere diameter + skin)");
    } else {
      g.lo[k] = lo[k];
      g.n[k] = static_cast<int>(std::clamp(std::floor((hi[k] - lo[k]) / cell) + 1.0, 1.0, 1e9));
    }
  }
  const std::size_t ncell = static_cast<std::size_t>(g.n[0]) * g.n[1] * g.n[2];
  g.cell_of.resize(n);
  g.wrap_of.assign(n, {0, 0, 0});
  std::vector<std::uint32_t> count(ncell + 1, 0);
  for (std::size_t i = 0; i < n; ++i) {
    std::array<int, 3> c{};
    for (int k = 0; k < 3; ++k) {
      double x = s.position_m[i][k] - g.lo[k];
      if (dom.periodic[k]) {
        const double w = std::floor(x / len[k]);
        // Image shifts are stored in 8 bits (pack_image): a sphere that has gone round a periodic
        // axis more than 60 times cannot be represented; stop rather than give wrong pairs.
        if (!(std::abs(w) <= 60.0))
          throw Error("sphere " + std::to_string(i) + " is " + std::to_string(w) + " periodic lengths away along axis " +
                      std::to_string(k) + " (at most 60 are supported)");
        g.wrap_of[i][k] = static_cast<int>(w);
        x -= w * len[k];
        c[k] = std::min(g.n[k] - 1, static_cast<int>(x / (len[k] / g.n[k])));
      } else {
        c[k] = static_cast<int>(std::clamp(x / cell, 0.0, static_cast<double>(g.n[k] - 1)));
      }
    }
    g.cell_of[i] = c;
    ++count[g.index(c[0], c[1], c[2]) + 1];
  }
  std::partial_sum(count.begin(), count.end(), count.begin());
  g.start = count;
  g.items.resize(n);
  std::vector<std::uint32_t> fill(count.begin(), count.end() - 1);
  for (std::size_t i = 0; i < n; ++i) {
    const auto& c = g.cell_of[i];
    g.items[fill[g.index(c[0], c[1], c[2])]++] = static_cast<std::uint32_t>(i);
  }
  return g;
}

std::int32_t pack_image(int sx, int sy, int sz) {
  return (static_cast<std::int32_t>(static_cast<std::uint8_t>(static_cast<std::int8_t>(sx)))) |
         (static_cast<std::int32_t>(static_cast<std::uint8_t>(static_cast<std::int8_t>(sy))) << 8) |
         (static_cast<std::int32_t>(static_cast<std::uint8_t>(static_cast<std::int8_t>(sz))) << 16);
}

/// Calls f(lo, hi, wrap) for the items [lo, hi) of the 27 cells around cell ci, with the
/// periodic image (-1, 0, 1 per axis) under which they are seen from ci. Along a non-periodic x
/// the three cells of a row are adjacent in the item order and come as one range.
template <class F>
void for_each_cell_around(const Grid& g, const Domain& dom, const std::array<int, 3>& ci, F&& f) {
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy) {
      int c[3] = {0, ci[1] + dy, ci[2] + dz}, wrap[3] = {0, 0, 0};
      bool skip = false;
      for (int k = 1; k < 3; ++k)
        if (c[k] < 0 || c[k] >= g.n[k]) {
          if (!dom.periodic[k]) { skip = true; break; }
          wrap[k] = c[k] < 0 ? -1 : 1;
          c[k] -= wrap[k] * g.n[k];
        }
      if (skip) continue;
      if (!dom.periodic[0]) {
        const int x0 = std::max(ci[0] - 1, 0), x1 = std::min(ci[0] + 1, g.n[0] - 1);
        f(g.start[g.index(x0, c[1], c[2])], g.start[g.index(x1, c[1], c[2]) + 1], wrap);
        continue;
      }
      for (int dx = -1; dx <= 1; ++dx) {
        c[0] = ci[0] + dx;
        wrap[0] = c[0] < 0 ? -1 : (c[0] >= g.n[0] ? 1 : 0);
        c[0] -= wrap[0] * g.n[0];
        const std::size_t cell = g.index(c[0], c[1], c[2]);
        f(g.start[cell], g.start[cell + 1], wrap);
      }
    }
}

}  // namespace

void VerletList::build(const state::SphereStore& s) {
  const std::size_t n = s.size();
  double r_max = 0.0;
  for (double r : s.radius_m) r_max = std::max(r_max, r);
  const Grid g = make_grid(s, domain_, 2.0 * r_max + skin_m_);
  const Vec3 len = domain_.length_m();

  // What the candidate scan reads, in cell order (contiguous loads while a row of cells is
  // scanned).
  scan_x_.resize(n);
  scan_y_.resize(n);
  scan_z_.resize(n);
  scan_r_.resize(n);
  scan_body_.resize(n);
  constexpr std::size_t kChunk = 256;
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  const int threads = n >= kParallelThreshold ? omp_get_max_threads() : 1;
  for_each_index(threads, chunks, [&](std::size_t c) {
    for (std::size_t p = c * kChunk; p < std::min(n, (c + 1) * kChunk); ++p) {
      const std::uint32_t q = g.items[p];
      scan_x_[p] = s.position_m[q].x;
      scan_y_[p] = s.position_m[q].y;
      scan_z_[p] = s.position_m[q].z;
      scan_r_[p] = s.radius_m[q];
      scan_body_[p] = s.body[q];
    }
  });
  const bool periodic = domain_.any_periodic();

  // Pass 1: the rows of each chunk of spheres into the chunk's buffer (kept from build to build:
  // no allocation once the buffers have grown), each row sorted by j; row_len_ holds their sizes.
  if (chunk_rows_.size() < chunks) chunk_rows_.resize(chunks);
  row_len_.resize(n);
  // Along non-periodic axes a range of candidates is scanned by best_candidate_scan() (eight at
  // a time with AVX-512F); periodic ranges, which need image shifts, by the loop below. The
  // buffers' size is their storage; `used` counts the rows' entries.
  const ScanFn scan = best_candidate_scan();
  const ScanArrays arrays{g.items.data(), scan_x_.data(), scan_y_.data(), scan_z_.data(), scan_r_.data(),
                          scan_body_.data()};
  for_each_index(threads, chunks, [&](std::size_t c) {
    auto& buf = chunk_rows_[c].rows;
    std::size_t used = 0;
    const std::size_t i1 = std::min(n, (c + 1) * kChunk);
    for (std::size_t i = c * kChunk; i < i1; ++i) {
      const std::size_t row0 = used;
      const Vec3 xi = s.position_m[i];
      const double ri = s.radius_m[i];
      const std::uint32_t bi = s.body[i];
      const auto ii = static_cast<std::uint32_t>(i);
      if (!periodic) {
        ScanRanges ranges;
        for_each_cell_around(g, domain_, g.cell_of[i], [&](std::uint32_t lo, std::uint32_t hi, const int*) {
          ranges.lo[ranges.count] = lo;
          ranges.hi[ranges.count++] = hi;
          ranges.slots += hi - lo;
        });
        if (buf.size() < used + ranges.slots + 8) buf.resize(std::max(2 * buf.size(), used + ranges.slots + 64));
        used += scan(arrays, ranges, ScanQuery{xi.x, xi.y, xi.z, ri, skin_m_, ii, bi}, buf.data() + used);
      } else {
        for_each_cell_around(g, domain_, g.cell_of[i], [&](std::uint32_t lo, std::uint32_t hi, const int* wrap) {
          if (buf.size() < used + (hi - lo)) buf.resize(std::max(2 * buf.size(), used + (hi - lo) + 64));
          for (std::uint32_t p = lo; p < hi; ++p) {
            const std::uint32_t jj = g.items[p];
            if (jj <= ii || scan_body_[p] == bi) continue;
            int sh[3] = {0, 0, 0};
            Vec3 d = xi - Vec3{scan_x_[p], scan_y_[p], scan_z_[p]};
            for (int k = 0; k < 3; ++k)
              if (domain_.periodic[k]) {
                sh[k] = g.wrap_of[i][k] - g.wrap_of[jj][k] + wrap[k];
                d[k] -= sh[k] * len[k];
              }
            const double cut = ri + scan_r_[p] + skin_m_;
            if (norm2(d) < cut * cut) buf[used++] = {jj, pack_image(sh[0], sh[1], sh[2])};
          }
        });
      }
      std::sort(buf.begin() + static_cast<std::ptrdiff_t>(row0), buf.begin() + static_cast<std::ptrdiff_t>(used),
                [](const RowEntry& a, const RowEntry& b) { return a.j != b.j ? a.j < b.j : a.image < b.image; });
      row_len_[i] = static_cast<std::uint32_t>(used - row0);
    }
  });

  // Pass 2: CSR, carrying history over from the previous list (rows sorted by j: merge).
  std::vector<std::uint32_t> new_start(n + 1, 0);
  for (std::size_t i = 0; i < n; ++i) new_start[i + 1] = new_start[i] + row_len_[i];
  const std::size_t m = new_start[n];
  // The new arrays reuse the previous build's (kept as spares): every element is written below,
  // by the parallel merge, so nothing is cleared serially here.
  std::vector<std::uint32_t>& new_j = spare_j_;
  std::vector<std::int32_t>& new_image = spare_image_;
  std::vector<contact::ContactHistory>& new_hist = spare_history_;
  std::vector<std::uint8_t>& new_touch = spare_touching_;
  new_j.resize(m);
  row_of.resize(m);
  new_image.resize(m);
  new_hist.resize(m);
  new_touch.resize(m);
  force_i.resize(m);
  torque_j.resize(m);
  // Spheres added since the last build (an insertion wave) are appended: the old spheres keep
  // their indices, so the old rows (i < n_old, j < n_old) still name the same pairs and their
  // history carries over. Any other change of count goes through renumber() first.
  const std::size_t n_old = row_start.empty() ? 0 : row_start.size() - 1;
  const bool had_old = n_old > 0 && n_old <= n;
  for_each_index(threads, chunks, [&](std::size_t c) {
    const auto& buf = chunk_rows_[c].rows;
    std::size_t from = 0;
    const std::size_t i1 = std::min(n, (c + 1) * kChunk);
    for (std::size_t i = c * kChunk; i < i1; ++i) {
      const bool has_row = had_old && i < n_old;
      std::size_t o = has_row ? row_start[i] : 0;
      const std::size_t o_end = has_row ? row_start[i + 1] : 0;
      for (std::size_t k = new_start[i]; k < new_start[i + 1]; ++k, ++from) {
        new_j[k] = buf[from].j;
        new_image[k] = buf[from].image;
        row_of[k] = static_cast<std::uint32_t>(i);
        while (o < o_end && j[o] < new_j[k]) ++o;
        const bool carried = o < o_end && j[o] == new_j[k] && touching[o];
        new_hist[k] = carried ? history[o] : contact::ContactHistory{};
        new_touch[k] = carried ? 1 : 0;
        force_i[k] = Vec3{};
        torque_j[k] = Vec3{};
      }
    }
  });
  row_start.swap(new_start);
  j.swap(new_j);
  image.swap(new_image);
  history.swap(new_hist);
  touching.swap(new_touch);

  // Reverse index (entries sorted by row, so each sphere's list is in ascending i order).
  rev_start.assign(n + 1, 0);
  for (std::size_t k = 0; k < m; ++k) ++rev_start[j[k] + 1];
  std::partial_sum(rev_start.begin(), rev_start.end(), rev_start.begin());
  rev_entry.resize(m);
  std::vector<std::uint32_t> fill(rev_start.begin(), rev_start.end() - 1);
  for (std::size_t k = 0; k < m; ++k) rev_entry[fill[j[k]]++] = static_cast<std::uint32_t>(k);

  built_at_ = s.position_m;
  ++builds_;
}

void VerletList::renumber(const std::vector<std::uint32_t>& new_of_old) {
  const std::size_t n = new_of_old.size();
  if (row_start.empty()) return;
  // Spheres appended since the last build have no rows yet (indices >= n_old); a list that
  // knows more spheres than the map cannot be mapped and is dropped.
  const std::size_t n_old = row_start.size() - 1;
  if (n_old > n) {
    row_start.clear();
    j.clear();
    row_of.clear();
    image.clear();
    history.clear();
    touching.clear();
    built_at_.clear();  // forces a rebuild
    return;
  }
  std::size_t n_new = 0;
  for (std::uint32_t v : new_of_old) n_new += v != kRemoved;
  struct E {
    std::uint32_t i, j;
    std::int32_t image;
    contact::ContactHistory h;
  };
  std::vector<E> kept;
  for (std::size_t i = 0; i < n_old; ++i)
    for (std::uint32_t k = row_start[i]; k < row_start[i + 1]; ++k) {
      if (!touching[k] || new_of_old[i] == kRemoved || new_of_old[j[k]] == kRemoved) continue;
      E e{new_of_old[i], new_of_old[j[k]], image[k], history[k]};
      if (e.i > e.j) {
        std::swap(e.i, e.j);
        e.h.xi = -e.h.xi;
        e.h.m_r = -e.h.m_r;
        // The image shift is also from i's side: negate each packed component.
        const auto c = [&](int sh) { return -static_cast<int>(static_cast<std::int8_t>((image[k] >> sh) & 0xff)); };
        e.image = static_cast<std::int32_t>(static_cast<std::uint8_t>(static_cast<std::int8_t>(c(0)))) |
                  (static_cast<std::int32_t>(static_cast<std::uint8_t>(static_cast<std::int8_t>(c(8)))) << 8) |
                  (static_cast<std::int32_t>(static_cast<std::uint8_t>(static_cast<std::int8_t>(c(16)))) << 16);
      }
      kept.push_back(e);
    }
  std::sort(kept.begin(), kept.end(), [](const E& a, const E& b) { return a.i != b.i ? a.i < b.i : a.j < b.j; });
  row_start.assign(n_new + 1, 0u);
  for (const auto& e : kept) ++row_start[e.i + 1];
  std::partial_sum(row_start.begin(), row_start.end(), row_start.begin());
  j.resize(kept.size());
  image.resize(kept.size());
  history.resize(kept.size());
  touching.assign(kept.size(), 1);
  for (std::size_t k = 0; k < kept.size(); ++k) {
    j[k] = kept[k].j;
    image[k] = kept[k].image;
    history[k] = kept[k].h;
  }
  index_rows();
  built_at_.clear();  // forces a rebuild
}

void VerletList::index_rows() {
  row_of.resize(j.size());
  const std::size_t n = row_start.empty() ? 0 : row_start.size() - 1;
  for (std::size_t i = 0; i < n; ++i)
    for (std::uint32_t k = row_start[i]; k < row_start[i + 1]; ++k) row_of[k] = static_cast<std::uint32_t>(i);
}

bool VerletList::needs_rebuild(const state::SphereStore& s) const {
  if (built_at_.size() != s.size()) return true;
  const double limit2 = rebuild_limit2();
  const std::size_t n = s.size();
  int flag = 0;
#pragma omp parallel for proc_bind(close) reduction(| : flag) schedule(static) if (n >= kParallelThreshold)
  for (std::size_t i = 0; i < n; ++i)
    if (!(norm2(s.position_m[i] - built_at_[i]) <= limit2)) flag = 1;  // NaN also triggers a (failing) build
  return flag != 0;
}

std::vector<std::pair<std::uint32_t, std::uint32_t>> brute_force_overlaps(const state::SphereStore& s,
                                                                          const Domain& dom) {
  std::vector<std::pair<std::uint32_t, std::uint32_t>> out;
  const Vec3 len = dom.length_m();
  for (std::uint32_t i = 0; i < s.size(); ++i)
    for (std::uint32_t jj = i + 1; jj < s.size(); ++jj) {
      if (s.body[i] == s.body[jj]) continue;
      Vec3 d = s.position_m[i] - s.position_m[jj];
      for (int k = 0; k < 3; ++k)
        if (dom.periodic[k]) d[k] -= len[k] * std::round(d[k] / len[k]);
      const double c = s.radius_m[i] + s.radius_m[jj];
      if (norm2(d) < c * c) out.emplace_back(i, jj);
    }
  return out;
}

std::size_t pairs_missing_within_cutoff(const VerletList& L, const state::SphereStore& s,
                                        const std::vector<std::pair<std::uint32_t, std::uint32_t>>& pairs) {
  const Domain& dom = L.domain();
  const Vec3 len = dom.length_m();
  std::size_t count = 0;
  for (const auto& [p, q] : pairs) {
    const std::uint32_t a = std::min(p, q), b = std::max(p, q);
    if (s.body[a] == s.body[b]) continue;
    const auto row = L.j.begin() + L.row_start[a], end = L.j.begin() + L.row_start[a + 1];
    if (std::find(row, end, b) != end) continue;
    Vec3 d = s.position_m[a] - s.position_m[b];
    for (int k = 0; k < 3; ++k)
      if (dom.periodic[k]) d[k] -= len[k] * std::round(d[k] / len[k]);
    const double cut = s.radius_m[a] + s.radius_m[b] + L.skin_m();
    if (norm(d) < cut * (1.0 - 1e-12)) ++count;  // (a pair at the cut-off itself may go either way)
  }
  return count;
}

}  // namespace biodem::neighbor
