// Plan, then react: RRT-Connect's joint path as the moving target of a reactive layer (or executed open loop).
#include "rmpmarl/planning/plan_follow.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "rmpmarl/common/error.h"

namespace rmpmarl::planning {
namespace {

constexpr double kTimeEpsilon = 1e-9;

void Require(bool ok, std::string_view field, std::string_view expected, double got) {
  if (!ok) throw InputError(fmt::format("PlanFollowOptions.{}: expected {}, got {}", field, expected, got));
}

bool PositiveFinite(double v) { return std::isfinite(v) && v > 0.0; }

}  // namespace

void ValidatePlanFollowOptions(const PlanFollowOptions& o) {
  ValidateRrtOptions(o.planner);
  Require(PositiveFinite(o.lookahead), "lookahead", "a finite distance > 0", o.lookahead);
  Require(PositiveFinite(o.corner_velocity_jump), "corner_velocity_jump", "a finite velocity > 0",
          o.corner_velocity_jump);
  Require(PositiveFinite(o.posture_metric), "posture_metric", "a finite metric > 0", o.posture_metric);
  Require(o.yield_metric > 0.0 && o.yield_metric <= o.posture_metric, "yield_metric",
          fmt::format("a metric in (0, posture_metric = {}]", o.posture_metric), o.yield_metric);
  Require(o.yield_near >= 0.0 && std::isfinite(o.yield_near), "yield_near", "a finite distance >= 0 m", o.yield_near);
  Require(o.yield_far > o.yield_near && std::isfinite(o.yield_far), "yield_far",
          fmt::format("a finite distance > yield_near = {} m", o.yield_near), o.yield_far);
  Require(PositiveFinite(o.stall_time), "stall_time", "a finite time > 0 s", o.stall_time);
  Require(PositiveFinite(o.check_period), "check_period", "a finite period > 0 s", o.check_period);
  Require(PositiveFinite(o.goal_tolerance), "goal_tolerance", "a finite distance > 0", o.goal_tolerance);
  Require(PositiveFinite(o.goal_shift), "goal_shift", "a finite distance > 0", o.goal_shift);
  Require(PositiveFinite(o.approach_distance), "approach_distance", "a finite distance > 0", o.approach_distance);
}

PlanFollowPolicy::PlanFollowPolicy(const kinematics::Robot& robot,
                                   std::unique_ptr<control::AccelerationPolicy> reactive,
                                   const PlanFollowOptions& options)
    : robot_(robot), reactive_(std::move(reactive)), options_(options), planner_(robot, options.planner),
      kin_(robot.model), checker_(robot, {options.planner.check_floor, options.planner.floor_height}), placed_(checker_) {
  ValidatePlanFollowOptions(options_);
  if (reactive_ == nullptr) {  // open loop: planned once, inside the call
    options_.replan = false;
    options_.plan_beside_loop = false;
  }
  const int nq = robot_.model.nq();
  if (reactive_ != nullptr && reactive_->nq() != nq) {
    throw InputError(fmt::format("PlanFollowPolicy: the reactive layer '{}' has {} joints, robot '{}' has {}",
                                 reactive_->name(), reactive_->nq(), robot_.name, nq));
  }
  v_path_.resize(nq);
  for (int i = 0; i < nq; ++i) {
    v_path_[i] = options_.planner.path_speed_fraction * robot_.model.limits()[i].velocity;  // > 0: RrtPolicy checked
  }
  q_goal_.setZero(nq);
  q_d_.setZero(nq);
  qd_d_.setZero(nq);
  qdd_d_.setZero(nq);
  J_WE_.setZero(3, nq);
  q_check_.setZero(nq);
  follow_.q_T.setZero(nq);
}

PlanFollowPolicy::~PlanFollowPolicy() { DropPlan(); }

std::string PlanFollowPolicy::name() const { return reactive_ ? "plan+" + reactive_->name() : "rrt-connect"; }

int PlanFollowPolicy::nq() const { return robot_.model.nq(); }

void PlanFollowPolicy::Reset(const Eigen::Ref<const Eigen::VectorXd>& q0) {
  DropPlan();  // the last episode's
  planner_.Reset(q0);
  if (reactive_) reactive_->Reset(q0);
  stats_ = PlanFollowStats{};
  path_.clear();
  path_times_.clear();
  q_d_ = q0;
  qd_d_.setZero();
  time_ = tau_ = 0.0;
  yield_ = 1.0;
  last_progress_ = last_check_ = 0.0;
  last_attempt_ = -1e9;
  planned_once_ = false;
  has_goal_ = false;
}

const char* PlanOutcomeName(PlanOutcome outcome) {
  switch (outcome) {
    case PlanOutcome::kPlanned:
      return "planned";
    case PlanOutcome::kNoGoal:
      return "no goal configuration";
    case PlanOutcome::kGoalInCollision:
      return "goal in collision";
    case PlanOutcome::kNoPath:
      return "no path within the budget";
    case PlanOutcome::kNone:
      break;
  }
  return "not yet";
}

void PlanFollowPolicy::BeginAttempt(const rmp::Scene& scene) {
  ++stats_.plans_attempted;
  last_attempt_ = time_;
  planned_once_ = true;
  planned_q_T_ = scene.q_T;
  planned_p_WT_ = scene.p_WT;
}

PlanFollowPolicy::PlanResult PlanFollowPolicy::ComputePlan(const PlanRequest& request, const rmp::Scene& scene) {
  PlanResult r;
  // the goal: the scene's joint goal, else a valid IK configuration at its target (else the one known before)
  r.has_goal = request.has_goal;
  r.q_goal = request.q_goal;
  if (scene.q_T.size() > 0) {
    r.q_goal = scene.q_T;
    r.has_goal = true;
  } else if (scene.has_target) {
    const IkResult ik = planner_.SolveIk(request.q, scene);
    r.has_goal = ik.found && ik.reached;
    if (r.has_goal) r.q_goal = ik.q;
  }
  if (!r.has_goal) {
    ++r.goal_failures;
    r.outcome = PlanOutcome::kNoGoal;
    return r;
  }
  // from the arm; from a start too close to something (the reactive layer holds a few cm), from the reference
  r.path = planner_.PlanPath(request.q, r.q_goal, scene);
  if (r.path.empty() && request.q_reference.size() > 0) r.path = planner_.PlanPath(request.q_reference, r.q_goal, scene);
  r.margin = planner_.last_plan_margin();  // the path is checked against what it was planned with
  r.outcome = PlanOutcome::kNoPath;
  if (r.path.empty() && !planner_.IsStateValid(r.q_goal, scene)) {
    ++r.goal_failures;
    r.outcome = PlanOutcome::kGoalInCollision;
  }
  if (!r.path.empty()) r.outcome = PlanOutcome::kPlanned;
  return r;
}

void PlanFollowPolicy::AdoptPlan(PlanResult result, double seconds) {
  has_goal_ = result.has_goal;
  if (has_goal_) {
    q_goal_ = std::move(result.q_goal);
    p_WG_ = EndEffectorAt(q_goal_);
    plan_margin_ = result.margin;
  }
  stats_.goal_failures += result.goal_failures;
  stats_.last_outcome = result.outcome;
  if (!result.path.empty()) {
    path_ = std::move(result.path);
    path_times_ = PathArrivalTimes(path_, v_path_);
    path_s_ = PathArcLengths(path_);
    CornerSpeeds();
    s_near_ = s_ref_ = 0.0;
    segment_ = 0;
    if (stats_.plans_succeeded == 0) stats_.first_path_length = path_s_.back();
    ++stats_.plans_succeeded;
    tau_ = 0.0;
    last_progress_ = last_check_ = time_;
  } else {
    // no new path: the old one is stale (stalled, blocked or for another goal); the reactive layer goes for the
    // scene's goal until a plan succeeds
    path_.clear();
  }
  stats_.planning_times_s.push_back(seconds);
}

void PlanFollowPolicy::StartPlan(const Eigen::Ref<const Eigen::VectorXd>& q, const rmp::Scene& scene) {
  const auto start = std::chrono::steady_clock::now();
  BeginAttempt(scene);
  PlanRequest request{.q = q, .q_reference = {}, .has_goal = has_goal_, .q_goal = q_goal_};
  if (!path_.empty() && !(q_d_ - q).isZero()) request.q_reference = q_d_;
  if (!options_.plan_beside_loop) {
    PlanResult result = ComputePlan(request, scene);
    AdoptPlan(std::move(result), std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    return;
  }
  // the worker's own copy of the scene: the caller's changes at the next step
  pending_ = std::async(std::launch::async, [this, request = std::move(request), scene_copy = scene, start] {
    PlanResult result = ComputePlan(request, scene_copy);
    return std::make_pair(std::move(result),
                          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  });
}

void PlanFollowPolicy::PollPlan() {
  if (!pending_.valid() || pending_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return;
  auto [result, seconds] = pending_.get();
  AdoptPlan(std::move(result), seconds);
}

void PlanFollowPolicy::DropPlan() {
  if (!pending_.valid()) return;
  pending_.wait();
  pending_ = {};  // its result, or what it threw, goes unread
}

Eigen::Vector3d PlanFollowPolicy::EndEffectorAt(const Eigen::Ref<const Eigen::VectorXd>& q) {
  const kinematics::EndEffector& ee = robot_.end_effector;
  kinematics::CalcForwardKinematics(robot_.model, q, &kin_);
  return kinematics::CalcPointPosition(kin_, ee.link, ee.X_LE.translation());
}

void PlanFollowPolicy::PointAt(double s) {
  const int last = static_cast<int>(path_.size()) - 1;
  qd_d_.setZero();
  qdd_d_.setZero();
  if (last <= 0 || s >= path_s_[last]) {
    q_d_ = path_[std::max(last, 0)];
    return;
  }
  const PathLocation at = LocateOnPath(path_s_, s);
  const int k = at.segment;
  const double length = path_s_[k + 1] - path_s_[k];
  q_d_ = path_[k] + at.fraction * (path_[k + 1] - path_[k]);
  if (length <= 0.0) return;
  // the reference's velocity: along the segment at most at its speed, and within `lookahead` of a waypoint (any
  // waypoint, not only the segment's ends) or of the path's end at most on a ramp from the waypoint's speed (0 at the
  // end) up to the path's top speed: the speed is continuous in s, its slope at most top speed / lookahead; and its
  // acceleration: rate · d(rate)/ds along the segment, d(rate)/ds the slope of the ramp that limits it
  const double L = options_.lookahead;
  double rate = path_segment_speed_[k], slope = 0.0;
  // a ramp `distance` before (sign −1) or after (+1) a point of speed `corner` that limits the rate more
  auto limit = [&](double corner, double distance, double span, double sign) {
    const double r = Ramp(corner, distance, span);
    if (r < rate) {
      rate = r;
      slope = distance < span ? sign * (path_top_speed_ - corner) / span : 0.0;
    }
  };
  limit(0.0, path_s_[last] - s, options_.approach_distance, -1.0);  // to rest at the path's end
  for (int j = k; j >= 1 && path_s_[j] > s - L; --j) limit(path_corner_speed_[j], s - path_s_[j], L, 1.0);
  for (int j = k + 1; j < last && path_s_[j] < s + L; ++j) limit(path_corner_speed_[j], path_s_[j] - s, L, -1.0);
  qd_d_ = (rate / length) * (path_[k + 1] - path_[k]);
  qdd_d_ = (rate * slope / length) * (path_[k + 1] - path_[k]);
}

double PlanFollowPolicy::Ramp(double corner, double distance, double length) const {
  return corner + (path_top_speed_ - corner) * std::min(1.0, distance / length);
}

void PlanFollowPolicy::CornerSpeeds() {
  // each segment's speed: its slowest joint at the path speed
  const size_t n = path_.size();
  path_segment_speed_.assign(n, 0.0);
  path_top_speed_ = 0.0;
  for (size_t k = 0; k + 1 < n; ++k) {
    const double length = path_s_[k + 1] - path_s_[k];
    if (length > 0.0) {
      path_segment_speed_[k] = 1.0 / ((path_[k + 1] - path_[k]).cwiseAbs().cwiseQuotient(v_path_) / length).maxCoeff();
      path_top_speed_ = std::max(path_top_speed_, path_segment_speed_[k]);
    }
  }
  // the speed at each interior waypoint: at most the slower of its two segments', and such that the velocity turns by
  // at most corner_velocity_jump: |q̇_out − q̇_in| = ṡ · |d_out − d_in| for unit directions d
  path_corner_speed_.assign(n, path_top_speed_);  // the ends and waypoints between zero-length segments: no limit
  for (size_t k = 1; k + 1 < n; ++k) {
    const double l_in = path_s_[k] - path_s_[k - 1], l_out = path_s_[k + 1] - path_s_[k];
    if (!(l_in > 0.0) || !(l_out > 0.0)) continue;
    double corner = std::min(path_segment_speed_[k - 1], path_segment_speed_[k]);
    const double turn = ((path_[k + 1] - path_[k]) / l_out - (path_[k] - path_[k - 1]) / l_in).norm();
    if (turn > 1e-12) corner = std::min(corner, options_.corner_velocity_jump / turn);
    path_corner_speed_[k] = corner;
  }
}

void PlanFollowPolicy::Reference() {
  // never behind the arm's nearest point, at most lookahead ahead of it; full path speed up to half of that lead
  s_ref_ = std::clamp(s_ref_, s_near_, s_near_ + options_.lookahead);
  PointAt(s_ref_);
  const double lead = s_ref_ - s_near_;
  const double lead_scale = std::clamp(2.0 * (options_.lookahead - lead) / options_.lookahead, 0.0, 1.0);
  qd_d_ *= lead_scale;
  // the acceleration scaled as the rate and the speed along the path both are (the scales' own rates of change left
  // out: where the arm lags or yields, the feed-forward is an approximation)
  qdd_d_ *= lead_scale * lead_scale;
  if (options_.yield_slows) {
    qd_d_ *= yield_;
    qdd_d_ *= yield_ * yield_;
  }
}

void PlanFollowPolicy::Project(const Eigen::Ref<const Eigen::VectorXd>& q) {
  // the nearest point on the segments from the current one to lookahead beyond the last (never behind the last)
  const int last = static_cast<int>(path_.size()) - 1;
  if (last <= 0) return;
  double best = std::numeric_limits<double>::infinity(), best_s = s_near_;
  int best_k = segment_;
  for (int k = segment_; k < last && path_s_[k] <= s_near_ + options_.lookahead; ++k) {
    const Eigen::VectorXd& a = path_[k];
    const Eigen::VectorXd& b = path_[k + 1];
    const double length = path_s_[k + 1] - path_s_[k];
    double f = length > 0.0 ? std::clamp((q - a).dot(b - a) / (length * length), 0.0, 1.0) : 0.0;
    double s = path_s_[k] + f * length;
    if (s < s_near_) {  // behind the last nearest point (its own segment): that point
      s = s_near_;
      f = length > 0.0 ? (s - path_s_[k]) / length : 0.0;
    }
    const double d = (q - (a + f * (b - a))).squaredNorm();
    if (d < best) {
      best = d;
      best_s = s;
      best_k = k;
    }
  }
  if (best_s > s_near_ + 1e-6) last_progress_ = time_;
  s_near_ = best_s;
  segment_ = best_k;
}

bool PlanFollowPolicy::RestValid(const rmp::Scene& scene) {
  // from the arm's nearest point along the rest of its segment and every later one, with the margin planned with
  const int last = static_cast<int>(path_.size()) - 1;
  PointAt(s_near_);
  q_check_ = q_d_;
  for (int k = std::min(segment_ + 1, last); k <= last; ++k) {
    if (!planner_.IsSegmentValid(q_check_, path_[k], scene, plan_margin_)) return false;
    q_check_ = path_[k];
  }
  return true;
}

bool PlanFollowPolicy::GoalMoved(const rmp::Scene& scene) const {
  if (scene.q_T.size() != planned_q_T_.size()) return true;
  if (scene.q_T.size() > 0) return (scene.q_T - planned_q_T_).cwiseAbs().maxCoeff() > options_.goal_tolerance;
  return scene.has_target && (scene.p_WT - planned_p_WT_).norm() > options_.goal_shift;
}

void PlanFollowPolicy::Advance(const Eigen::Ref<const Eigen::VectorXd>& q, const rmp::Scene& scene,
                               bool control_step) {
  // a plan beside the loop: nothing else until it is ready (the path checks use the planner it runs on); switching to
  // it ends this call
  if (pending_.valid()) {
    PollPlan();
    return;
  }
  if (!planned_once_) {
    StartPlan(q, scene);
    return;
  }
  if (!options_.replan) return;
  if (path_.empty()) {
    if (time_ - last_attempt_ >= options_.planner.retry_period - kTimeEpsilon) StartPlan(q, scene);
    return;
  }
  if (!control_step) return;
  if (GoalMoved(scene) && time_ - last_attempt_ >= options_.planner.retry_period - kTimeEpsilon) {
    ++stats_.replans_moved;
    StartPlan(q, scene);
    return;
  }
  // at the goal: the configuration within the tolerance, or the end effector within it [m] of the goal's (a reactive
  // layer that reaches the target in another posture of a redundant arm)
  bool at_goal = (q - q_goal_).cwiseAbs().maxCoeff() <= options_.goal_tolerance;
  if (!at_goal) at_goal = (EndEffectorAt(q) - p_WG_).norm() <= options_.goal_tolerance;
  if (!at_goal && time_ - last_progress_ >= options_.stall_time - kTimeEpsilon &&
      time_ - last_attempt_ >= options_.planner.retry_period - kTimeEpsilon) {
    ++stats_.replans_stalled;
    StartPlan(q, scene);
    return;
  }
  if (!at_goal && time_ - last_check_ >= options_.check_period - kTimeEpsilon) {
    last_check_ = time_;
    if (!RestValid(scene)) {
      ++stats_.replans_blocked;
      StartPlan(q, scene);
    }
  }
}

double PlanFollowPolicy::MovingClearance(const Eigen::Ref<const Eigen::VectorXd>& q, const rmp::Scene& scene) {
  double d = std::numeric_limits<double>::infinity();
  bool placed = false;
  for (size_t k = 0; k < scene.obstacles.size(); ++k) {
    const rmp::Obstacle& obstacle = scene.obstacles[k];
    if (obstacle.v_WO.isZero()) continue;
    if (!placed) {
      collision::PlaceRobot(checker_, q, &placed_);
      placed = true;
    }
    d = collision::CalcObstacleClearance(checker_, placed_, obstacle, static_cast<int>(k),
                                         -std::numeric_limits<double>::infinity(), d);
  }
  return d;
}

double PlanFollowPolicy::Yield(const Eigen::Ref<const Eigen::VectorXd>& q, const rmp::Scene& scene) {
  const PlanFollowOptions& o = options_;
  if (o.yield_metric == o.posture_metric && !o.yield_slows) return 1.0;
  return std::clamp((MovingClearance(q, scene) - o.yield_near) / (o.yield_far - o.yield_near), 0.0, 1.0);
}

void PlanFollowPolicy::FillFollowScene(const rmp::Scene& scene) {
  follow_.obstacles = scene.obstacles;
  if (path_.empty()) {  // no plan (yet): the scene's own goal
    follow_.has_target = scene.has_target;
    follow_.p_WT = scene.p_WT;
    follow_.v_WT = scene.v_WT;
    follow_.q_T_metric = scene.q_T_metric;
    if (has_goal_) {
      follow_.q_T = q_goal_;
    } else if (scene.q_T.size() > 0) {
      follow_.q_T = scene.q_T;
    } else {
      follow_.q_T.resize(0);
    }
    follow_.qd_T.resize(0);
    follow_.qdd_T.resize(0);
    return;
  }
  const kinematics::EndEffector& ee = robot_.end_effector;
  kinematics::CalcForwardKinematics(robot_.model, q_d_, &kin_);
  follow_.has_target = true;
  follow_.p_WT = kinematics::CalcPointPosition(kin_, ee.link, ee.X_LE.translation());
  kinematics::CalcPointJacobian(robot_.model, kin_, ee.link, ee.X_LE.translation(), J_WE_);
  follow_.v_WT = J_WE_ * qd_d_;
  follow_.q_T = q_d_;
  follow_.qd_T = qd_d_;
  if (options_.acceleration_feedforward) {
    follow_.qdd_T = qdd_d_;
  } else {
    follow_.qdd_T.resize(0);
  }
  // geometrically from yield_metric (near what moves) to posture_metric (nothing moving near)
  follow_.q_T_metric = yield_ >= 1.0 ? options_.posture_metric
                                     : options_.yield_metric *
                                           std::pow(options_.posture_metric / options_.yield_metric, yield_);
}

void PlanFollowPolicy::BeginControlStep(const Eigen::Ref<const Eigen::VectorXd>& q,
                                        const Eigen::Ref<const Eigen::VectorXd>& qd, const rmp::Scene& scene) {
  Advance(q, scene, /*control_step=*/true);
  if (!reactive_) return;
  if (!path_.empty()) {
    yield_ = Yield(q, scene);
    Project(q);
    Reference();
  }
  FillFollowScene(scene);
  reactive_->BeginControlStep(q, qd, follow_);
}

void PlanFollowPolicy::Evaluate(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
                                const rmp::Scene& scene, Eigen::Ref<Eigen::VectorXd> qdd) {
  // a caller without control steps plans here; a plan beside the loop is switched to as soon as it is ready
  if (!planned_once_ || pending_.valid()) Advance(q, scene, /*control_step=*/false);
  const double dt = options_.planner.evaluation_period;
  if (reactive_ == nullptr) {
    if (path_.empty()) {
      qdd = -options_.planner.kd * qd;  // no plan: brake
    } else {
      SamplePath(path_, path_times_, tau_, &q_d_, &qd_d_);
      qdd = options_.planner.kp * (q_d_ - q) + options_.planner.kd * (qd_d_ - qd);
      tau_ += dt;
    }
    time_ += dt;
    return;
  }
  if (!path_.empty()) {
    yield_ = Yield(q, scene);
    Project(q);
    Reference();
  }
  FillFollowScene(scene);
  reactive_->Evaluate(q, qd, follow_, qdd);
  if (!path_.empty()) s_ref_ += dt * qd_d_.norm();  // q̇_d_ runs along the path: its norm is the arc-length rate
  time_ += dt;
}

std::unique_ptr<PlanFollowPolicy> MakePlanFollower(const kinematics::Robot& robot,
                                                   std::unique_ptr<control::AccelerationPolicy> reactive,
                                                   const control::ControllerOptions& controller,
                                                   PlanFollowOptions options) {
  const double period = 1.0 / controller.control_rate;
  options.planner.evaluation_period = period / control::ControlSubsteps(period, controller);
  return std::make_unique<PlanFollowPolicy>(robot, std::move(reactive), options);
}

}  // namespace rmpmarl::planning
