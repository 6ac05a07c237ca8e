// `cells`: procedurally generated work cells (shelf, box, table, under a table) around a static target at a
// collision-free joint goal, with cubes crossing on top.
#include <fmt/format.h>

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>

#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/rmp/scene.h"
#include "rmpmarl/sim/scenario.h"
#include "scenario_internal.h"

namespace rmpmarl::sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
using internal::EndEffector;
using internal::LowestMovingPoint;
using internal::MinSelfClearance;
using internal::Require;
using internal::Uniform;

double Uniform(std::mt19937_64& rng, const std::array<double, 2>& range) { return Uniform(rng, range[0], range[1]); }

void RequireRange(const std::array<double, 2>& r, const std::string& where, double lo, double hi) {
  if (!(std::isfinite(r[0]) && std::isfinite(r[1]) && r[0] >= lo && r[0] <= r[1] && r[1] <= hi)) {
    throw InputError(fmt::format("{}: expected a range [min, max] within [{}, {}], got [{}, {}]", where, lo, hi, r[0],
                                 r[1]));
  }
}

// the scene: num_panels boards, num_objects cubes, the object reached for, num_crossing crossing cubes, in that order
SceneSpec CellsScene(const CellsOptions& o) {
  SceneSpec spec;
  const Eigen::Vector3d half(0.5 * o.panel_length, 0.5 * o.panel_width, 0.5 * o.panel_thickness);
  for (int j = 0; j < std::max(0, o.num_panels); ++j) spec.obstacles.push_back(ObstacleSpec::Box(half));
  for (int j = 0; j < std::max(0, o.num_objects); ++j) spec.obstacles.push_back(ObstacleSpec::Cube(o.object_side));
  spec.obstacles.push_back(ObstacleSpec::Box(
      Eigen::Vector3d(o.grasp_object_half_width, o.grasp_object_half_width, o.grasp_object_half_length)));
  for (int j = 0; j < std::max(0, o.num_crossing); ++j) {
    spec.obstacles.push_back(ObstacleSpec::Cube(o.crossing_side));
  }
  spec.has_target = true;
  return spec;
}

// a board's orientation: its long side along `length`, its short side along `width` (unit, orthogonal)
Eigen::Matrix3d BoardFrame(const Eigen::Vector3d& length, const Eigen::Vector3d& width) {
  Eigen::Matrix3d R;
  R.col(0) = length;
  R.col(1) = width;
  R.col(2) = length.cross(width);
  return R;
}

}  // namespace

std::string_view CellKindName(CellKind kind) {
  switch (kind) {
    case CellKind::kShelf: return "shelf";
    case CellKind::kBox: return "box";
    case CellKind::kTable: return "table";
    case CellKind::kUnderTable: return "under-table";
  }
  return "?";
}

CellsScenario::CellsScenario(const kinematics::Robot& robot, const CellsOptions& options)
    : Scenario("cells", robot, CellsScene(options), 10.0, options.workspace, Eigen::VectorXd()),
      options_(options) {
  const std::string w = "CellsOptions";
  double total = 0.0;
  for (double k : options.kind_weights) {
    Require(std::isfinite(k) && k >= 0.0, w + ".kind_weights", "weights >= 0", k);
    total += k;
  }
  Require(total > 0.0, w + ".kind_weights", "at least one weight > 0", total);
  // the smallest sizes leave room for the target's margins inside every kind of cell (6–10 cm from its edges)
  Require(std::isfinite(options.panel_length) && options.panel_length >= 0.21 && options.panel_length <= 5.0,
          w + ".panel_length", "a length in [0.21, 5] m", options.panel_length);
  Require(std::isfinite(options.panel_width) && options.panel_width >= 0.17 && options.panel_width <= options.panel_length,
          w + ".panel_width", "a width in [0.17 m, panel_length]", options.panel_width);
  Require(std::isfinite(options.panel_thickness) && options.panel_thickness > 0.0 &&
              options.panel_thickness <= options.panel_width,
          w + ".panel_thickness", "a thickness in (0, panel_width] m", options.panel_thickness);
  Require(options.num_panels >= 6 && options.num_panels <= 16, w + ".num_panels", "an integer in [6, 16] (a shelf "
          "compartment with a board above or below takes 6)", options.num_panels);
  Require(options.num_objects >= 0 && options.num_objects <= 16, w + ".num_objects", "an integer in [0, 16]",
          options.num_objects);
  Require(std::isfinite(options.object_side) && options.object_side > 0.0 && options.object_side <= 0.3,
          w + ".object_side", "a side in (0, 0.3] m", options.object_side);
  Require(std::isfinite(options.grasp_object_probability) && options.grasp_object_probability >= 0.0 &&
              options.grasp_object_probability <= 1.0,
          w + ".grasp_object_probability", "a probability in [0, 1]", options.grasp_object_probability);
  Require(std::isfinite(options.grasp_object_half_width) && options.grasp_object_half_width > 0.0 &&
              options.grasp_object_half_width <= 0.3,
          w + ".grasp_object_half_width", "a half width in (0, 0.3] m", options.grasp_object_half_width);
  Require(std::isfinite(options.grasp_object_half_length) && options.grasp_object_half_length > 0.0 &&
              options.grasp_object_half_length <= 0.5,
          w + ".grasp_object_half_length", "a half length in (0, 0.5] m", options.grasp_object_half_length);
  RequireRange(options.grasp_clearance, w + ".grasp_clearance", 0.0, 0.2);
  RequireRange(options.opening_width, w + ".opening_width", 0.13, options.panel_length);
  RequireRange(options.opening_height, w + ".opening_height", 0.09, options.panel_width);
  RequireRange(options.depth, w + ".depth", 0.1, options.panel_width);
  RequireRange(options.box_size, w + ".box_size", 0.13, std::min(options.panel_length, 2.0 * options.panel_width));
  RequireRange(options.box_height, w + ".box_height", 0.02, options.panel_width);
  RequireRange(options.table_gap, w + ".table_gap", 0.02, 2.0);
  Require(options.num_crossing >= 0 && options.num_crossing <= 16, w + ".num_crossing", "an integer in [0, 16]",
          options.num_crossing);
  Require(std::isfinite(options.crossing_side) && options.crossing_side > 0.0, w + ".crossing_side", "> 0 m",
          options.crossing_side);
  Require(std::isfinite(options.crossing_speed) && options.crossing_speed > 0.0, w + ".crossing_speed", "> 0 m/s",
          options.crossing_speed);
  Require(std::isfinite(options.crossing_speed_max) && options.crossing_speed_max >= 0.0,
          w + ".crossing_speed_max", ">= 0 m/s (<= crossing_speed: every path at crossing_speed)",
          options.crossing_speed_max);
  Require(std::isfinite(options.min_base_distance) && options.min_base_distance >= 0.0,
          w + ".min_base_distance", ">= 0", options.min_base_distance);
  Require(std::isfinite(options.spawn_margin) && options.spawn_margin >= 0.0, w + ".spawn_margin", ">= 0",
          options.spawn_margin);
  Require(std::isfinite(options.start_spread) && options.start_spread >= 0.0 && options.start_spread <= M_PI,
          w + ".start_spread", "an angle in [0, pi] rad", options.start_spread);
  Require(std::isfinite(options.limit_margin) && options.limit_margin >= 0.0, w + ".limit_margin", ">= 0",
          options.limit_margin);
  Require(std::isfinite(options.min_target_distance) && options.min_target_distance >= 0.0,
          w + ".min_target_distance", ">= 0 m", options.min_target_distance);
  Require(std::isfinite(options.goal_clearance) && options.goal_clearance >= 0.0, w + ".goal_clearance", ">= 0 m",
          options.goal_clearance);
  Require(std::isfinite(options.start_clearance) && options.start_clearance >= 0.0, w + ".start_clearance",
          ">= 0 m", options.start_clearance);
  Require(options.max_attempts >= 1, w + ".max_attempts", ">= 1", options.max_attempts);
  if (workspace_.planar || robot.model.nq() < 3) {
    throw InputError(fmt::format("scenario 'cells': expected a spatial arm with at least 3 joints (cells are 3-D), got "
                                 "robot '{}' ({} joints{})", robot.name, robot.model.nq(),
                                 workspace_.planar ? ", planar" : ""));
  }
}

bool CellsScenario::BuildCell(CellKind kind, const kinematics::Data& start, const kinematics::Data& goal,
                              std::mt19937_64& rng) {
  const CellsOptions& o = options_;
  const kinematics::Model& m = robot_.model;
  const Eigen::Vector3d p_E = EndEffector(robot_, goal);
  // the way the hand comes in: from the wrist (the origin of the link the last-but-one joint moves) to the end effector
  const Eigen::Vector3d p_wrist = goal.X_WL[m.dof_link(m.nq() - 2)].translation();
  const Eigen::Vector3d approach = (p_E - p_wrist).normalized();
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  const Eigen::Vector2d base_h = p_E.head<2>();
  if (!(base_h.norm() > 0.25)) return false;  // not over the arm's own base
  Eigen::Vector3d x;  // horizontal, into the cell
  if (kind == CellKind::kShelf || kind == CellKind::kUnderTable) {
    if (std::abs(approach.z()) > 0.5) return false;  // reached from the front: a roughly horizontal approach
    x = Eigen::Vector3d(approach.x(), approach.y(), 0.0).normalized();
    if (x.head<2>().dot(base_h.normalized()) < 0.2) return false;  // opening towards the robot
  } else {
    if (approach.z() > (kind == CellKind::kBox ? -0.7 : -0.3)) return false;  // reached from above
    x = Eigen::Vector3d(base_h.x(), base_h.y(), 0.0).normalized();
  }
  const Eigen::Vector3d y = z.cross(x);
  const double T = o.panel_thickness, W = o.panel_width, L = o.panel_length;
  int panel = 0, object = 0;
  double support = -kInf;  // the height of the surface the target is above (a board, the box's floor, the table)
  double ceiling = kInf;   // the underside of a board above the target (a shelf's top, a table over it)
  auto place = [&](int j, const Eigen::Vector3d& c, const Eigen::Matrix3d& R) {
    obstacles_[j].p_start = c;
    obstacles_[j].R_WO = R;
  };
  auto board = [&](const Eigen::Vector3d& c, const Eigen::Vector3d& length, const Eigen::Vector3d& width) {
    RMPMARL_ASSERT(panel < o.num_panels, "CellsScenario: more boards than num_panels");
    place(panel++, c, BoardFrame(length, width));
  };
  // a cube resting on the horizontal surface through `centre`, within centre ± (hx x, hy y), clear of the target and
  // of the other cubes (none placed when 20 draws find no room)
  auto object_on = [&](const Eigen::Vector3d& centre, double hx, double hy) {
    if (object >= o.num_objects) return;
    const double half = 0.5 * o.object_side;
    if (hx < half || hy < half) return;
    for (int attempt = 0; attempt < 20; ++attempt) {
      const Eigen::Vector3d c = centre + Uniform(rng, -hx + half, hx - half) * x +
                                Uniform(rng, -hy + half, hy - half) * y + half * z;
      if ((c - p_E).norm() < 0.08 + half * std::sqrt(3.0)) continue;
      bool overlaps = false;
      for (int k = 0; k < object && !overlaps; ++k) {
        overlaps = (c - obstacles_[o.num_panels + k].p_start).norm() < o.object_side * 1.8;
      }
      if (overlaps) continue;
      const double yaw = Uniform(rng, 0.0, M_PI / 2);
      place(o.num_panels + object++, c, Eigen::AngleAxisd(yaw, z).toRotationMatrix());
      return;
    }
  };
  switch (kind) {
    case CellKind::kShelf: {
      const double w = Uniform(rng, o.opening_width), h = Uniform(rng, o.opening_height), D = Uniform(rng, o.depth);
      const double t = Uniform(rng, 0.03, D - 0.06);      // the target behind the opening
      const double u = Uniform(rng, -0.5 * w + 0.06, 0.5 * w - 0.06);
      const double v = Uniform(rng, 0.04, h - 0.04);      // above the bottom board
      if (!(D - 0.06 > 0.03) || !(0.5 * w > 0.06) || !(h > 0.08)) return false;
      const Eigen::Vector3d O = p_E - t * x - u * y - v * z;  // the opening's bottom edge, middle
      board(O + 0.5 * W * x - 0.5 * T * z, y, x);               // bottom
      support = O.z();
      board(O + 0.5 * W * x + (h + 0.5 * T) * z, y, x);         // top
      ceiling = O.z() + h;
      board(O + (D + 0.5 * T) * x + 0.5 * h * z, y, z);         // back
      for (double side : {-1.0, 1.0}) board(O + 0.5 * W * x + side * (0.5 * w + 0.5 * T) * y + 0.5 * h * z, z, x);
      // the next compartment's board, above or below
      const double h2 = Uniform(rng, o.opening_height);
      const bool above = std::bernoulli_distribution(0.5)(rng);
      board(O + 0.5 * W * x + (above ? h + T + h2 + 0.5 * T : -(T + h2 + 0.5 * T)) * z, y, x);
      object_on(O + 0.5 * D * x, 0.5 * D, 0.5 * w);
      break;
    }
    case CellKind::kBox: {
      const double lx = Uniform(rng, o.box_size), ly = Uniform(rng, o.box_size), H = Uniform(rng, o.box_height);
      const double v = Uniform(rng, 0.03, std::max(0.04, H));  // the target above the box floor
      const double ox = Uniform(rng, -0.5 * lx + 0.06, 0.5 * lx - 0.06);
      const double oy = Uniform(rng, -0.5 * ly + 0.06, 0.5 * ly - 0.06);
      if (!(0.5 * lx > 0.06) || !(0.5 * ly > 0.06)) return false;
      const Eigen::Vector3d C = p_E - ox * x - oy * y - v * z;  // the floor's top, middle
      if (C.z() < 0.0) return false;                             // the box stands on the base plane or above it
      for (double half : {-0.5, 0.5}) board(C + half * W * x - 0.5 * T * z, y, x);  // floor: two boards side by side
      support = C.z();
      for (double side : {-1.0, 1.0}) {                          // walls, their top edge H above the floor
        board(C + side * (0.5 * lx + 0.5 * T) * x + (H - 0.5 * W) * z, y, z);
        board(C + side * (0.5 * ly + 0.5 * T) * y + (H - 0.5 * W) * z, x, z);
      }
      object_on(C, 0.5 * lx, 0.5 * ly);
      break;
    }
    case CellKind::kTable: {
      const double v = Uniform(rng, 0.03, 0.15);  // the target above the table top
      const double ox = Uniform(rng, -0.5 * W + 0.08, 0.5 * W - 0.08), oy = Uniform(rng, -0.5 * L + 0.1, 0.5 * L - 0.1);
      const Eigen::Vector3d C = p_E - ox * x - oy * y - v * z;  // the top's surface, middle
      if (C.z() < 0.0) return false;
      board(C - 0.5 * T * z, y, x);
      support = C.z();
      if (std::bernoulli_distribution(0.5)(rng)) board(C + (0.5 * W + 0.5 * T) * x + (0.5 * W - 0.02) * z, y, z);  // a wall behind
      for (int k = 0; k < o.num_objects; ++k) object_on(C, 0.5 * W, 0.5 * L);
      break;
    }
    case CellKind::kUnderTable: {
      const double g = Uniform(rng, o.table_gap);       // the top's underside above the target
      const double t = Uniform(rng, 0.05, W - 0.08);   // the target under it, this far in from its front edge
      const double u = Uniform(rng, -0.5 * L + 0.1, 0.5 * L - 0.1);
      const Eigen::Vector3d F = p_E - t * x - u * y;   // below the front edge's middle, at the target's height
      board(F + 0.5 * W * x + (g + 0.5 * T) * z, y, x);
      ceiling = F.z() + g;
      if (std::bernoulli_distribution(0.5)(rng)) {  // a board below (a lower shelf) with objects on it
        const double b = Uniform(rng, 0.04, 0.2);
        if (F.z() - b < 0.0) return false;
        board(F + 0.5 * W * x - (b + 0.5 * T) * z, y, x);
        support = F.z() - b;
        object_on(F + 0.5 * W * x - b * z, 0.5 * W, 0.5 * L);
      }
      break;
    }
  }
  if (std::bernoulli_distribution(o.grasp_object_probability)(rng)) {
    // ahead of the hand in a shelf or under a table, beside it in a random direction on a table or in a box
    Eigen::Vector3d dir = x;
    if (kind == CellKind::kBox || kind == CellKind::kTable) {
      const double angle = Uniform(rng, 0.0, 2.0 * M_PI);
      dir = std::cos(angle) * x + std::sin(angle) * y;
    }
    if (!PlaceGraspObject(goal, p_E, dir, support, ceiling, rng)) return false;
  }
  return ClearOfCell(start, goal);
}

bool CellsScenario::PlaceGraspObject(const kinematics::Data& goal, const Eigen::Vector3d& p_E,
                                     const Eigen::Vector3d& dir, double support, double ceiling,
                                     std::mt19937_64& rng) {
  // beside the hand at a drawn clearance (bisection along `dir`, the box turned to face the way it is approached),
  // standing on the cell's surface when the hand is within its height above it, else centred at the hand's height;
  // left out (parked) where it would not fit under the board above or could not come as close as drawn
  const CellsOptions& o = options_;
  const int grasp = o.grasp_object_index();
  const double hl = o.grasp_object_half_length, r = o.grasp_object_half_width;
  const double zc = p_E.z() - support < 2.0 * hl ? support + hl : p_E.z();
  const double want = Uniform(rng, o.grasp_clearance);
  if (zc + hl > ceiling) return true;
  auto at = [&](double s) {
    const Eigen::Vector3d c = p_E + s * dir;
    obstacles_[grasp].p_start = Eigen::Vector3d(c.x(), c.y(), zc);
    obstacles_[grasp].R_WO = BoardFrame(dir, Eigen::Vector3d::UnitZ().cross(dir));
    return RobotClearance(goal, ObstacleAsRmp(grasp));
  };
  double lo = std::sqrt(2.0) * r + 0.005, hi = 0.5;  // never around the target itself
  if (at(hi) < want) return false;
  const double nearest = at(lo);
  if (nearest > o.grasp_clearance[1]) {  // the hand keeps it farther than the clearances drawn from
    obstacles_[grasp] = ObstacleState{};
    return true;
  }
  if (nearest < want) {
    for (int it = 0; it < 30; ++it) {
      const double mid = 0.5 * (lo + hi);
      (at(mid) < want ? lo : hi) = mid;
    }
  } else {
    hi = lo;
  }
  at(hi);
  // not into a board: the capsule around its vertical axis through its top and bottom faces' centres (radius: the
  // half diagonal of its cross-section) clear of every board
  const double R = std::sqrt(2.0) * r;
  const Eigen::Vector3d c = obstacles_[grasp].p_start;
  const math::Capsule around{c - std::max(0.0, hl - R) * Eigen::Vector3d::UnitZ(),
                             c + std::max(0.0, hl - R) * Eigen::Vector3d::UnitZ(), R};
  for (int j = 0; j < o.num_panels; ++j) {
    if (obstacles_[j].p_start == ParkedPose().translation()) continue;
    if (rmp::CapsuleObstacleDistance(around, ObstacleAsRmp(j)).distance < -1e-6) {
      obstacles_[grasp] = ObstacleState{};
      return true;
    }
  }
  return true;
}

bool CellsScenario::ClearOfCell(const kinematics::Data& start, const kinematics::Data& goal) const {
  // every placed board and object clear of the arm at the goal (the object reached for at its own clearance) and at
  // the start
  const CellsOptions& o = options_;
  for (int j = 0; j < o.grasp_object_index() + 1; ++j) {
    if (obstacles_[j].p_start == ParkedPose().translation()) continue;
    const rmp::Obstacle obstacle = ObstacleAsRmp(j);
    if (j != o.grasp_object_index() && RobotClearance(goal, obstacle) < o.goal_clearance) return false;
    if (RobotClearance(start, obstacle) < o.start_clearance) return false;
  }
  return true;
}

void CellsScenario::DrawCrossingPath(int j, std::mt19937_64& rng) {
  DrawHorizontalCrossing(j,
                         {options_.min_base_distance, options_.spawn_margin, options_.crossing_speed,
                          options_.crossing_speed_max, "CellsOptions.min_base_distance"},
                         rng);
}

void CellsScenario::OnPathEnd(int j, std::mt19937_64& rng) {
  if (j <= options_.grasp_object_index()) return;  // the cell stays
  const int paths = obstacles_[j].paths;
  DrawCrossingPath(j, rng);
  obstacles_[j].paths = paths + 1;
}

void CellsScenario::Draw(std::mt19937_64& rng) {
  const CellsOptions& o = options_;
  const kinematics::Model& m = robot_.model;
  const Eigen::VectorXd ready = ReadyConfiguration(robot_);
  kinematics::Data start(m), goal(m);
  Eigen::Matrix3Xd J(3, m.nq());
  std::discrete_distribution<int> kinds(o.kind_weights.begin(), o.kind_weights.end());
  const int fixed = o.grasp_object_index() + 1;  // the cell's obstacles; the crossing cubes after them
  q_goal_.resize(m.nq());
  // the kind first, then draws until one of it fits: every kind as often as its weight says, however hard it is to fit
  kind_ = static_cast<CellKind>(kinds(rng));
  for (int attempt = 0; attempt < o.max_attempts; ++attempt) {
    for (int j = 0; j < fixed; ++j) obstacles_[j] = ObstacleState{};
    // the start: the ready posture, spread
    q_start_ = ready;
    for (int i = 0; i < m.nq(); ++i) {
      const auto& l = m.limits()[i];
      q_start_[i] = std::clamp(ready[i] + Uniform(rng, -o.start_spread, o.start_spread), l.lower, l.upper);
    }
    kinematics::CalcForwardKinematics(m, q_start_, &start);
    if (MinSelfClearance(checker_, start) < 0.01) continue;
    const Eigen::Vector3d p_start = EndEffector(robot_, start);
    // the goal: uniform within the limits, not singular, clear of itself and above the base plane
    for (int i = 0; i < m.nq(); ++i) {
      const auto [lo, hi] = internal::SamplingRange(m.limits()[i]);
      q_goal_[i] = hi - lo > 2.0 * o.limit_margin ? Uniform(rng, lo + o.limit_margin, hi - o.limit_margin)
                                                  : 0.5 * (lo + hi);
    }
    kinematics::CalcForwardKinematics(m, q_goal_, &goal);
    const Eigen::Vector3d p = EndEffector(robot_, goal);
    if ((p - p_start).norm() < o.min_target_distance) continue;
    if (LowestMovingPoint(robot_, goal) < 0.05 || MinSelfClearance(checker_, goal) < 0.01) continue;
    kinematics::CalcPointJacobian(m, goal, robot_.end_effector.link, robot_.end_effector.X_LE.translation(), J);
    if (Eigen::JacobiSVD<Eigen::MatrixXd>(Eigen::MatrixXd(J)).singularValues().minCoeff() < 0.05) continue;
    if (!BuildCell(kind_, start, goal, rng)) continue;
    target_.p_WT = p;
    target_.v_WT.setZero();
    joint_goal_ = o.joint_goal ? q_goal_ : Eigen::VectorXd();
    for (int j = fixed; j < num_obstacles(); ++j) {
      DrawCrossingPath(j, rng);
      obstacles_[j].s = -Uniform(rng, 0.0, 0.5) * obstacles_[j].path_length;  // staggered arrivals
    }
    return;
  }
  throw InputError(fmt::format("scenario 'cells' (robot '{}'): found no {} cell and joint goal satisfying "
                               "CellsOptions in {} draws; expected looser options (clearances, sizes) or a zero "
                               "weight for that kind", robot_.name, CellKindName(kind_), o.max_attempts));
}

}  // namespace rmpmarl::sim
