// The pre-training scenario: moving target, one cube beside (or on) its path.
#include "rmpmarl/sim/pretrain_scenario.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "rmpmarl/common/error.h"

namespace rmpmarl::sim {
namespace {

SceneSpec PretrainScene(const PretrainScenarioOptions& o) {
  SceneSpec spec;
  spec.obstacles.push_back(ObstacleSpec::Cube(o.obstacle_side));
  spec.has_target = true;
  return spec;
}

double Uniform(std::mt19937_64& rng, const std::array<double, 2>& range) {
  return range[1] > range[0] ? std::uniform_real_distribution<double>(range[0], range[1])(rng) : range[0];
}

}  // namespace

Eigen::Vector3d ReflectedPosition(const Eigen::Vector3d& p, const Eigen::Vector3d& v, double t,
                                  const Eigen::AlignedBox3d& box) {
  Eigen::Vector3d out;
  for (int a = 0; a < 3; ++a) {
    const double lo = box.min()[a], hi = box.max()[a];
    if (!(hi > lo)) {
      out[a] = lo;
      continue;
    }
    // unfold: a triangle wave of period 2L over the box
    const double L = hi - lo;
    double x = std::fmod(p[a] - lo + v[a] * t, 2.0 * L);
    if (x < 0.0) x += 2.0 * L;
    out[a] = lo + (x <= L ? x : 2.0 * L - x);
  }
  return out;
}

Eigen::Vector3d ReflectedDirection(const Eigen::Vector3d& p, const Eigen::Vector3d& v, double t,
                                   const Eigen::AlignedBox3d& box) {
  Eigen::Vector3d d = Eigen::Vector3d::Zero();
  for (int a = 0; a < 3; ++a) {
    const double lo = box.min()[a], hi = box.max()[a];
    if (!(hi > lo)) continue;  // pinned axis (ReflectedPosition)
    // the unfolded coordinate runs forward on the first half of each 2L period, backward on the second
    const double L = hi - lo;
    double x = std::fmod(p[a] - lo + v[a] * t, 2.0 * L);
    if (x < 0.0) x += 2.0 * L;
    d[a] = x <= L ? v[a] : -v[a];
  }
  const double n = d.norm();
  return n > 0.0 ? Eigen::Vector3d(d / n) : d;
}

double PathCubeClearance(const Eigen::Vector3d& p, const Eigen::Vector3d& v, double duration,
                         const Eigen::AlignedBox3d& box, const Eigen::Vector3d& c, double h) {
  const double speed = v.norm();
  const int samples = speed > 0.0 ? 1 + static_cast<int>(std::ceil(speed * duration / 0.002)) : 1;
  double d = std::numeric_limits<double>::infinity();
  for (int k = 0; k <= samples; ++k) {
    const double t = samples > 0 ? duration * k / samples : 0.0;
    const Eigen::Vector3d x = ReflectedPosition(p, v, t, box);
    // point–box distance: the norm of the per-axis excess over the half side
    d = std::min(d, ((x - c).cwiseAbs().array() - h).max(0.0).matrix().norm());
  }
  return d;
}

void ValidatePretrainScenarioOptions(const PretrainScenarioOptions& o, std::string_view where) {
  const auto check = [&](bool ok, std::string_view key, std::string_view expected, const auto& got) {
    if (!ok) throw InputError(fmt::format("{}.{}: expected {}, got {}", where, key, expected, got));
  };
  const auto range = [&](const std::array<double, 2>& r, std::string_view key, double lo, double hi) {
    check(std::isfinite(r[0]) && std::isfinite(r[1]) && r[0] >= lo && r[0] <= r[1] && r[1] <= hi, key,
          fmt::format("[min, max] with {} <= min <= max <= {}", lo, hi), fmt::format("[{}, {}]", r[0], r[1]));
  };
  range(o.target_speed, "target_speed", 0.0, 10.0);
  check(std::isfinite(o.obstacle_side) && o.obstacle_side > 0.0, "obstacle_side", "a side > 0 m", o.obstacle_side);
  range(o.obstacle_lead_time, "obstacle_lead_time", 0.0, 1000.0);
  range(o.obstacle_path_offset, "obstacle_path_offset", 0.0, 10.0);
  range(o.obstacle_speed, "obstacle_speed", 0.0, 10.0);
  check(std::isfinite(o.start_clearance), "start_clearance", "a finite distance", o.start_clearance);
  check(std::isfinite(o.target_clearance), "target_clearance", "a finite distance", o.target_clearance);
  check(o.max_attempts >= 1, "max_attempts", "an integer >= 1", o.max_attempts);
}

PretrainScenario::PretrainScenario(const kinematics::Robot& robot, const PretrainScenarioOptions& options)
    : Scenario("pretrain-2link", robot, PretrainScene(options), 8.0, options.workspace, Eigen::VectorXd()),
      options_(options),
      ready_(q_start_) {
  ValidatePretrainScenarioOptions(options, "PretrainScenarioOptions");
}

void PretrainScenario::SetNextStart(const Eigen::VectorXd& q0) {
  const kinematics::Model& m = robot_.model;
  if (q0.size() == 0) {
    q_start_ = ready_;
    return;
  }
  if (q0.size() != m.nq() || !q0.allFinite()) {
    throw InputError(fmt::format("PretrainScenario::SetNextStart: expected {} finite values, got {}", m.nq(),
                                 q0.size()));
  }
  q_start_ = q0.cwiseMax(m.LowerLimits()).cwiseMin(m.UpperLimits());
}

void PretrainScenario::Draw(std::mt19937_64& rng) {
  const PretrainScenarioOptions& o = options_;
  const double half_diagonal = 0.5 * o.obstacle_side * std::sqrt(3.0);
  double best_clearance = -std::numeric_limits<double>::infinity();
  TargetState best_target;
  Eigen::Vector3d best_p = Eigen::Vector3d::Zero();
  for (int attempt = 0; attempt < o.max_attempts; ++attempt) {
    const TargetState t = RandomMovingTarget(Uniform(rng, o.target_speed), rng);
    const double lead = Uniform(rng, o.obstacle_lead_time);
    Eigen::Vector3d p = ReflectedPosition(t.p_WT, t.v_WT, lead, t.bounds);
    if (o.obstacle_path_offset[1] > 0.0) {
      // beside the path: move the cube along a random unit normal n of the motion there until its surface is
      // `offset` from the path point (the support of an axis-aligned cube along n is h |n|_1)
      const double offset = Uniform(rng, o.obstacle_path_offset);
      const Eigen::Vector3d d = ReflectedDirection(t.p_WT, t.v_WT, lead, t.bounds);
      Eigen::Vector3d n = RandomDirection(rng);
      n -= n.dot(d) * d;
      if (n.norm() < 1e-6) continue;
      n.normalize();
      p += (offset + 0.5 * o.obstacle_side * n.lpNorm<1>()) * n;
      if (PathCubeClearance(t.p_WT, t.v_WT, default_duration(), t.bounds, p, 0.5 * o.obstacle_side) <
          o.obstacle_path_offset[0] - 1e-9) {
        continue;  // the reflected path comes back closer elsewhere
      }
    }
    if ((p - t.p_WT).norm() - half_diagonal < o.target_clearance) continue;
    const double clearance = RobotClearance(q_start_, 0, p);
    if (clearance > best_clearance) {
      best_clearance = clearance;
      best_target = t;
      best_p = p;
    }
    if (clearance >= o.start_clearance) break;
  }
  if (!std::isfinite(best_clearance) && o.obstacle_path_offset[1] > 0.0) {
    throw InputError(fmt::format("scenario pretrain-2link: no draw in {} attempts kept the cube {}–{} m beside the "
                                 "target's path and clear of its start; expected a smaller scenario.obstacle_path_offset",
                                 o.max_attempts, o.obstacle_path_offset[0], o.obstacle_path_offset[1]));
  }
  if (!std::isfinite(best_clearance)) {  // no draw kept its distance from the target: use a last plain draw
    best_target = RandomMovingTarget(Uniform(rng, o.target_speed), rng);
    best_p = ReflectedPosition(best_target.p_WT, best_target.v_WT, Uniform(rng, o.obstacle_lead_time),
                               best_target.bounds);
  }
  target_ = best_target;
  ObstacleState& cube = obstacles_[0];
  cube.p_start = best_p;
  cube.R_WO.setIdentity();
  cube.s = 0.0;
  cube.speed = Uniform(rng, o.obstacle_speed);
  cube.direction = cube.speed > 0.0 ? RandomDirection(rng) : Eigen::Vector3d::UnitX();
  cube.path_length = cube.speed > 0.0 ? 100.0 : 0.0;  // far beyond any episode: it just keeps going
  cube.wrap = 0.0;
  if (o.obstacle_out_of_reach) cube.p_start.z() += 10.0;  // after every draw: the episode is otherwise the same
}

}  // namespace rmpmarl::sim
