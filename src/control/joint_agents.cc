// The per-joint agents: sensing (nearest warning, look-ahead), local observations, options and held parameters, and
// the basic layer their actions set. Shared by ManipulatorEnv and LearnedController.
#include "rmpmarl/control/joint_agents.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "rmpmarl/common/error.h"
#include "rmpmarl/math/geometry.h"
#include "rmpmarl/rmp/joint_layer.h"
#include "rmpmarl/rmp/rmpflow.h"

namespace rmpmarl::control {
namespace {

// velocity of the material point of link L at p_W.
Eigen::Vector3d MaterialVelocity(const kinematics::Data& kin, int link, const Eigen::Vector3d& p_W) {
  return kin.v_WLo.col(link) + kin.w_WL.col(link).cross(p_W - kin.X_WL[link].translation());
}

void Put3(float* o, const Eigen::Vector3d& v) {
  o[0] = static_cast<float>(v.x());
  o[1] = static_cast<float>(v.y());
  o[2] = static_cast<float>(v.z());
}

}  // namespace

// ------------------------------------------------------------------------------------------ the basic layer

/// The per-joint agents' basic layer as the controller's acceleration policy: q̈_i = EvaluateJointLayer at joint i
/// with the RMPs and scales of agent i's option, or the coupled resolve of every joint's terms.
class JointAgents::Layer final : public AccelerationPolicy {
 public:
  Layer(const kinematics::Robot* robot, const BasicLayerConfig& config)
      : robot_(robot), config_(config), kin_(robot->model), coupled_(robot->model.nq()), weights(robot->model.nq()) {
    set_robot(robot);
  }

  void Evaluate(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
                const rmp::Scene& scene, Eigen::Ref<Eigen::VectorXd> qdd) override {
    if (config_.resolve == rmp::LayerResolve::kCoupled) {
      // the agents' RMPs resolved together on the robot's RMPflow structure, capped as RMPflow caps; the structure's
      // push-forward computed the kinematics of (q, q̇), which the agents' leaves read too
      structure_->EvaluateStructure(q, qd, scene.q_T, scene.q_T_metric, scene.qd_T, scene.qdd_T);
      rmp::EvaluateCoupledLayer(*robot_, structure_->data().kinematics, scene, config_.params, weights,
                                structure_->data().f_root, structure_->data().M_root, config_.relative_regularizer,
                                &coupled_, qdd);
      const double norm = qdd.norm();
      const double cap = structure_->options().max_acceleration_norm;
      if (norm > cap) qdd *= cap / norm;
      return;
    }
    kinematics::CalcVelocityKinematics(robot_->model, q, qd, &kin_);
    for (int i = 0; i < robot_->model.nq(); ++i) {
      qdd[i] = rmp::EvaluateJointLayer(*robot_, kin_, i, scene, config_.params, weights[i],
                                       config_.relative_regularizer)
                   .qdd;
    }
  }
  std::string name() const override { return "per-joint-rmp"; }
  int nq() const override { return robot_->model.nq(); }
  /// switches to another variant's robot (same joints); the coupled resolve's structure is built once per robot.
  void set_robot(const kinematics::Robot* robot) {
    robot_ = robot;
    if (config_.resolve != rmp::LayerResolve::kCoupled) return;
    for (const auto& [r, s] : structures_) {
      if (r == robot) {
        structure_ = s.get();
        return;
      }
    }
    structures_.emplace_back(robot, std::make_unique<rmp::RmpflowPolicy>(*robot, rmp::LoadRmpflowOptions(*robot), 0));
    structure_ = structures_.back().second.get();
  }

 private:
  const kinematics::Robot* robot_;
  BasicLayerConfig config_;
  kinematics::Data kin_;
  rmp::CoupledLayerWorkspace coupled_;  ///< buffers of the coupled resolve
  /// the coupled resolve's RMPflow structure per robot variant, and the current one
  std::vector<std::pair<const kinematics::Robot*, std::unique_ptr<rmp::RmpflowPolicy>>> structures_;
  rmp::RmpflowPolicy* structure_ = nullptr;

 public:
  std::vector<rmp::JointLayerWeights> weights;  ///< per joint, set by Apply before every control step
};

// ------------------------------------------------------------------------------------------------ the agents

namespace {

const kinematics::Robot* NonNull(const kinematics::Robot* robot) {
  RMPMARL_ASSERT(robot != nullptr, "JointAgents: null robot");
  return robot;
}

}  // namespace

JointAgents::JointAgents(const AgentConfig& config, const kinematics::Robot* robot)
    : config_(config), action_(MakeActionSpec(config, NonNull(robot)->model.nq())), robot_(robot),
      nq_(robot->model.nq()), kin_(robot->model) {
  const kinematics::Model& m = robot_->model;
  q_.setZero(nq_);
  qd_.setZero(nq_);
  v_max_.resize(nq_);
  for (int i = 0; i < nq_; ++i) {
    const double v = m.limits()[i].velocity;
    v_max_[i] = (v > 0.0 ? v : 1.0) * config_.controller.velocity_limit_scale;
  }
  J_WE_.setZero(3, nq_);
  warnings_.resize(nq_);
  lookahead_.resize(nq_);
  option_warning_.assign(nq_, 0);
  options_.assign(nq_, OptionMachine(config_.options.termination, config_.options.horizon));
  terminate_flags_.assign(nq_, 0);
  held_parameters_.setZero(nq_, RmpActionLayout::kNumContinuous);
  parameter_age_.assign(nq_, -1);
  parameter_warning_.assign(nq_, 0);
  scale_memo_.assign(nq_, ScaleMemo{});
  if (config_.interface == InterfaceMode::kPerJointRmp) layer_ = std::make_unique<Layer>(robot_, config_.basic_layer);
}

JointAgents::~JointAgents() = default;

void JointAgents::set_robot(const kinematics::Robot* robot) {
  RMPMARL_ASSERT(robot != nullptr && robot->model.nq() == nq_, "JointAgents::set_robot: another joint count");
  robot_ = robot;
  if (layer_ != nullptr) layer_->set_robot(robot);
}

namespace {

// a ReactiveController's handle on the agents' basic layer (owned by the agents).
class LayerHandle final : public AccelerationPolicy {
 public:
  explicit LayerHandle(AccelerationPolicy* layer) : layer_(layer) {}
  void Evaluate(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
                const rmp::Scene& scene, Eigen::Ref<Eigen::VectorXd> qdd) override {
    layer_->Evaluate(q, qd, scene, qdd);
  }
  std::string name() const override { return layer_->name(); }
  int nq() const override { return layer_->nq(); }

 private:
  AccelerationPolicy* layer_;
};

}  // namespace

std::unique_ptr<AccelerationPolicy> JointAgents::MakeLayerPolicy() {
  RMPMARL_ASSERT(layer_ != nullptr, "JointAgents::MakeLayerPolicy: the per-joint-rmp interface only");
  return std::make_unique<LayerHandle>(layer_.get());
}

void JointAgents::Reset() {
  for (OptionMachine& o : options_) o.Reset();
  std::fill(parameter_age_.begin(), parameter_age_.end(), -1);  // the first step reads every joint's parameters
}

void JointAgents::Sense(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
                        const Eigen::Vector3d& p_WT, const Eigen::Vector3d& v_WT,
                        std::span<const WarningContact> contacts, const rmp::Scene& scene) {
  SenseState(q, qd, p_WT, v_WT);
  SenseContacts(contacts, scene);
}

void JointAgents::SenseState(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
                             const Eigen::Vector3d& p_WT, const Eigen::Vector3d& v_WT) {
  kinematics::CalcVelocityKinematics(robot_->model, q, qd, &kin_);
  SenseEndEffector(q, qd, p_WT, v_WT);
}

void JointAgents::SenseState(const kinematics::Data& kin, const Eigen::Ref<const Eigen::VectorXd>& q,
                             const Eigen::Ref<const Eigen::VectorXd>& qd, const Eigen::Vector3d& p_WT,
                             const Eigen::Vector3d& v_WT) {
  RMPMARL_ASSERT(kin.has_velocities && kin.X_WL.size() == kin_.X_WL.size(),
                 "JointAgents::SenseState: the kinematics of another robot or without velocities");
  kin_ = kin;
  SenseEndEffector(q, qd, p_WT, v_WT);
}

void JointAgents::SenseEndEffector(const Eigen::Ref<const Eigen::VectorXd>& q,
                                   const Eigen::Ref<const Eigen::VectorXd>& qd, const Eigen::Vector3d& p_WT,
                                   const Eigen::Vector3d& v_WT) {
  const kinematics::Model& m = robot_->model;
  const kinematics::EndEffector& ee = robot_->end_effector;
  q_ = q;
  qd_ = qd;
  p_WT_ = p_WT;
  v_WT_ = v_WT;
  p_WE_ = kinematics::CalcPointPosition(kin_, ee.link, ee.X_LE.translation());
  v_WE_ = kinematics::CalcPointVelocity(kin_, ee.link, ee.X_LE.translation());
  kinematics::CalcPointJacobian(m, kin_, ee.link, ee.X_LE.translation(), J_WE_);
}

void JointAgents::SenseContacts(std::span<const WarningContact> contacts, const rmp::Scene& scene) {
  const kinematics::Model& m = robot_->model;

  for (JointWarning& w : warnings_) w = JointWarning{};
  const bool all_warnings = config_.options.warnings == OptionWarnings::kAll;
  std::fill(option_warning_.begin(), option_warning_.end(), 0);
  // a contact counts at the joints that move exactly one of its sides: the dofs of its link and of the other link
  // (none for an obstacle or the floor) merged, those in both left out, in ascending order
  auto observe = [&](const WarningContact& c, int i, bool moves_robot_side) {
    // W_i of the options: what the collision RMPs act on (obstacles), or every warning (options.warnings: all)
    if (all_warnings || c.other_kind == PartnerKind::kObstacle) option_warning_[i] = 1;
    JointWarning& w = warnings_[i];
    if (c.distance >= w.distance) return;
    w.present = true;
    w.distance = c.distance;
    if (moves_robot_side) {
      w.link = c.link;
      w.p_W1 = c.p_W1;
      w.p_W2 = c.p_W2;
      w.n_W = c.n_W;
      w.partner = c.other_kind;
      w.partner_index = c.other_index;
    } else {  // a link-link contact seen from the other link's side
      w.link = c.other_index;
      w.p_W1 = c.p_W2;
      w.p_W2 = c.p_W1;
      w.n_W = -c.n_W;
      w.partner = PartnerKind::kLink;
      w.partner_index = c.link;
    }
  };
  static const std::vector<int> kNoDofs;
  for (const WarningContact& c : contacts) {
    const std::vector<int>& robot_side = m.link_dofs(c.link);
    const std::vector<int>& other_side = c.other_kind == PartnerKind::kLink ? m.link_dofs(c.other_index) : kNoDofs;
    auto a = robot_side.begin(), b = other_side.begin();
    while (a != robot_side.end() || b != other_side.end()) {
      if (b == other_side.end() || (a != robot_side.end() && *a < *b)) {
        observe(c, *a++, /*moves_robot_side=*/true);
      } else if (a == robot_side.end() || *b < *a) {
        observe(c, *b++, /*moves_robot_side=*/false);
      } else {  // moves both rigidly
        ++a;
        ++b;
      }
    }
  }
  for (int i = 0; i < nq_; ++i) {
    JointWarning& w = warnings_[i];
    if (!w.present) continue;
    Eigen::Vector3d v_other = Eigen::Vector3d::Zero();
    if (w.partner == PartnerKind::kObstacle) {
      RMPMARL_ASSERT(w.partner_index >= 0 && w.partner_index < static_cast<int>(scene.obstacles.size()),
                     "JointAgents::Sense: a warning names an obstacle the scene does not hold");
      v_other = scene.obstacles[w.partner_index].v_WO;
    } else if (w.partner == PartnerKind::kLink) {
      v_other = MaterialVelocity(kin_, w.partner_index, w.p_W2);
    }
    w.closing_speed = -w.n_W.dot(MaterialVelocity(kin_, w.link, w.p_W1) - v_other);
    w.gradient = w.n_W.dot(kinematics::CalcPointJacobianColumn(m, kin_, i, w.link, w.p_W1));
  }
  if (config_.observation.lookahead > 0.0 && config_.interface != InterfaceMode::kDirect) UpdateLookahead(scene);
}

void JointAgents::UpdateLookahead(const rmp::Scene& scene) {
  // Each moving obstacle j sweeps the segment [c_j, c_j + T v_j] over the horizon (straight, constant speed, the arm
  // held still). The closest points of that segment and a capsule's axis give the smallest distance between the
  // obstacle's centre and the axis over [0, T], and when (the parameter along the swept segment × T); the clearance
  // subtracts the capsule radius and the obstacle's bounding radius (a conservative sphere around a box).
  const kinematics::Model& m = robot_->model;
  const double horizon = config_.observation.lookahead;
  for (JointLookahead& l : lookahead_) l = JointLookahead{};
  for (const kinematics::LinkCapsule& lc : robot_->capsules) {
    const Eigen::Isometry3d& X_WL = kin_.X_WL[lc.link];
    const Eigen::Vector3d p_WA = X_WL * lc.p_LA, p_WB = X_WL * lc.p_LB;
    for (const rmp::Obstacle& obstacle : scene.obstacles) {
      const double speed = obstacle.v_WO.norm();
      if (!(speed > 0.0)) continue;  // static obstacles are the warning features' business
      const Eigen::Vector3d c_W = rmp::Centre(obstacle);
      const math::SegmentClosestPoints pass =
          math::ClosestPointsSegmentSegment(c_W, c_W + horizon * obstacle.v_WO, p_WA, p_WB);
      const double clearance = pass.distance - lc.radius - rmp::BoundingRadius(obstacle);
      const double time = pass.s * horizon;
      for (int i = 0; i < nq_; ++i) {
        if (!m.DofMovesLink(i, lc.link)) continue;
        JointLookahead& l = lookahead_[i];
        if (clearance < l.clearance || (clearance == l.clearance && time < l.time)) l = {clearance, time, speed};
      }
    }
  }
}

bool JointAgents::PassesClear(double clearance) const {
  if (!std::isfinite(clearance)) return true;  // −inf: not gated (validated: never +inf)
  for (const JointLookahead& l : lookahead_) {
    if (l.clearance <= clearance) return false;
  }
  return true;
}

void JointAgents::WriteLocal(int i, int step, float* o) const {
  const kinematics::Model& m = robot_->model;
  const ObservationConfig& oc = config_.observation;
  const double l = oc.length_scale, vs = oc.speed_scale;
  const int link = m.dof_link(i);
  const Eigen::Matrix3d R_JW = kin_.X_WL[link].linear().transpose();
  const Eigen::Vector3d o_W = kin_.X_WL[link].translation();
  const Eigen::Vector3d e = p_WE_ - p_WT_;
  Put3(o + LocalObs::kEeToTarget, R_JW * e / l);
  o[LocalObs::kLogDistance] = static_cast<float>(LogDistanceFeature(e.norm()));
  Put3(o + LocalObs::kEeVelocity, R_JW * (v_WE_ - v_WT_) / vs);
  Put3(o + LocalObs::kLever, R_JW * (p_WE_ - o_W) / l);
  Put3(o + LocalObs::kAxis, R_JW * kin_.axis_W.col(i));
  Put3(o + LocalObs::kEeJacobian, R_JW * J_WE_.col(i) / l);
  const JointWarning& w = warnings_[i];
  if (w.present) {
    o[LocalObs::kWarningFlag] = 1.0f;
    Put3(o + LocalObs::kWarningDirection, R_JW * (-w.n_W));
    o[LocalObs::kWarningDistance] = static_cast<float>(w.distance / oc.warning_distance);
    o[LocalObs::kClosingSpeed] = static_cast<float>(w.closing_speed / vs);
    Put3(o + LocalObs::kWitnessLever, R_JW * (w.p_W1 - o_W) / l);
    o[LocalObs::kDistanceGradient] = static_cast<float>(w.gradient / l);
    o[LocalObs::kWarningIsSelf] = w.partner == PartnerKind::kLink ? 1.0f : 0.0f;
  } else {
    std::fill(o + LocalObs::kWarningFlag, o + LocalObs::kJointPosition, 0.0f);
  }
  const double q = q_[i];
  const kinematics::DofLimits& lim = m.limits()[i];
  const double q_norm = std::isfinite(lim.lower) && std::isfinite(lim.upper) && lim.upper > lim.lower
                            ? 2.0 * (q - lim.lower) / (lim.upper - lim.lower) - 1.0
                            : std::atan2(std::sin(q), std::cos(q)) / M_PI;
  o[LocalObs::kJointPosition] = static_cast<float>(q_norm);
  o[LocalObs::kJointSin] = static_cast<float>(std::sin(q));
  o[LocalObs::kJointCos] = static_cast<float>(std::cos(q));
  o[LocalObs::kJointVelocity] = static_cast<float>(qd_[i] / v_max_[i]);
  o[LocalObs::kJointIndex] = nq_ > 1 ? static_cast<float>(i) / static_cast<float>(nq_ - 1) : 0.0f;
  const int max_steps = config_.episode.max_steps;
  o[LocalObs::kProgress] = static_cast<float>(std::min(step, max_steps)) / static_cast<float>(max_steps);
  if (config_.interface == InterfaceMode::kPerJointRmp) {
    const OptionMachine& om = options_[i];
    for (int k = 0; k < kNumRmpOptions; ++k) o[LocalObs::kOption + k] = om.option() == k ? 1.0f : 0.0f;
    o[LocalObs::kOptionPhaseB] = om.phase_b() ? 1.0f : 0.0f;
    o[LocalObs::kOptionAge] =
        std::min(1.0f, static_cast<float>(om.age()) / static_cast<float>(config_.options.horizon));
  }
  if (config_.observation.lookahead > 0.0) {
    const JointLookahead& la = lookahead_[i];
    WriteLookaheadBlock(la.clearance, la.time, la.speed, oc, o + LookaheadOffset(config_.interface));
  }
}

void JointAgents::Apply(const float* actions, float* option_started, float* parameters_read) {
  RMPMARL_ASSERT(layer_ != nullptr, "JointAgents::Apply: the per-joint-rmp interface only");
  const ActionSpec& a = action_;
  const int size = a.size();
  const double g = config_.options.gain_range;
  const double g_target = config_.options.TargetGainRange();
  const double length_exponent = config_.options.collision_length_exponent;
  for (int i = 0; i < nq_; ++i) {
    const float* u = actions + i * size;
    const int chosen = config_.options.fixed_option >= 0
                           ? config_.options.fixed_option
                           : DecodeOptionIndex(u[RmpActionLayout::kOption], a.num_options);
    const OptionSelection sel = options_[i].Begin(chosen, option_warning_[i] != 0);
    if (option_started != nullptr) option_started[i] = sel.started ? 1.0f : 0.0f;
    // the RMP parameters: read now, or held since the last read (options.parameter_period)
    const bool read = sel.started || ParametersDue(i);
    if (read) {
      for (int c = 0; c < RmpActionLayout::kNumContinuous; ++c) {
        held_parameters_(i, c) = u[RmpActionLayout::kTargetAccelScale + c];
      }
      parameter_age_[i] = 0;
      parameter_warning_[i] = option_warning_[i];
    }
    ++parameter_age_[i];
    if (parameters_read != nullptr) parameters_read[i] = read ? 1.0f : 0.0f;
    auto p = [&](int index) { return held_parameters_(i, index - RmpActionLayout::kTargetAccelScale); };
    rmp::JointLayerWeights& w = layer_->weights[i];
    // while the collision RMPs run, the target RMP keeps a small priority (options.collision_target_weight)
    const double target_weight = sel.use_collision ? config_.options.collision_target_weight : 1.0;
    w.use_target = sel.use_target || target_weight > 0.0;
    w.use_collision = sel.use_collision;
    double u_target_accel = p(RmpActionLayout::kTargetAccelScale);
    double u_target_metric = p(RmpActionLayout::kTargetMetricScale);
    double u_collision_accel = p(RmpActionLayout::kCollisionAccelScale);
    double u_collision_metric = p(RmpActionLayout::kCollisionMetricScale);
    if (const OptionConfig& oc = config_.options; oc.TargetGated()) {
      // options.target_gate_* and collision_gate_*: the hand priors of the look-ahead block (as seen in this step's
      // observation) under the agent's target and collision accel parameters, decided every step
      const bool threat = lookahead_[i].clearance < oc.target_gate_clearance;
      if (oc.agents_under_threat_only && !threat) {
        u_target_accel = u_target_metric = u_collision_accel = u_collision_metric = 0.0;
      }
      u_target_accel += threat ? oc.target_gate_threat : oc.target_gate_clear;
      u_target_accel = std::clamp(u_target_accel, -1.0, 1.0);
      u_collision_accel += threat ? oc.collision_gate_threat : oc.collision_gate_clear;
      u_collision_accel = std::clamp(u_collision_accel, -1.0, 1.0);
    }
    // the scales are exponentials of the parameters, which are held for many steps: computed when they change
    ScaleMemo& memo = scale_memo_[i];
    const std::array<double, 4> u_now{u_target_accel, u_target_metric, u_collision_accel, u_collision_metric};
    if (!memo.valid || u_now != memo.u) {
      memo.u = u_now;
      memo.scale = {GainScale(u_target_accel, g_target), GainScale(u_target_metric, g_target),
                    GainScale(u_collision_accel, g), GainScale(u_collision_metric, g)};
      memo.length_scale = length_exponent == 0.0 ? 1.0 : std::pow(memo.scale[2], length_exponent);
      memo.valid = true;
    }
    w.target_accel_scale = memo.scale[0];
    w.target_metric_scale = target_weight * memo.scale[1];
    w.collision_accel_scale = memo.scale[2];
    w.collision_metric_scale = memo.scale[3];
    w.collision_length_scale = memo.length_scale;
    terminate_flags_[i] = a.has_termination && u[a.termination_offset()] >= 0.5f ? 1 : 0;
  }
}

bool JointAgents::ReadsAction(int i) const {
  RMPMARL_ASSERT(layer_ != nullptr, "JointAgents::ReadsAction: the per-joint-rmp interface only");
  RMPMARL_ASSERT(i >= 0 && i < nq_, "JointAgents::ReadsAction: joint index out of range");
  return action_.has_termination || options_[i].idle() || ParametersDue(i);
}

bool JointAgents::ParametersDue(int i) const {
  const int period = config_.options.parameter_period;
  return period == 1 || parameter_age_[i] < 0 || parameter_age_[i] >= period ||
         parameter_warning_[i] != option_warning_[i];
}

const rmp::JointLayerWeights& JointAgents::layer_weights(int i) const {
  RMPMARL_ASSERT(layer_ != nullptr, "JointAgents::layer_weights: the per-joint-rmp interface only");
  return layer_->weights[i];
}

void JointAgents::End() {
  for (int i = 0; i < nq_; ++i) options_[i].End(terminate_flags_[i] != 0, option_warning_[i] != 0);
}

}  // namespace rmpmarl::control
