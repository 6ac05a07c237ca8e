// Several capsules covering a link's geometry, split greedily where one sticks out too far; see capsule_cover.h.
#include "rmpmarl/setup/capsule_cover.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>

#include "capsule_cover_internal.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/math/point_cloud.h"

namespace rmpmarl::setup {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kMaxSamples = 400'000;
constexpr int kCutPositions = 7;  // per axis, at 1/8 … 7/8 of the part's extent

using Polygon = std::vector<Eigen::Vector3d>;

// a piece of the geometry that one capsule covers: convex polygons (clipped triangles) and whole balls.
struct Part {
  std::vector<Polygon> polygons;
  std::vector<Ball> balls;
};

void CheckInput(const CoverGeometry& g, const CapsuleCoverOptions& options) {
  if (!(options.tolerance > 0.0) || !std::isfinite(options.tolerance)) {
    throw InputError(fmt::format("capsule cover: tolerance: expected a finite value > 0 m, got {}", options.tolerance));
  }
  if (options.max_capsules < 1 || options.max_capsules > 256) {
    throw InputError(fmt::format("capsule cover: max_capsules: expected 1 to 256, got {}", options.max_capsules));
  }
  if (!(options.sample_spacing >= 1e-5) || !std::isfinite(options.sample_spacing)) {
    throw InputError(fmt::format("capsule cover: sample_spacing: expected a finite value >= 1e-5 m, got {}",
                                 options.sample_spacing));
  }
  if (!(options.fit.angle_step > 0.0 && options.fit.angle_step < 1.0) || options.fit.refine_rounds < 0 ||
      options.fit.refine_rounds > 20) {
    throw InputError(fmt::format("capsule cover: fit: expected 0 < angle_step < 1 rad and 0 to 20 refine_rounds, got "
                                 "{} and {}", options.fit.angle_step, options.fit.refine_rounds));
  }
  if (g.triangles.empty() && g.balls.empty()) {
    throw InputError("capsule cover: expected at least one triangle or ball, got none");
  }
  for (size_t i = 0; i < g.vertices.size(); ++i) {
    if (!g.vertices[i].allFinite()) {
      throw InputError(fmt::format("capsule cover: vertex {}: expected finite coordinates, got [{} {} {}]", i,
                                   g.vertices[i].x(), g.vertices[i].y(), g.vertices[i].z()));
    }
  }
  const int n = static_cast<int>(g.vertices.size());
  for (const Eigen::Vector3i& t : g.triangles) {
    if (t.minCoeff() < 0 || t.maxCoeff() >= n) {
      throw InputError(fmt::format("capsule cover: triangle [{} {} {}]: expected indices in [0, {}), got one outside",
                                   t[0], t[1], t[2], n));
    }
  }
  for (size_t i = 0; i < g.balls.size(); ++i) {
    if (!g.balls[i].p_F.allFinite() || !std::isfinite(g.balls[i].radius) || g.balls[i].radius < 0.0) {
      throw InputError(fmt::format("capsule cover: ball {}: expected a finite centre and radius >= 0, got [{} {} {}] "
                                   "r={}", i, g.balls[i].p_F.x(), g.balls[i].p_F.y(), g.balls[i].p_F.z(),
                                   g.balls[i].radius));
    }
  }
}

// points on a Fibonacci sphere of radius r around c.
void AppendSpherePoints(const Eigen::Vector3d& c, double r, int n, std::vector<Eigen::Vector3d>* out) {
  const double golden = kPi * (3.0 - std::sqrt(5.0));
  for (int k = 0; k < n; ++k) {
    const double z = 1.0 - 2.0 * (k + 0.5) / n;
    const double rho = std::sqrt(std::max(0.0, 1.0 - z * z));
    out->push_back(c + r * Eigen::Vector3d(rho * std::cos(golden * k), rho * std::sin(golden * k), z));
  }
}

// A triangle's grid of samples: from the corner a opposite its longest edge, na steps along ab and nb along ac, each
// no longer than the spacing, plus the longest edge bc itself in nc steps.
struct TriangleGrid {
  Eigen::Vector3d a, ab, ac, b, bc;
  int na = 1, nb = 1, nc = 1;
};

TriangleGrid GridOf(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Eigen::Vector3d& p2, double spacing) {
  const Eigen::Vector3d* p[3] = {&p0, &p1, &p2};
  int corner = 0;  // opposite the longest edge
  double longest = -1.0;
  for (int k = 0; k < 3; ++k) {
    const double l = (*p[(k + 1) % 3] - *p[(k + 2) % 3]).norm();
    if (l > longest) {
      longest = l;
      corner = k;
    }
  }
  TriangleGrid g;
  g.a = *p[corner];
  g.b = *p[(corner + 1) % 3];
  g.ab = g.b - g.a;
  g.ac = *p[(corner + 2) % 3] - g.a;
  g.bc = *p[(corner + 2) % 3] - g.b;
  auto steps = [&](const Eigen::Vector3d& e) {
    return static_cast<int>(std::clamp(std::ceil(e.norm() / spacing), 1.0, 1e6));
  };
  g.na = steps(g.ab);
  g.nb = steps(g.ac);
  g.nc = steps(g.bc);
  return g;
}

template <typename F>
void ForEachGridPoint(const TriangleGrid& g, F&& f) {
  for (int i = 0; i <= g.na; ++i) {
    const double u = static_cast<double>(i) / g.na;
    for (int j = 0; j <= g.nb; ++j) {
      const double v = static_cast<double>(j) / g.nb;
      if (u + v > 1.0 + 1e-12) break;
      f(g.a + u * g.ab + v * g.ac);
    }
  }
  for (int k = 1; k < g.nc; ++k) f(g.b + (static_cast<double>(k) / g.nc) * g.bc);
}

// at least the number of points ForEachGridPoint gives (the rows of the grid hold at most nb + 1 points each).
double GridCount(const TriangleGrid& g) { return 0.5 * (g.na + 1.0) * (g.nb + 2.0) + (g.nc - 1.0); }

// Fibonacci points on a ball: by area, at least 32; a ball of radius 0 (a point) is its centre alone.
int SphereSamples(double radius, double spacing) {
  if (radius <= 0.0) return 1;
  const double n = std::ceil(4.0 * kPi * radius * radius / (spacing * spacing));
  return static_cast<int>(std::clamp(n, 32.0, 20000.0));
}

}  // namespace

namespace internal {
// samples of the geometry's surface: a grid on every triangle (its corners and edges included) no coarser than
// `spacing`, and Fibonacci points on every ball; the spacing grows until there are at most kMaxSamples, or until it
// is the size of the whole geometry (then every corner, at least, is a sample: a mesh of very many triangles).
std::vector<Eigen::Vector3d> SurfaceSamples(const CoverGeometry& g, double* spacing) {
  Eigen::AlignedBox3d box;
  for (const Eigen::Vector3d& v : g.vertices) box.extend(v);
  for (const Ball& b : g.balls) {
    box.extend(b.p_F - Eigen::Vector3d::Constant(b.radius));
    box.extend(b.p_F + Eigen::Vector3d::Constant(b.radius));
  }
  const double size = std::max(box.diagonal().norm(), 1e-9);
  for (;;) {
    double count = 0.0;
    for (const Eigen::Vector3i& t : g.triangles) {
      count += GridCount(GridOf(g.vertices[t[0]], g.vertices[t[1]], g.vertices[t[2]], *spacing));
    }
    for (const Ball& b : g.balls) count += SphereSamples(b.radius, *spacing);
    if (count <= kMaxSamples || *spacing >= size) break;
    *spacing = std::min(size, *spacing * std::max(1.1, std::sqrt(count / kMaxSamples)));
  }
  std::vector<Eigen::Vector3d> p;
  for (const Eigen::Vector3i& t : g.triangles) {
    ForEachGridPoint(GridOf(g.vertices[t[0]], g.vertices[t[1]], g.vertices[t[2]], *spacing),
                     [&](const Eigen::Vector3d& x) { p.push_back(x); });
  }
  for (const Ball& b : g.balls) AppendSpherePoints(b.p_F, b.radius, SphereSamples(b.radius, *spacing), &p);
  return p;
}
}  // namespace internal

namespace {

// How densely a capsule's surface is sampled for its excess: the final measure, or a quick one for candidate cuts.
enum class Resolution { kFine, kQuick };

// points on the surface of a capsule: rings along the segment and two hemispheres.
std::vector<Eigen::Vector3d> CapsuleSurfacePoints(const math::Capsule& c, Resolution resolution) {
  const bool fine = resolution == Resolution::kFine;
  std::vector<Eigen::Vector3d> p;
  const Eigen::Vector3d ab = c.p_WB - c.p_WA;
  const double len = ab.norm();
  const Eigen::Vector3d u = len > 1e-12 ? Eigen::Vector3d(ab / len) : Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d e1 = u.unitOrthogonal(), e2 = u.cross(e1);
  const int around = fine ? 32 : 16;
  const double ring_spacing = std::max((fine ? 0.2 : 0.4) * c.radius, 1e-3);
  const int along = std::max(2, static_cast<int>(std::ceil(len / ring_spacing)));
  for (int k = 0; k <= along; ++k) {
    for (int j = 0; j < around; ++j) {
      const double a = 2.0 * kPi * j / around;
      p.push_back(c.p_WA + ab * k / along + c.radius * (std::cos(a) * e1 + std::sin(a) * e2));
    }
  }
  std::vector<Eigen::Vector3d> cap;
  AppendSpherePoints(Eigen::Vector3d::Zero(), c.radius, fine ? 400 : 100, &cap);
  for (const Eigen::Vector3d& q : cap) p.push_back((q.dot(u) >= 0.0 ? c.p_WB : c.p_WA) + q);
  return p;
}

// How far capsule k's surface (outside the other capsules) lies from the nearest surface sample: the farthest point
// (the excess) and the mean over its points.
struct ExcessStats {
  double max = 0.0;
  double sum = 0.0;
  int count = 0;
  double mean() const { return count > 0 ? sum / count : 0.0; }
  ExcessStats& operator+=(const ExcessStats& o) {
    max = std::max(max, o.max);
    sum += o.sum;
    count += o.count;
    return *this;
  }
};

ExcessStats CapsuleExcess(const std::vector<math::Capsule>& capsules, size_t k, const math::PointCloudIndex& surface,
                          Resolution resolution, const SolidTest* solid = nullptr) {
  ExcessStats stats;
  for (const Eigen::Vector3d& p : CapsuleSurfacePoints(capsules[k], resolution)) {
    bool inside_other = false;
    for (size_t o = 0; o < capsules.size() && !inside_other; ++o) {
      inside_other = o != k && CapsuleSignedDistance(capsules[o], p) < -1e-9;
    }
    if (inside_other || (solid != nullptr && solid->Inside(p))) continue;
    const double d = surface.NearestToSegment(p, p).distance;
    stats.max = std::max(stats.max, d);
    stats.sum += d;
    ++stats.count;
  }
  return stats;
}

// the balls a part's capsule must cover: its polygons' corners (duplicates removed) and its balls.
std::vector<Ball> PartBalls(const Part& part) {
  std::vector<Eigen::Vector3d> corners;
  for (const Polygon& poly : part.polygons) corners.insert(corners.end(), poly.begin(), poly.end());
  std::sort(corners.begin(), corners.end(), [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
  });
  corners.erase(std::unique(corners.begin(), corners.end()), corners.end());
  std::vector<Ball> balls;
  balls.reserve(corners.size() + part.balls.size());
  for (const Eigen::Vector3d& p : corners) balls.push_back({p, 0.0});
  balls.insert(balls.end(), part.balls.begin(), part.balls.end());
  return balls;
}

// the two sides of the plane u·p = s: each polygon clipped to each side (Sutherland–Hodgman on a convex polygon),
// each ball to the side of its centre.
std::pair<Part, Part> Cut(const Part& part, const Eigen::Vector3d& u, double s) {
  std::pair<Part, Part> sides;
  for (const Polygon& poly : part.polygons) {
    Polygon below, above;
    for (size_t i = 0; i < poly.size(); ++i) {
      const Eigen::Vector3d& a = poly[i];
      const Eigen::Vector3d& b = poly[(i + 1) % poly.size()];
      const double da = u.dot(a) - s, db = u.dot(b) - s;
      (da <= 0.0 ? below : above).push_back(a);
      if ((da <= 0.0) != (db <= 0.0)) {
        const Eigen::Vector3d x = a + (b - a) * (da / (da - db));
        below.push_back(x);
        above.push_back(x);
      }
    }
    if (!below.empty()) sides.first.polygons.push_back(std::move(below));
    if (!above.empty()) sides.second.polygons.push_back(std::move(above));
  }
  for (const Ball& b : part.balls) (u.dot(b.p_F) <= s ? sides.first : sides.second).balls.push_back(b);
  return sides;
}

bool Empty(const Part& p) { return p.polygons.empty() && p.balls.empty(); }

// A cut of one part: the two sides, their capsules and how far those stick out.
struct CutResult {
  Part below, above;
  math::Capsule a, b;
  ExcessStats excess;
};

// the best cut of part k of the cover (its capsule capsules[k]): of seven positions across each of the part's three
// principal axes and the three axes of the frame (links are usually drawn along their frame's axes), the one whose
// two capsules (quick fits) lie closest to the geometry on average over their surfaces, ties to the smaller volume;
// its capsules then fitted in full. Nothing when every cut leaves a side empty.
std::optional<CutResult> BestCut(const std::vector<Part>& parts, const std::vector<math::Capsule>& capsules, size_t k,
                                 const math::PointCloudIndex& surface, const CapsuleFitOptions& fit) {
  const Part& part = parts[k];
  const std::vector<Ball> balls = PartBalls(part);
  if (balls.size() < 2) return std::nullopt;
  const Eigen::Matrix3d principal = PrincipalAxes(balls);
  const std::vector<Eigen::Vector3d> axes = {principal.col(2), principal.col(1), principal.col(0),
                                             Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ()};
  CapsuleFitOptions quick;
  quick.refine_axis = false;
  std::vector<math::Capsule> trial = capsules;
  trial.push_back({});
  const size_t other = trial.size() - 1;
  // how far the two capsules replacing capsule k stick out
  auto pair_excess = [&](const math::Capsule& a, const math::Capsule& b, Resolution resolution) {
    trial[k] = a;
    trial[other] = b;
    ExcessStats e = CapsuleExcess(trial, k, surface, resolution);
    e += CapsuleExcess(trial, other, surface, resolution);
    return e;
  };
  std::optional<CutResult> best;
  double best_volume = std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3d& u : axes) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const Ball& b : balls) {
      lo = std::min(lo, u.dot(b.p_F) - b.radius);
      hi = std::max(hi, u.dot(b.p_F) + b.radius);
    }
    if (!(hi - lo > 1e-6)) continue;
    for (int m = 1; m <= kCutPositions; ++m) {
      auto [below, above] = Cut(part, u, lo + (hi - lo) * m / (kCutPositions + 1.0));
      if (Empty(below) || Empty(above)) continue;
      const math::Capsule a = FitCapsuleToBalls(PartBalls(below), quick);
      const math::Capsule b = FitCapsuleToBalls(PartBalls(above), quick);
      const ExcessStats e = pair_excess(a, b, Resolution::kQuick);
      const double v = CapsuleVolume(a) + CapsuleVolume(b);
      const double best_mean = best ? best->excess.mean() : std::numeric_limits<double>::infinity();
      if (e.mean() < best_mean - 1e-7 || (e.mean() <= best_mean + 1e-7 && v < best_volume)) {
        best = CutResult{std::move(below), std::move(above), a, b, e};
        best_volume = v;
      }
    }
  }
  if (!best) return std::nullopt;
  best->a = FitCapsuleToBalls(PartBalls(best->below), fit);
  best->b = FitCapsuleToBalls(PartBalls(best->above), fit);
  best->excess = pair_excess(best->a, best->b, Resolution::kFine);
  return best;
}

// a capsule whose segment is shorter than 1 µm as the sphere around it (simulators refuse a degenerate segment).
math::Capsule SphereIfShort(const math::Capsule& c) {
  const double length = (c.p_WB - c.p_WA).norm();
  if (length >= 1e-6) return c;
  const Eigen::Vector3d centre = 0.5 * (c.p_WA + c.p_WB);
  return {centre, centre, c.radius + 0.5 * length};
}

// the plane cuts' capsules (CoverMethod::kCuts, the file comment of capsule_cover.h) over the surface samples of
// `surface`; *reached_max says whether it stopped at options.max_capsules
std::vector<math::Capsule> FitCutCapsules(const CoverGeometry& geometry, const CapsuleCoverOptions& options,
                                          const math::PointCloudIndex& surface, bool* reached_max) {
  std::vector<Part> parts(1);
  for (const Eigen::Vector3i& t : geometry.triangles) {
    parts[0].polygons.push_back({geometry.vertices[t[0]], geometry.vertices[t[1]], geometry.vertices[t[2]]});
  }
  parts[0].balls = geometry.balls;
  std::vector<math::Capsule> capsules = {FitCapsuleToBalls(PartBalls(parts[0]), options.fit)};
  std::vector<bool> settled = {false};  // no cut of this part helps
  for (;;) {
    if (static_cast<int>(parts.size()) >= options.max_capsules) {
      *reached_max = true;
      break;
    }
    // the capsule that sticks out farthest beyond the tolerance and can still be cut
    int worst = -1;
    ExcessStats worst_excess;
    worst_excess.max = options.tolerance;
    for (size_t k = 0; k < parts.size(); ++k) {
      if (settled[k]) continue;
      const ExcessStats e = CapsuleExcess(capsules, k, surface, Resolution::kFine);
      if (e.max > worst_excess.max) {
        worst_excess = e;
        worst = static_cast<int>(k);
      }
    }
    if (worst < 0) break;
    std::optional<CutResult> cut = BestCut(parts, capsules, worst, surface, options.fit);
    // a cut is kept when its two capsules stick out less than the one they replace: at their farthest point (by
    // 0.5 mm at least) or on average over their surfaces (by 5 % at least: a bent link's one fat capsule is replaced
    // by two slim ones whose farthest point, often a cap over a flat end, stays where it was)
    if (!cut || !(cut->excess.max < worst_excess.max - 5e-4 || cut->excess.mean() < 0.95 * worst_excess.mean())) {
      settled[worst] = true;
      continue;
    }
    parts[worst] = std::move(cut->below);
    capsules[worst] = cut->a;
    parts.push_back(std::move(cut->above));
    capsules.push_back(cut->b);
    settled[worst] = false;
    settled.push_back(false);
  }
  return capsules;
}

}  // namespace

namespace internal {
CapsuleCover Measure(std::vector<math::Capsule> capsules, const std::vector<Eigen::Vector3d>& samples,
                     const math::PointCloudIndex& index, double spacing, double tolerance, const SolidTest* solid) {
  CapsuleCover cover;
  cover.capsules = std::move(capsules);
  for (math::Capsule& c : cover.capsules) c = SphereIfShort(c);
  cover.samples = static_cast<int>(samples.size());
  cover.sample_spacing = spacing;
  ExcessStats all;
  for (size_t k = 0; k < cover.capsules.size(); ++k) {
    const ExcessStats e = CapsuleExcess(cover.capsules, k, index, Resolution::kFine, solid);
    cover.excess.push_back(e.max);
    all += e;
  }
  cover.mean_excess = all.mean();
  cover.max_excess = cover.excess.empty() ? 0.0 : *std::max_element(cover.excess.begin(), cover.excess.end());
  cover.max_outside = -std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3d& p : samples) {
    double nearest = std::numeric_limits<double>::infinity();
    for (const math::Capsule& c : cover.capsules) nearest = std::min(nearest, CapsuleSignedDistance(c, p));
    cover.max_outside = std::max(cover.max_outside, nearest);
  }
  cover.within_tolerance = cover.max_excess <= tolerance && cover.max_outside <= 1e-9;
  return cover;
}

Eigen::Matrix3Xd AsMatrix(const std::vector<Eigen::Vector3d>& p) {
  Eigen::Matrix3Xd m(3, p.size());
  for (size_t i = 0; i < p.size(); ++i) m.col(i) = p[i];
  return m;
}
}  // namespace internal

using internal::AsMatrix;
using internal::Measure;
using internal::SurfaceSamples;

CapsuleCover MeasureCapsuleCover(const CoverGeometry& geometry, std::vector<math::Capsule> capsules,
                                 const CapsuleCoverOptions& options) {
  CheckInput(geometry, options);
  if (capsules.empty()) throw InputError("capsule cover: measure: expected at least one capsule, got none");
  for (size_t k = 0; k < capsules.size(); ++k) {
    const math::Capsule& c = capsules[k];
    if (!c.p_WA.allFinite() || !c.p_WB.allFinite() || !std::isfinite(c.radius) || c.radius < 0.0) {
      throw InputError(fmt::format("capsule cover: measure: capsule {}: expected finite end points and a radius >= 0, "
                                   "got r={}", k, c.radius));
    }
  }
  double spacing = options.sample_spacing;
  const std::vector<Eigen::Vector3d> samples = SurfaceSamples(geometry, &spacing);
  const math::PointCloudIndex index(AsMatrix(samples));
  if (options.method == CoverMethod::kInscribed) {
    const SolidTest solid(geometry);
    return Measure(std::move(capsules), samples, index, spacing, options.tolerance, &solid);
  }
  return Measure(std::move(capsules), samples, index, spacing, options.tolerance, nullptr);
}

CapsuleCover FitCapsuleCover(const CoverGeometry& geometry, const CapsuleCoverOptions& options) {
  CheckInput(geometry, options);
  double spacing = options.sample_spacing;
  const std::vector<Eigen::Vector3d> samples = SurfaceSamples(geometry, &spacing);
  const math::PointCloudIndex index(AsMatrix(samples));
  if (options.method == CoverMethod::kInscribed) {
    const SolidTest solid(geometry);
    std::optional<std::vector<math::Capsule>> inscribed =
        internal::FitInscribedCapsules(geometry, options, samples, index, solid);
    if (inscribed) return Measure(std::move(*inscribed), samples, index, spacing, options.tolerance, &solid);
    // more capsules than allowed: the plane cuts' cover, within the same limit, measured the same way
    bool reached_max = false;
    CapsuleCover cover = Measure(FitCutCapsules(geometry, options, index, &reached_max), samples, index, spacing,
                                 options.tolerance, &solid);
    cover.reached_max_capsules = !cover.within_tolerance;
    return cover;
  }

  bool reached_max = false;
  std::vector<math::Capsule> capsules = FitCutCapsules(geometry, options, index, &reached_max);
  CapsuleCover cover = Measure(std::move(capsules), samples, index, spacing, options.tolerance, nullptr);
  cover.reached_max_capsules = reached_max && !cover.within_tolerance;
  return cover;
}

void AppendBoxSurface(const Eigen::Isometry3d& X_FG, const Eigen::Vector3d& size, CoverGeometry* g) {
  const int o = static_cast<int>(g->vertices.size());
  const Eigen::Vector3d h = 0.5 * size;
  for (int i = 0; i < 8; ++i) {
    g->vertices.push_back(X_FG * Eigen::Vector3d(i & 1 ? h.x() : -h.x(), i & 2 ? h.y() : -h.y(), i & 4 ? h.z() : -h.z()));
  }
  const int faces[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
  for (const auto& f : faces) {
    g->triangles.emplace_back(o + f[0], o + f[1], o + f[2]);
    g->triangles.emplace_back(o + f[0], o + f[2], o + f[3]);
  }
}

void AppendCylinderSurface(const Eigen::Isometry3d& X_FG, double radius, double length, int sides,
                           bool circumscribed, CoverGeometry* g) {
  if (sides < 3) throw InputError(fmt::format("cylinder surface: sides: expected >= 3, got {}", sides));
  const int o = static_cast<int>(g->vertices.size());
  // the circumscribed polygon covers the circle; the inscribed one's corners lie on it
  const double r_out = circumscribed ? radius / std::cos(kPi / sides) : radius;
  for (int k = 0; k < sides; ++k) {
    const double a = 2.0 * kPi * k / sides;
    g->vertices.push_back(X_FG * Eigen::Vector3d(r_out * std::cos(a), r_out * std::sin(a), -0.5 * length));
    g->vertices.push_back(X_FG * Eigen::Vector3d(r_out * std::cos(a), r_out * std::sin(a), 0.5 * length));
  }
  g->vertices.push_back(X_FG * Eigen::Vector3d(0, 0, -0.5 * length));
  g->vertices.push_back(X_FG * Eigen::Vector3d(0, 0, 0.5 * length));
  const int bottom = o + 2 * sides, top = bottom + 1;
  for (int k = 0; k < sides; ++k) {
    const int lo0 = o + 2 * k, hi0 = lo0 + 1, lo1 = o + 2 * ((k + 1) % sides), hi1 = lo1 + 1;
    g->triangles.emplace_back(lo0, lo1, hi1);
    g->triangles.emplace_back(lo0, hi1, hi0);
    g->triangles.emplace_back(bottom, lo1, lo0);
    g->triangles.emplace_back(top, hi0, hi1);
  }
}

}  // namespace rmpmarl::setup
