// Capsules covering URDF primitives (closed-form families) and fitted to ball/point sets; see capsule_fit.h.
#include "rmpmarl/setup/capsule_fit.h"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <functional>
#include <numeric>

#include "rmpmarl/common/error.h"
#include "rmpmarl/common/random.h"
#include "rmpmarl/math/golden_section.h"

namespace rmpmarl::setup {

namespace {

constexpr double kPi = 3.14159265358979323846;

// minimiser of f on [lo, hi]: the best of `grid` + 1 evenly spaced values, refined by golden-section search between
// its neighbours (f need not be unimodal on the whole interval).
double MinimiseOnInterval(const std::function<double(double)>& f, double lo, double hi, int grid = 32,
                          int golden_iterations = 40) {
  if (!(hi > lo)) return lo;
  int best = 0;
  double best_value = std::numeric_limits<double>::infinity();
  for (int k = 0; k <= grid; ++k) {
    const double v = f(lo + (hi - lo) * k / grid);
    if (v < best_value) {
      best_value = v;
      best = k;
    }
  }
  const double a = lo + (hi - lo) * std::max(best - 1, 0) / grid;
  const double b = lo + (hi - lo) * std::min(best + 1, grid) / grid;
  const math::GoldenBracket g = math::GoldenSectionSearch(f, a, b, golden_iterations);
  const double x = 0.5 * (g.a + g.b);
  const double grid_x = lo + (hi - lo) * best / grid;
  return f(x) <= best_value ? x : grid_x;
}

// the cylinder family of CapsuleCoveringCylinder: parameter s, returns (half segment length, radius).
std::pair<double, double> CylinderFamily(double radius, double half_length) {
  auto volume = [&](double s) {
    const double R2 = radius * radius + s * s;
    return 2.0 * kPi * R2 * (half_length - s) + 4.0 / 3.0 * kPi * R2 * std::sqrt(R2);
  };
  const double s = MinimiseOnInterval(volume, 0.0, half_length, 64, 60);
  return {half_length - s, std::sqrt(radius * radius + s * s)};
}

// smallest circle enclosing 2-D points (Welzl's algorithm, iterative, on a seeded shuffle): centre and radius.
std::pair<Eigen::Vector2d, double> SmallestEnclosingCircle(std::vector<Eigen::Vector2d> p) {
  // deterministic Fisher–Yates shuffle: expected linear time without unseeded randomness
  std::uint64_t state = 0x5eedULL;
  for (size_t i = p.size(); i > 1; --i) {
    state = SplitMix64(state);
    std::swap(p[i - 1], p[state % i]);
  }
  auto circle2 = [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return std::make_pair(Eigen::Vector2d(0.5 * (a + b)), 0.5 * (a - b).norm());
  };
  auto circle3 = [&](const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
    const Eigen::Vector2d ab = b - a, ac = c - a;
    const double d = 2.0 * (ab.x() * ac.y() - ab.y() * ac.x());
    if (std::abs(d) < 1e-18) {  // collinear: the circle over the farthest pair
      auto best = circle2(a, b);
      for (const auto& cand : {circle2(a, c), circle2(b, c)}) {
        if (cand.second > best.second) best = cand;
      }
      return best;
    }
    const Eigen::Vector2d centre_rel((ac.y() * ab.squaredNorm() - ab.y() * ac.squaredNorm()) / d,
                                     (ab.x() * ac.squaredNorm() - ac.x() * ab.squaredNorm()) / d);
    return std::make_pair(Eigen::Vector2d(a + centre_rel), centre_rel.norm());
  };
  auto outside = [](const std::pair<Eigen::Vector2d, double>& c, const Eigen::Vector2d& q) {
    return (q - c.first).norm() > c.second * (1.0 + 1e-12) + 1e-15;
  };
  std::pair<Eigen::Vector2d, double> c(p[0], 0.0);
  for (size_t i = 1; i < p.size(); ++i) {
    if (!outside(c, p[i])) continue;
    c = {p[i], 0.0};
    for (size_t j = 0; j < i; ++j) {
      if (!outside(c, p[j])) continue;
      c = circle2(p[i], p[j]);
      for (size_t k = 0; k < j; ++k) {
        if (outside(c, p[k])) c = circle3(p[i], p[j], p[k]);
      }
    }
  }
  return c;
}

void CheckBalls(const std::vector<Ball>& balls) {
  if (balls.empty()) throw InputError("capsule fit: expected at least one point or ball, got none");
  for (size_t i = 0; i < balls.size(); ++i) {
    if (!balls[i].p_F.allFinite() || !std::isfinite(balls[i].radius) || balls[i].radius < 0.0) {
      throw InputError(fmt::format("capsule fit: ball {}: expected a finite centre and radius >= 0, got [{} {} {}] "
                                   "r={}", i, balls[i].p_F.x(), balls[i].p_F.y(), balls[i].p_F.z(), balls[i].radius));
    }
  }
}

// at most `limit` balls for the axis search: every k-th one plus the extreme ones along the coordinate axes.
std::vector<Ball> SearchSubset(const std::vector<Ball>& balls, size_t limit) {
  if (balls.size() <= limit) return balls;
  std::vector<Ball> subset;
  const size_t stride = (balls.size() + limit - 1) / limit;
  for (size_t i = 0; i < balls.size(); i += stride) subset.push_back(balls[i]);
  for (int a = 0; a < 3; ++a) {
    auto [lo, hi] = std::minmax_element(balls.begin(), balls.end(),
                                        [a](const Ball& x, const Ball& y) { return x.p_F[a] < y.p_F[a]; });
    subset.push_back(*lo);
    subset.push_back(*hi);
  }
  return subset;
}

}  // namespace

double CapsuleVolume(const math::Capsule& c) {
  return kPi * c.radius * c.radius * (c.p_WB - c.p_WA).norm() + 4.0 / 3.0 * kPi * std::pow(c.radius, 3);
}

double CapsuleSignedDistance(const math::Capsule& c, const Eigen::Vector3d& p_F) {
  const Eigen::Vector3d ab = c.p_WB - c.p_WA;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0.0 ? std::clamp((p_F - c.p_WA).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (p_F - (c.p_WA + t * ab)).norm() - c.radius;
}

math::Capsule CapsuleCoveringSphere(double radius) { return {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), radius}; }

math::Capsule CapsuleCoveringCylinder(double radius, double length) {
  const auto [h, R] = CylinderFamily(radius, 0.5 * length);
  return {Eigen::Vector3d(0, 0, -h), Eigen::Vector3d(0, 0, h), R};
}

math::Capsule CapsuleCoveringBox(const Eigen::Vector3d& size) {
  math::Capsule best;
  double best_volume = std::numeric_limits<double>::infinity();
  for (int axis = 0; axis < 3; ++axis) {
    const int i = (axis + 1) % 3, j = (axis + 2) % 3;
    const double rho = 0.5 * std::hypot(size[i], size[j]);
    const auto [h, R] = CylinderFamily(rho, 0.5 * size[axis]);
    math::Capsule c;
    c.p_WA[axis] = -h;
    c.p_WB[axis] = h;
    c.radius = R;
    if (CapsuleVolume(c) < best_volume) {
      best_volume = CapsuleVolume(c);
      best = c;
    }
  }
  return best;
}

math::Capsule CapsuleCoveringCapsule(double radius, double length) {
  return {Eigen::Vector3d(0, 0, -0.5 * length), Eigen::Vector3d(0, 0, 0.5 * length), radius};
}

math::Capsule FitCapsuleAlongAxis(const std::vector<Ball>& balls, const Eigen::Vector3d& u_F) {
  CheckBalls(balls);
  const Eigen::Vector3d u = u_F.normalized();
  const Eigen::Vector3d e1 = u.unitOrthogonal();
  const Eigen::Vector3d e2 = u.cross(e1);
  const size_t n = balls.size();
  std::vector<Eigen::Vector2d> q(n);
  for (size_t i = 0; i < n; ++i) q[i] = Eigen::Vector2d(e1.dot(balls[i].p_F), e2.dot(balls[i].p_F));
  const Eigen::Vector2d centre = SmallestEnclosingCircle(q).first;
  const Eigen::Vector3d o = centre.x() * e1 + centre.y() * e2;
  std::vector<double> t(n), d(n);
  double R0 = 0.0, t_min = std::numeric_limits<double>::infinity(), t_max = -t_min;
  for (size_t i = 0; i < n; ++i) {
    t[i] = u.dot(balls[i].p_F);
    d[i] = (q[i] - centre).norm();
    R0 = std::max(R0, d[i] + balls[i].radius);
    t_min = std::min(t_min, t[i]);
    t_max = std::max(t_max, t[i]);
  }
  // shortest covering segment [ta, tb] for radius R (ta > tb: a sphere anywhere in [tb, ta] covers everything)
  auto segment = [&](double R) {
    double ta = std::numeric_limits<double>::infinity(), tb = -ta;
    for (size_t i = 0; i < n; ++i) {
      const double reach = R - balls[i].radius;
      const double s = std::sqrt(std::max(0.0, reach * reach - d[i] * d[i]));
      ta = std::min(ta, t[i] + s);
      tb = std::max(tb, t[i] - s);
    }
    return std::make_pair(ta, tb);
  };
  auto volume = [&](double R) {
    const auto [ta, tb] = segment(R);
    return kPi * R * R * std::max(0.0, tb - ta) + 4.0 / 3.0 * kPi * R * R * R;
  };
  const double t_mid = 0.5 * (t_min + t_max);
  double R_sphere = R0;
  for (size_t i = 0; i < n; ++i) R_sphere = std::max(R_sphere, std::hypot(d[i], t[i] - t_mid) + balls[i].radius);
  const double R = MinimiseOnInterval(volume, R0, R_sphere);
  auto [ta, tb] = segment(R);
  if (ta > tb) ta = tb = 0.5 * (ta + tb);
  math::Capsule c;
  c.p_WA = o + ta * u;
  c.p_WB = o + tb * u;
  c.radius = R;
  return c;
}

Eigen::Matrix3d PrincipalAxes(const std::vector<Ball>& balls) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Ball& b : balls) mean += b.p_F;
  mean /= static_cast<double>(std::max<size_t>(balls.size(), 1));
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const Ball& b : balls) cov += (b.p_F - mean) * (b.p_F - mean).transpose();
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvectors();
}

math::Capsule FitCapsuleToBalls(const std::vector<Ball>& balls, const CapsuleFitOptions& options) {
  CheckBalls(balls);
  const std::vector<Ball> search = SearchSubset(balls, 3000);
  const Eigen::Matrix3d axes = PrincipalAxes(search);
  Eigen::Vector3d best_axis = axes.col(2);
  double best_volume = std::numeric_limits<double>::infinity();
  for (int k = 2; k >= 0; --k) {  // largest variance first
    const Eigen::Vector3d u = axes.col(k);
    const double v = CapsuleVolume(FitCapsuleAlongAxis(search, u));
    if (v < best_volume * (1.0 - 1e-9)) {
      best_volume = v;
      best_axis = u;
    }
  }
  if (options.refine_axis) {
    double step = options.angle_step;
    for (int round = 0; round < options.refine_rounds; ++round, step *= 0.5) {
      for (int move = 0; move < 4; ++move) {
        const Eigen::Vector3d e1 = best_axis.unitOrthogonal(), e2 = best_axis.cross(e1);
        Eigen::Vector3d round_best = best_axis;
        for (int k = 0; k < 8; ++k) {
          const double theta = 2.0 * kPi * k / 8.0;
          const Eigen::Vector3d u =
              (best_axis + std::tan(step) * (std::cos(theta) * e1 + std::sin(theta) * e2)).normalized();
          const double v = CapsuleVolume(FitCapsuleAlongAxis(search, u));
          if (v < best_volume * (1.0 - 1e-9)) {
            best_volume = v;
            round_best = u;
          }
        }
        if (round_best == best_axis) break;
        best_axis = round_best;
      }
    }
  }
  return FitCapsuleAlongAxis(balls, best_axis);
}

math::Capsule FitCapsuleToPoints(const Eigen::Matrix3Xd& p_F, const CapsuleFitOptions& options) {
  std::vector<Ball> balls(p_F.cols());
  for (Eigen::Index i = 0; i < p_F.cols(); ++i) balls[i].p_F = p_F.col(i);
  return FitCapsuleToBalls(balls, options);
}

}  // namespace rmpmarl::setup
