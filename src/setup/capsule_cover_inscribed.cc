// A cover of capsules grown inside a link's solid (CoverMethod::kInscribed); see capsule_cover.h.
//
// A segment inside the solid whose points all lie at least d from the surface carries a capsule of radius d + e that
// sticks out of the solid by at most e: a point of the capsule's surface outside the solid is reached from the
// segment by a ray that leaves the solid after ≥ d, so it lies ≤ e beyond the surface. d is the segment's distance to
// the nearest surface sample (the kd-tree's exact segment query). The cover is a greedy set cover of the surface
// samples by such capsules: the uncovered sample farthest from the others' centroid is taken, candidate segments are
// grown from interior points whose ball covers it (along 13 lattice directions and the link's principal axes, while
// the interior stays at least a level deep: the point's depth, 70 % or 40 % of it), and the candidate covering the
// most uncovered samples is kept. A sample no interior point reaches (a plate thinner than the grid) gets a ball of
// radius e at itself. Capsules whose samples the others all cover are dropped afterwards.
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>

#include "capsule_cover_internal.h"

namespace rmpmarl::setup {


SolidTest::SolidTest(const CoverGeometry& g) : vertices_(g.vertices), triangles_(g.triangles), balls_(g.balls) {
  for (int a = 0; a < 3; ++a) {
    AxisGrid& grid = grids_[a];
    grid.a = a;
    grid.b = (a + 1) % 3;
    grid.c = (a + 2) % 3;
    if (triangles_.empty()) continue;
    double lo_b = std::numeric_limits<double>::infinity(), hi_b = -lo_b, lo_c = lo_b, hi_c = -lo_b;
    for (const Eigen::Vector3d& v : vertices_) {
      lo_b = std::min(lo_b, v[grid.b]);
      hi_b = std::max(hi_b, v[grid.b]);
      lo_c = std::min(lo_c, v[grid.c]);
      hi_c = std::max(hi_c, v[grid.c]);
    }
    grid.cell = std::max({hi_b - lo_b, hi_c - lo_c, 1e-6}) / 64.0;
    grid.lo_b = lo_b;
    grid.lo_c = lo_c;
    grid.nb = static_cast<int>((hi_b - lo_b) / grid.cell) + 1;
    grid.nc = static_cast<int>((hi_c - lo_c) / grid.cell) + 1;
    grid.cells.assign(static_cast<size_t>(grid.nb) * grid.nc, {});
    for (size_t t = 0; t < triangles_.size(); ++t) {
      double tb0 = std::numeric_limits<double>::infinity(), tb1 = -tb0, tc0 = tb0, tc1 = -tb0;
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector3d& v = vertices_[triangles_[t][k]];
        tb0 = std::min(tb0, v[grid.b]);
        tb1 = std::max(tb1, v[grid.b]);
        tc0 = std::min(tc0, v[grid.c]);
        tc1 = std::max(tc1, v[grid.c]);
      }
      const int b0 = std::clamp(static_cast<int>((tb0 - lo_b) / grid.cell), 0, grid.nb - 1);
      const int b1 = std::clamp(static_cast<int>((tb1 - lo_b) / grid.cell), 0, grid.nb - 1);
      const int c0 = std::clamp(static_cast<int>((tc0 - lo_c) / grid.cell), 0, grid.nc - 1);
      const int c1 = std::clamp(static_cast<int>((tc1 - lo_c) / grid.cell), 0, grid.nc - 1);
      for (int ib = b0; ib <= b1; ++ib) {
        for (int ic = c0; ic <= c1; ++ic) grid.cells[static_cast<size_t>(ib) * grid.nc + ic].push_back(int(t));
      }
    }
  }
}

bool SolidTest::InsideAlong(const AxisGrid& grid, const Eigen::Vector3d& p) const {
  // the ray's foot moved off the mesh's edges and vertices by a fixed irrational-looking offset
  const double qb = p[grid.b] + 1.2345678e-7, qc = p[grid.c] + 0.7654321e-7;
  const int ib = static_cast<int>(std::floor((qb - grid.lo_b) / grid.cell));
  const int ic = static_cast<int>(std::floor((qc - grid.lo_c) / grid.cell));
  if (ib < 0 || ic < 0 || ib >= grid.nb || ic >= grid.nc) return false;
  int parity = 0, winding = 0;
  for (int t : grid.cells[static_cast<size_t>(ib) * grid.nc + ic]) {
    const Eigen::Vector3d& v0 = vertices_[triangles_[t][0]];
    const Eigen::Vector3d& v1 = vertices_[triangles_[t][1]];
    const Eigen::Vector3d& v2 = vertices_[triangles_[t][2]];
    const double x0 = v0[grid.b] - qb, y0 = v0[grid.c] - qc;
    const double x1 = v1[grid.b] - qb, y1 = v1[grid.c] - qc;
    const double x2 = v2[grid.b] - qb, y2 = v2[grid.c] - qc;
    const double w0 = x1 * y2 - x2 * y1, w1 = x2 * y0 - x0 * y2, w2 = x0 * y1 - x1 * y0;
    const double d = w0 + w1 + w2;
    if (d == 0.0) continue;  // seen edge-on
    if (!((w0 >= 0 && w1 >= 0 && w2 >= 0) || (w0 <= 0 && w1 <= 0 && w2 <= 0))) continue;
    const double hit = (w0 * v0[grid.a] + w1 * v1[grid.a] + w2 * v2[grid.a]) / d;
    if (hit <= p[grid.a]) continue;
    parity ^= 1;
    winding += d > 0 ? 1 : -1;
  }
  return parity == 1 || winding != 0;
}

bool SolidTest::Inside(const Eigen::Vector3d& p) const {
  for (const Ball& b : balls_) {
    if ((p - b.p_F).squaredNorm() < b.radius * b.radius) return true;
  }
  if (triangles_.empty()) return false;
  int votes = 0;
  for (const AxisGrid& grid : grids_) votes += InsideAlong(grid, p) ? 1 : 0;
  return votes >= 2;
}

namespace internal {
namespace {

constexpr int kInteriorPoints = 40'000;  // the interior grid's size, about
constexpr int kSeeds = 64;               // interior points tried per uncovered sample
constexpr int kScoreSamples = 3000;      // uncovered samples a candidate is scored on, about
constexpr std::array<double, 6> kLevels = {1.0, 0.85, 0.7, 0.55, 0.4, 0.25};

double SegmentDistanceSquared(const Eigen::Vector3d& a, const Eigen::Vector3d& ab, double ab2,
                              const Eigen::Vector3d& p) {
  const Eigen::Vector3d ap = p - a;
  const double t = ab2 > 0.0 ? std::clamp(ap.dot(ab) / ab2, 0.0, 1.0) : 0.0;
  return (ap - t * ab).squaredNorm();
}

// depth below the surface on a grid over the solid's box: −1 outside, else the distance to the nearest sample.
class DepthGrid {
 public:
  DepthGrid(const Eigen::AlignedBox3d& box, double spacing, const SolidTest& solid,
            const math::PointCloudIndex& index) {
    const Eigen::Vector3d extent = box.sizes();
    h_ = std::max(spacing, std::cbrt(std::max(extent.prod(), 1e-12) / kInteriorPoints));
    lo_ = box.min();
    for (int k = 0; k < 3; ++k) n_[k] = static_cast<int>(std::ceil(extent[k] / h_)) + 1;
    depth_.assign(static_cast<size_t>(n_[0]) * n_[1] * n_[2], -1.0);
    for (int i = 0; i < n_[0]; ++i) {
      for (int j = 0; j < n_[1]; ++j) {
        for (int k = 0; k < n_[2]; ++k) {
          const Eigen::Vector3d p = Point(i, j, k);
          if (!solid.Inside(p)) continue;
          depth_[Index(i, j, k)] = index.NearestToSegment(p, p).distance;
        }
      }
    }
  }
  double h() const { return h_; }
  int size() const { return static_cast<int>(depth_.size()); }
  double depth(int flat) const { return depth_[flat]; }
  Eigen::Vector3d PointOf(int flat) const {
    const int k = flat % n_[2], j = (flat / n_[2]) % n_[1], i = flat / (n_[2] * n_[1]);
    return Point(i, j, k);
  }
  // the least depth at the eight grid points around q (−1 outside the grid or next to the outside)
  double LeastAround(const Eigen::Vector3d& q) const {
    const Eigen::Vector3d g = (q - lo_) / h_;
    const int i = static_cast<int>(std::floor(g.x())), j = static_cast<int>(std::floor(g.y())),
              k = static_cast<int>(std::floor(g.z()));
    if (i < 0 || j < 0 || k < 0 || i + 1 >= n_[0] || j + 1 >= n_[1] || k + 1 >= n_[2]) return -1.0;
    double least = std::numeric_limits<double>::infinity();
    for (int di = 0; di < 2; ++di) {
      for (int dj = 0; dj < 2; ++dj) {
        for (int dk = 0; dk < 2; ++dk) least = std::min(least, depth_[Index(i + di, j + dj, k + dk)]);
      }
    }
    return least;
  }

  // every point of [a, b] (at half-grid steps) has its eight grid points inside the solid
  bool InsideAlong(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const {
    const int n = static_cast<int>(std::ceil((b - a).norm() / (0.5 * h_)));
    for (int s = 0; s <= n; ++s) {
      if (!(LeastAround(a + (b - a) * (n > 0 ? static_cast<double>(s) / n : 0.0)) > 0.0)) return false;
    }
    return true;
  }

 private:
  size_t Index(int i, int j, int k) const { return (static_cast<size_t>(i) * n_[1] + j) * n_[2] + k; }
  Eigen::Vector3d Point(int i, int j, int k) const { return lo_ + h_ * Eigen::Vector3d(i, j, k); }

  double h_ = 1.0;
  Eigen::Vector3d lo_;
  int n_[3] = {1, 1, 1};
  std::vector<double> depth_;
};

std::vector<Eigen::Vector3d> Directions(const std::vector<Eigen::Vector3d>& samples) {
  std::vector<Eigen::Vector3d> dirs;
  for (int x = -1; x <= 1; ++x) {
    for (int y = -1; y <= 1; ++y) {
      for (int z = -1; z <= 1; ++z) {
        const Eigen::Vector3d d(x, y, z);
        // one of each opposite pair: the first non-zero coordinate positive
        const bool first_positive = x > 0 || (x == 0 && (y > 0 || (y == 0 && z > 0)));
        if (first_positive) dirs.push_back(d.normalized());
      }
    }
  }
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : samples) mean += p;
  mean /= std::max<size_t>(samples.size(), 1);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : samples) cov += (p - mean) * (p - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  for (int k = 0; k < 3; ++k) {
    if (eig.eigenvectors().col(k).allFinite()) dirs.push_back(eig.eigenvectors().col(k).normalized());
  }
  return dirs;
}

}  // namespace

std::optional<std::vector<math::Capsule>> FitInscribedCapsules(const CoverGeometry& g,
                                                               const CapsuleCoverOptions& options,
                                                               const std::vector<Eigen::Vector3d>& samples,
                                                               const math::PointCloudIndex& index,
                                                               const SolidTest& solid) {
  // A sample counts as covered when it lies half a sample spacing inside a capsule, so that the surface between
  // samples is covered too (to within a fraction of a millimetre at the default 2 mm spacing). The radius is the
  // depth plus the tolerance less the samples' own error: the nearest sample lies up to about spacing²/(4e) farther
  // than the surface from a point e outside it.
  const double spacing = options.sample_spacing;
  const double e = options.tolerance - std::min(0.25 * options.tolerance, 0.5 * spacing * spacing / options.tolerance);
  const double inset = 0.5 * spacing;
  // a segment's distance to the nearest sample overstates its depth below the surface by up to
  // √(d² + s²) − d (a surface point lies within about a spacing s of a sample): the radius takes the least depth
  auto radius_at = [&](double sample_distance) {
    return e + std::sqrt(std::max(0.0, sample_distance * sample_distance - spacing * spacing));
  };
  // the geometry's balls are their own capsules (every sample of a ball is on it)
  std::vector<math::Capsule> capsules;
  for (const Ball& b : g.balls) capsules.push_back({b.p_F, b.p_F, b.radius});
  if (g.triangles.empty()) return capsules;
  auto inside_capsule = [](const math::Capsule& c, const Eigen::Vector3d& p, double inset) {
    const Eigen::Vector3d ab = c.p_WB - c.p_WA;
    const double r = std::max(0.0, c.radius - inset);
    return SegmentDistanceSquared(c.p_WA, ab, ab.squaredNorm(), p) <= r * r;
  };
  std::vector<int> uncovered;
  for (int i = 0; i < static_cast<int>(samples.size()); ++i) {
    bool covered = false;
    for (size_t b = 0; b < g.balls.size() && !covered; ++b) {
      covered = (samples[i] - g.balls[b].p_F).norm() <= g.balls[b].radius * (1.0 + 1e-12) + 1e-12;
    }
    if (!covered) uncovered.push_back(i);
  }
  if (uncovered.empty()) return capsules;

  Eigen::AlignedBox3d box;
  for (const Eigen::Vector3d& v : g.vertices) box.extend(v);
  const DepthGrid depth(box, options.sample_spacing, solid, index);
  std::vector<int> interior;
  for (int k = 0; k < depth.size(); ++k) {
    if (depth.depth(k) > 0.0) interior.push_back(k);
  }
  const std::vector<Eigen::Vector3d> dirs = Directions(samples);
  const double step = 0.5 * depth.h();
  const int max_steps = static_cast<int>(std::ceil(box.diagonal().norm() / step)) + 1;

  while (!uncovered.empty()) {
    if (static_cast<int>(capsules.size()) >= options.max_capsules) return std::nullopt;
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (int i : uncovered) centroid += samples[i];
    centroid /= static_cast<double>(uncovered.size());
    int target = uncovered.front();
    for (int i : uncovered) {
      if ((samples[i] - centroid).squaredNorm() > (samples[target] - centroid).squaredNorm()) target = i;
    }
    const Eigen::Vector3d& u0 = samples[target];

    // interior points whose ball of radius depth + e holds the target, deepest first, spread over kSeeds
    std::vector<int> reach;
    for (int k : interior) {
      const double r = depth.depth(k) + e;
      if ((depth.PointOf(k) - u0).squaredNorm() <= r * r) reach.push_back(k);
    }
    std::sort(reach.begin(), reach.end(), [&](int a, int b) { return depth.depth(a) > depth.depth(b); });
    std::vector<int> seeds;
    const int nseeds = std::min<int>(kSeeds, static_cast<int>(reach.size()));
    for (int s = 0; s < nseeds; ++s) seeds.push_back(reach[static_cast<size_t>(s) * reach.size() / nseeds]);

    const int stride = std::max(1, static_cast<int>(uncovered.size()) / kScoreSamples);
    auto score = [&](const math::Capsule& c) {
      const Eigen::Vector3d ab = c.p_WB - c.p_WA;
      const double ab2 = ab.squaredNorm();
      const double r2 = std::max(0.0, c.radius - inset) * std::max(0.0, c.radius - inset);
      const Eigen::Vector3d lo = c.p_WA.cwiseMin(c.p_WB).array() - c.radius;
      const Eigen::Vector3d hi = c.p_WA.cwiseMax(c.p_WB).array() + c.radius;
      int n = 0;
      for (size_t s = 0; s < uncovered.size(); s += stride) {
        const Eigen::Vector3d& p = samples[uncovered[s]];
        if ((p.array() < lo.array()).any() || (p.array() > hi.array()).any()) continue;
        if (SegmentDistanceSquared(c.p_WA, ab, ab2, p) <= r2) ++n;
      }
      return n;
    };
    // the fallback that always covers the target: a ball of radius e at it
    math::Capsule best{u0, u0, e};
    int best_score = score(best);
    for (int k : seeds) {
      const Eigen::Vector3d p = depth.PointOf(k);
      for (double f : kLevels) {
        const double level = f * depth.depth(k);
        for (const Eigen::Vector3d& u : dirs) {
          Eigen::Vector3d a = p, b = p;
          for (int s = 0; s < max_steps && depth.LeastAround(a - step * u) >= level; ++s) a -= step * u;
          for (int s = 0; s < max_steps && depth.LeastAround(b + step * u) >= level; ++s) b += step * u;
          const math::Capsule c{a, b, radius_at(index.NearestToSegment(a, b).distance)};
          if (!inside_capsule(c, u0, inset)) continue;
          const int n = score(c);
          if (n > best_score || (n == best_score && c.radius > best.radius)) {
            best = c;
            best_score = n;
          }
          if ((b - a).squaredNorm() == 0.0) break;  // the point alone: every direction gives the same ball
        }
      }
    }
    // the best candidate's end points moved while that covers more: one grid step along ±x, ±y, ±z at a time
    for (int round = 0; round < 40; ++round) {
      bool improved = false;
      for (int end = 0; end < 2 && !improved; ++end) {
        for (int axis = 0; axis < 3 && !improved; ++axis) {
          for (double sign : {-1.0, 1.0}) {
            math::Capsule c = best;
            (end == 0 ? c.p_WA : c.p_WB)[axis] += sign * depth.h();
            if (depth.LeastAround(end == 0 ? c.p_WA : c.p_WB) < 0.0) continue;
            c.radius = radius_at(index.NearestToSegment(c.p_WA, c.p_WB).distance);
            if (!depth.InsideAlong(c.p_WA, c.p_WB) || !inside_capsule(c, u0, inset)) continue;
            const int n = score(c);
            if (n > best_score) {
              best = c;
              best_score = n;
              improved = true;
              break;
            }
          }
        }
      }
      if (!improved) break;
    }
    capsules.push_back(best);
    std::erase_if(uncovered, [&](int i) { return i == target || inside_capsule(best, samples[i], inset); });
  }

  // drop capsules whose samples the others cover, those covering fewest first (the geometry's balls stay)
  const size_t fixed = g.balls.size();
  std::vector<std::vector<int>> covers(capsules.size());
  std::vector<int> count(samples.size(), 0);
  for (size_t c = 0; c < capsules.size(); ++c) {
    for (int i = 0; i < static_cast<int>(samples.size()); ++i) {
      if (inside_capsule(capsules[c], samples[i], c < fixed ? 0.0 : inset)) {
        covers[c].push_back(i);
        ++count[i];
      }
    }
  }
  std::vector<size_t> order(capsules.size() - fixed);
  std::iota(order.begin(), order.end(), fixed);
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return covers[a].size() < covers[b].size(); });
  std::vector<bool> keep(capsules.size(), true);
  for (size_t c : order) {
    if (std::all_of(covers[c].begin(), covers[c].end(), [&](int i) { return count[i] >= 2; })) {
      keep[c] = false;
      for (int i : covers[c]) --count[i];
    }
  }
  std::vector<math::Capsule> kept;
  for (size_t c = 0; c < capsules.size(); ++c) {
    if (keep[c]) kept.push_back(capsules[c]);
  }
  return kept;
}

}  // namespace internal
}  // namespace rmpmarl::setup
