// The manipulator environment: variant pool, scenario, per-joint basic layer or direct Δq, observations, eq (14).
#include "rmpmarl/rl/manipulator_env.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/kinematics/robot_setup.h"
#include "rmpmarl/rl/pretrain_scenario.h"
#include "rmpmarl/rmp/joint_layer.h"
#include "rmpmarl/rmp/rmpflow.h"

namespace rmpmarl::rl {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
std::atomic<long> g_world_models_built{0};

double Uniform(std::mt19937_64& rng, double lo, double hi) {
  return hi > lo ? std::uniform_real_distribution<double>(lo, hi)(rng) : lo;
}

// ln(1 + d/1 mm)/ln(1001): 0 at the target, 0.35 at 1 cm, 1 at 1 m.
double LogDistance(double d) { return std::log1p(d / 0.001) / std::log(1001.0); }

// velocity of the material point of link L at p_W.
Eigen::Vector3d MaterialVelocity(const kinematics::Data& kin, int link, const Eigen::Vector3d& p_W) {
  return kin.v_WLo.col(link) + kin.w_WL.col(link).cross(p_W - kin.X_WL[link].translation());
}

void Put3(float* o, const Eigen::Vector3d& v) {
  o[0] = static_cast<float>(v.x());
  o[1] = static_cast<float>(v.y());
  o[2] = static_cast<float>(v.z());
}

int ScenarioSettings(const TaskConfig& c, bool custom) {
  if (custom || c.task != TaskKind::kLineCrossing) return 1;
  return static_cast<int>(c.scenario.line_speeds.size());
}

}  // namespace

// ------------------------------------------------------------------------------------------------ variants

kinematics::Robot ScaleRobot(const kinematics::Robot& robot, double s) {
  if (!std::isfinite(s) || !(s > 0.0)) throw InputError(fmt::format("ScaleRobot: expected a scale > 0, got {}", s));
  kinematics::Robot out = robot;
  std::vector<kinematics::Link> links = robot.model.links();
  for (kinematics::Link& link : links) link.X_PJ.translation() *= s;
  out.model = kinematics::Model(robot.model.name(), std::move(links), robot.model.limits());
  for (kinematics::LinkCapsule& c : out.capsules) {
    c.p_LA *= s;
    c.p_LB *= s;
    c.radius *= s;
  }
  out.end_effector.X_LE.translation() *= s;
  return out;
}

kinematics::Robot NominalTaskRobot(const TaskConfig& config) {
  // a user's URDF (its YAML beside it, else fitted in memory as `demo --urdf` does), else a shipped robot's name
  if (IsUrdfPath(config.robot)) return kinematics::LoadOrFitRobot(config.robot);
  if (config.robot != "planar2") return kinematics::LoadShippedRobot(config.robot);
  const Planar2Config& p = config.planar2;
  return kinematics::MakePlanar2({.link1_length = 0.5 * (p.link1_length[0] + p.link1_length[1]),
                                  .link2_length = 0.5 * (p.link2_length[0] + p.link2_length[1]),
                                  .link_radius = p.link_radius,
                                  .joint_limit = p.joint_limit,
                                  .velocity_limit = p.velocity_limit});
}

long WorldModelsBuilt() { return g_world_models_built.load(); }

TaskContext::TaskContext(TaskConfig config, ScenarioMaker scenario)
    : config_(std::move(config)), scenario_maker_(std::move(scenario)) {
  config_.controller.control_rate = config_.episode.control_rate;
  ValidateTaskConfig(config_, config_.source);
  const kinematics::Robot nominal = NominalTaskRobot(config_);
  nq_ = nominal.model.nq();
  const std::vector<double>& w = config_.reward.joint_reach_weights;
  if (w.size() != 1 && static_cast<int>(w.size()) != nq_) {
    throw InputError(fmt::format("{}: key 'reward.joint_reach_weights': expected 1 value or {} (one per joint of "
                                 "robot '{}'), got {}", config_.source, nq_, nominal.name, w.size()));
  }
  num_settings_ = ScenarioSettings(config_, static_cast<bool>(scenario_maker_));

  // the obstacle layout comes from the scenario (identical for every variant)
  make_scenario_ = [this](const kinematics::Robot& robot, int setting) -> std::unique_ptr<sim::Scenario> {
    if (scenario_maker_) return scenario_maker_(robot);
    switch (config_.task) {
      case TaskKind::kPretrain2Link: return std::make_unique<PretrainScenario>(robot, config_.scenario.pretrain);
      case TaskKind::kReachAvoid: return std::make_unique<sim::CrossingScenario>(robot, config_.scenario.crossing);
      case TaskKind::kLineCrossing: {
        sim::LineCrossingOptions o = config_.scenario.line_crossing;
        o.speed = config_.scenario.line_speeds[setting];
        return std::make_unique<sim::LineCrossingScenario>(robot, o);
      }
      case TaskKind::kCluttered: return std::make_unique<sim::ClutteredScenario>(robot, config_.scenario.cluttered);
    }
    return nullptr;
  };
  const std::unique_ptr<sim::Scenario> prototype = make_scenario_(nominal, 0);
  if (!prototype) throw InputError(fmt::format("{}: the scenario maker returned no scenario", config_.source));
  const sim::SceneSpec scene = prototype->scene_spec();
  num_obstacles_ = prototype->num_obstacles();
  if (num_obstacles_ > config_.observation.max_obstacles) {
    throw InputError(fmt::format("{}: key 'observation.max_obstacles': expected at least the scenario's {} "
                                 "obstacles, got {}", config_.source, num_obstacles_,
                                 config_.observation.max_obstacles));
  }

  // the variant pool: K WorldModels, built here once
  sim::WorldOptions world_options;
  world_options.timestep = config_.episode.physics_timestep;
  world_options.warning_margin = config_.observation.warning_distance;
  world_options.integrator = config_.episode.integrator;
  const RandomizationConfig& d = config_.randomization;
  std::mt19937_64 rng(d.seed);
  const bool planar2 = config_.robot == "planar2";
  for (int k = 0; k < d.variants; ++k) {
    RobotVariant v;
    kinematics::Robot robot;
    const bool nominal_variant = d.include_nominal && k == 0;
    if (planar2) {
      const Planar2Config& p = config_.planar2;
      v.planar2_lengths = {nominal_variant ? 0.5 * (p.link1_length[0] + p.link1_length[1])
                                           : Uniform(rng, p.link1_length[0], p.link1_length[1]),
                           nominal_variant ? 0.5 * (p.link2_length[0] + p.link2_length[1])
                                           : Uniform(rng, p.link2_length[0], p.link2_length[1])};
      robot = kinematics::MakePlanar2({.link1_length = v.planar2_lengths[0],
                                       .link2_length = v.planar2_lengths[1],
                                       .link_radius = p.link_radius,
                                       .joint_limit = p.joint_limit,
                                       .velocity_limit = p.velocity_limit});
    } else {
      v.link_scale = nominal_variant ? 1.0 : Uniform(rng, d.link_scale[0], d.link_scale[1]);
      robot = v.link_scale == 1.0 ? nominal : ScaleRobot(nominal, v.link_scale);
    }
    v.world_model = std::make_shared<const sim::WorldModel>(std::move(robot), scene, world_options);
    g_world_models_built.fetch_add(1);
    variants_.push_back(std::move(v));
  }

  // the spec
  spec_.task = std::string(TaskKindName(config_.task));
  spec_.num_agents = NumAgents(config_.interface, nq_);
  global_layout_ = GlobalStateLayout(config_.interface, nq_, config_.observation.max_obstacles);
  spec_.global_state_dim = global_layout_.size;
  spec_.global_state_names = global_layout_.Names();
  if (config_.interface == InterfaceMode::kDirect) {
    spec_.local_obs_names = spec_.global_state_names;  // the single agent sees the whole state
  } else {
    spec_.local_obs_names = PerJointObservationNames(config_.interface, config_.observation.lookahead > 0.0);
  }
  spec_.local_obs_dim = static_cast<int>(spec_.local_obs_names.size());
  spec_.action = MakeActionSpec(config_, nq_);
  spec_.reward_terms = RewardTermNames();
  spec_.discount = config_.episode.discount;
  spec_.max_episode_steps = config_.episode.max_steps;
  const double timestep = config_.episode.physics_timestep;
  spec_.control_dt = std::lround(1.0 / (config_.episode.control_rate * timestep)) * timestep;
}

std::unique_ptr<sim::Scenario> TaskContext::MakeScenario(int variant, int setting) const {
  RMPMARL_ASSERT(variant >= 0 && variant < num_variants() && setting >= 0 && setting < num_settings_,
                 "TaskContext::MakeScenario: index out of range");
  return make_scenario_(variants_[variant].world_model->robot(), setting);
}

std::shared_ptr<const TaskContext> MakeTaskContext(TaskConfig config, ScenarioMaker scenario) {
  return std::make_shared<const TaskContext>(std::move(config), std::move(scenario));
}

// ------------------------------------------------------------------------------------------ the basic layer

/// The per-joint agents' basic layer as the controller's acceleration policy: q̈_i = EvaluateJointLayer at joint i
/// with the RMPs and scales of agent i's option.
class ManipulatorEnv::PerJointRmpPolicy final : public sim::AccelerationPolicy {
 public:
  PerJointRmpPolicy(const kinematics::Robot* robot, const BasicLayerConfig& config)
      : robot_(robot), config_(config), kin_(robot->model), coupled_(robot->model.nq()), weights(robot->model.nq()) {
    set_robot(robot);
  }

  void Evaluate(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
                const rmp::Scene& scene, Eigen::Ref<Eigen::VectorXd> qdd) override {
    kinematics::CalcVelocityKinematics(robot_->model, q, qd, &kin_);
    if (config_.resolve == rmp::LayerResolve::kCoupled) {
      // the agents' RMPs resolved together on the robot's RMPflow structure, capped as RMPflow caps
      structure_->EvaluateStructure(q, qd);
      rmp::EvaluateCoupledLayer(*robot_, kin_, scene, config_.params, weights, structure_->data().f_root,
                                structure_->data().M_root, config_.relative_regularizer, &coupled_, qdd);
      const double norm = qdd.norm();
      const double cap = structure_->options().max_acceleration_norm;
      if (norm > cap) qdd *= cap / norm;
      return;
    }
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
  std::vector<rmp::JointLayerWeights> weights;  ///< per joint, set by the env before every control step
};

// ------------------------------------------------------------------------------------------------- the env

/// The nearest warning contact of joint i (W_i): among the robot contacts within the warning distance whose robot
/// capsule joint i moves while the partner (obstacle, floor, or a link) is not moved by it.
struct ManipulatorEnv::JointWarning {
  bool present = false;
  double distance = kInf;                          ///< signed [m]
  int link = -1;                                   ///< the link joint i moves
  Eigen::Vector3d p_W1 = Eigen::Vector3d::Zero();  ///< witness point on that link's capsule
  Eigen::Vector3d p_W2 = Eigen::Vector3d::Zero();  ///< witness point on the partner
  Eigen::Vector3d n_W = Eigen::Vector3d::Zero();   ///< unit normal from partner to robot
  sim::PartnerKind partner = sim::PartnerKind::kObstacle;
  int partner_index = -1;                          ///< obstacle or link index
  double closing_speed = 0.0;                      ///< −ḋ [m/s]
  double gradient = 0.0;                           ///< ∂d/∂q_i [m/rad or m/m]
};

/// The closest predicted pass of a moving obstacle by the capsules joint i moves (LocalObs::kLookahead…).
struct ManipulatorEnv::Lookahead {
  double clearance = kInf;  ///< [m] capsule surface to the obstacle's bounding sphere at the closest approach
  double time = 0.0;        ///< [s] when, in [0, T]
  double speed = 0.0;       ///< [m/s] that obstacle's speed
};

ManipulatorEnv::ManipulatorEnv(std::shared_ptr<const TaskContext> context)
    : context_(std::move(context)),
      config_(context_->config()),
      nq_(context_->nq()),
      num_agents_(context_->num_agents()),
      kin_(context_->variant(0).world_model->kinematic_model()) {
  const TaskContext& c = *context_;
  const int K = c.num_variants();
  scenarios_.resize(static_cast<size_t>(K) * c.num_scenario_settings());
  world_ = std::make_unique<sim::World>(c.variant(0).world_model);
  variant_ = 0;
  robot_ = &world_->model().robot();
  const double timestep = config_.episode.physics_timestep;
  physics_steps_ = static_cast<int>(std::lround(1.0 / (config_.episode.control_rate * timestep)));
  control_period_ = physics_steps_ * timestep;
  if (config_.interface == InterfaceMode::kPerJointRmp) {
    auto policy = std::make_unique<PerJointRmpPolicy>(robot_, config_.basic_layer);
    policy_ = policy.get();
    controller_ = std::make_unique<sim::ReactiveController>(world_->model(), std::move(policy), config_.controller);
  }
  scene_.obstacles.reserve(c.num_obstacles());
  const kinematics::Model& m = robot_->model;
  q_cmd_.setZero(nq_);
  q_cmd_before_.setZero(nq_);
  v_max_.resize(nq_);
  for (int i = 0; i < nq_; ++i) {
    const double v = m.limits()[i].velocity;
    v_max_[i] = (v > 0.0 ? v : 1.0) * config_.controller.velocity_limit_scale;
  }
  dq_max_ = config_.direct.max_speed_fraction * control_period_ * v_max_;
  J_WE_.setZero(3, nq_);
  J_WE_before_.setZero(3, nq_);
  warnings_.resize(nq_);
  lookahead_.resize(nq_);
  option_warning_.assign(nq_, 0);
  options_.assign(nq_, OptionMachine(config_.options.termination, config_.options.horizon));
  terminate_flags_.assign(nq_, 0);
  held_parameters_.setZero(nq_, RmpActionLayout::kNumContinuous);
  parameter_age_.assign(nq_, -1);
  parameter_warning_.assign(nq_, 0);
  joint_weights_.resize(nq_);
  const std::vector<double>& w = config_.reward.joint_reach_weights;
  for (int i = 0; i < nq_; ++i) joint_weights_[i] = w.size() == 1 ? w[0] : w[i];
  cycles_ = ReachCycleTracker(config_.reward.reach_tolerance, config_.reward.reach_release, config_.reward.time_reward);
  const int partners = c.num_obstacles() + m.num_links() + 1;
  pair_last_seen_.assign(static_cast<size_t>(m.num_links()) * partners, -10);
  info_.joint_reach.setZero(nq_);
  info_.dq_command.setZero(nq_);
  info_.qdd.setZero(nq_);
}

ManipulatorEnv::ManipulatorEnv(std::shared_ptr<const TaskContext> context, ExternalController external)
    : ManipulatorEnv(std::move(context)) {
  if (!external.make_policy) throw InputError("ManipulatorEnv: the external controller has no policy maker");
  external_ = std::move(external);
  external_.options.control_rate = config_.episode.control_rate;
  sim::ValidateControllerOptions(external_.options, config_.episode.physics_timestep);
  external_controllers_.resize(context_->num_variants());
  // the agents' basic layer is never stepped when a baseline drives the robot: not reset every episode either
  controller_.reset();
  policy_ = nullptr;
}

ManipulatorEnv::~ManipulatorEnv() = default;

void ManipulatorEnv::StartEpisode(std::mt19937_64& rng) {
  const TaskContext& c = *context_;
  const int variant = std::uniform_int_distribution<int>(0, c.num_variants() - 1)(rng);
  setting_ = std::uniform_int_distribution<int>(0, c.num_scenario_settings() - 1)(rng);
  const std::uint64_t seed = rng();
  if (variant != variant_) {
    world_ = std::make_unique<sim::World>(c.variant(variant).world_model);
    variant_ = variant;
    robot_ = &world_->model().robot();
    if (policy_ != nullptr) policy_->set_robot(robot_);
  }
  std::unique_ptr<sim::Scenario>& slot = scenarios_[static_cast<size_t>(variant_) * c.num_scenario_settings() + setting_];
  if (!slot) slot = c.MakeScenario(variant_, setting_);
  scenario_ = slot.get();

  const RandomizationConfig& d = config_.randomization;
  if (auto* pretrain = dynamic_cast<PretrainScenario*>(scenario_); pretrain != nullptr) {
    Eigen::VectorXd q0 = pretrain->ready();
    if (d.initial_q_spread > 0.0) {
      for (int i = 0; i < nq_; ++i) q0[i] += Uniform(rng, -d.initial_q_spread, d.initial_q_spread);
    }
    pretrain->SetNextStart(q0);
  }
  scenario_->Reset(seed, *world_);
  if (d.initial_qd_fraction > 0.0) {
    Eigen::VectorXd qd0(nq_);
    for (int i = 0; i < nq_; ++i) qd0[i] = Uniform(rng, -d.initial_qd_fraction, d.initial_qd_fraction) * v_max_[i];
    const Eigen::VectorXd q0 = world_->q();
    world_->Reset(q0, qd0);
  }
  if (external_.make_policy) {
    std::unique_ptr<sim::ReactiveController>& ext = external_controllers_[variant_];
    if (!ext) {
      ext = std::make_unique<sim::ReactiveController>(world_->model(), external_.make_policy(*robot_),
                                                      external_.options);
    }
    external_controller_ = ext.get();
    external_controller_->Reset(*world_);
  }
  if (controller_) controller_->Reset(*world_);
  q_cmd_ = world_->q();

  for (OptionMachine& o : options_) o.Reset();
  cycles_.Reset();
  std::fill(pair_last_seen_.begin(), pair_last_seen_.end(), -10);
  physics_step_ = 0;
  steps_ = 0;
  tracking_sum_mm_ = 0.0;
  settled_sum_mm_ = 0.0;
  settled_steps_ = 0;
  control_us_sum_ = 0.0;
  metrics_ = EpisodeMetrics{};
  metrics_.min_clearance_m = kInf;
  info_.invalid = false;
  info_.collision_events = 0;
  info_.reward = RewardTerms{};
  info_.joint_reach.setZero();
  info_.dq_command.setZero();
  info_.qdd.setZero();
  std::fill(parameter_age_.begin(), parameter_age_.end(), -1);  // the first step reads every joint's parameters

  report_ = &world_->QueryContacts();
  step_collisions_ = 0;
  step_min_clearance_ = kInf;
  CountCollisions(*report_);  // pairs touching at the start are not new events later
  step_collisions_ = 0;
  collision_physics_steps_ = 0;
  metrics_.min_clearance_m = step_min_clearance_;
  scenario_->FillScene(&scene_);
  p_WT_ = scenario_->target().p_WT;
  v_WT_ = scenario_->target().v_WT;
  UpdateKinematics();
  active_ = true;
}

void ManipulatorEnv::Reset(std::mt19937_64& rng, const StepOutput& out) {
  StartEpisode(rng);
  WriteObservation(out);
  std::fill(out.reward_terms, out.reward_terms + spec().reward_terms.size(), 0.0f);
  *out.reward = 0.0f;
  *out.terminated = 0;
  *out.truncated = 0;
  std::fill(out.option_started, out.option_started + num_agents_, 0.0f);
  SanitiseOutputs(out);
}

bool ManipulatorEnv::ValidActions(const float* actions) const {
  const ActionSpec& a = spec().action;
  const int size = a.size();
  for (int k = 0; k < num_agents_ * size; ++k) {
    if (!std::isfinite(actions[k])) return false;
  }
  if (a.num_options > 0) {
    for (int agent = 0; agent < num_agents_; ++agent) {
      if (DecodeOptionIndex(actions[agent * size], a.num_options) < 0) return false;
    }
  }
  return true;
}

void ManipulatorEnv::ApplyActions(const float* actions, float* option_started, float* parameters_read) {
  const ActionSpec& a = spec().action;
  const int size = a.size();
  if (external_controller_ != nullptr) {  // a baseline drives the robot; the actions are ignored
    q_cmd_before_ = external_controller_->q_cmd();
    control_us_sum_ += external_controller_->Step(*world_, scene_).compute_us;
    info_.qdd = external_controller_->qdd();
    info_.dq_command = external_controller_->q_cmd() - q_cmd_before_;
    std::fill(option_started, option_started + num_agents_, 0.0f);
    return;
  }
  switch (config_.interface) {
    case InterfaceMode::kPerJointRmp: {
      q_cmd_before_ = controller_->q_cmd();
      const double g = config_.options.gain_range;
      const double g_target = config_.options.TargetGainRange();
      const double length_exponent = config_.options.collision_length_exponent;
      for (int i = 0; i < nq_; ++i) {
        const float* u = actions + i * size;
        const int chosen = config_.options.fixed_option >= 0
                               ? config_.options.fixed_option
                               : DecodeOptionIndex(u[RmpActionLayout::kOption], a.num_options);
        const OptionSelection sel = options_[i].Begin(chosen, option_warning_[i] != 0);
        option_started[i] = sel.started ? 1.0f : 0.0f;
        // the RMP parameters: read now, or held since the last read (options.parameter_period)
        const int period = config_.options.parameter_period;
        const bool read = period == 1 || sel.started || parameter_age_[i] < 0 || parameter_age_[i] >= period ||
                          parameter_warning_[i] != option_warning_[i];
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
        rmp::JointLayerWeights& w = policy_->weights[i];
        // while the collision RMPs run, the target RMP keeps a small priority (options.collision_target_weight)
        const double target_weight = sel.use_collision ? config_.options.collision_target_weight : 1.0;
        w.use_target = sel.use_target || target_weight > 0.0;
        w.use_collision = sel.use_collision;
        double u_target_accel = p(RmpActionLayout::kTargetAccelScale);
        if (const OptionConfig& oc = config_.options; oc.TargetGated()) {
          // options.target_gate_*: the hand prior of the look-ahead block (as seen in this step's observation) under
          // the agent's target accel parameter, decided every step
          const bool threat = lookahead_[i].clearance < oc.target_gate_clearance;
          u_target_accel += threat ? oc.target_gate_threat : oc.target_gate_clear;
          u_target_accel = std::clamp(u_target_accel, -1.0, 1.0);
        }
        w.target_accel_scale = GainScale(u_target_accel, g_target);
        w.target_metric_scale = target_weight * GainScale(p(RmpActionLayout::kTargetMetricScale), g_target);
        w.collision_accel_scale = GainScale(p(RmpActionLayout::kCollisionAccelScale), g);
        w.collision_metric_scale = GainScale(p(RmpActionLayout::kCollisionMetricScale), g);
        w.collision_length_scale = length_exponent == 0.0 ? 1.0 : std::pow(w.collision_accel_scale, length_exponent);
        terminate_flags_[i] = a.has_termination && u[a.termination_offset()] >= 0.5f ? 1 : 0;
      }
      control_us_sum_ += controller_->Step(*world_, scene_).compute_us;
      info_.qdd = controller_->qdd();
      info_.dq_command = controller_->q_cmd() - q_cmd_before_;
      break;
    }
    case InterfaceMode::kDirect:
    case InterfaceMode::kPerJointDirect: {
      q_cmd_before_ = q_cmd_;
      const Eigen::VectorXd& q = world_->q();
      if ((q_cmd_ - q).cwiseAbs().maxCoeff() > config_.controller.resync_threshold) q_cmd_ = q;
      const sim::WorldModel& wm = world_->model();
      for (int i = 0; i < nq_; ++i) {
        const float u = config_.interface == InterfaceMode::kDirect ? actions[a.continuous_offset() + i]
                                                                    : actions[i * size + a.continuous_offset()];
        const double dq = std::clamp(static_cast<double>(u), -1.0, 1.0) * dq_max_[i];
        q_cmd_[i] = std::clamp(q_cmd_[i] + dq, wm.lower_limits()[i], wm.upper_limits()[i]);
      }
      for (int k = 0; k < num_agents_; ++k) option_started[k] = 1.0f;
      world_->SetJointTargets(q_cmd_);
      info_.dq_command = q_cmd_ - q_cmd_before_;
      break;
    }
  }
}

void ManipulatorEnv::CountCollisions(const sim::ContactReport& report) {
  const int links = robot_->model.num_links();
  const int partners = context_->num_obstacles() + links + 1;
  if (!report.colliding_pairs.empty()) ++collision_physics_steps_;
  for (const sim::CollidingPair& p : report.colliding_pairs) {
    int partner = 0;
    switch (p.other_kind) {
      case sim::PartnerKind::kObstacle: partner = p.other_index; break;
      case sim::PartnerKind::kLink: partner = context_->num_obstacles() + p.other_index; break;
      case sim::PartnerKind::kFloor: partner = partners - 1; break;
    }
    long& seen = pair_last_seen_[static_cast<size_t>(p.link) * partners + partner];
    if (seen != physics_step_ - 1) ++step_collisions_;  // the pair enters penetration
    seen = physics_step_;
  }
  for (const sim::WarningContact& w : report.warnings) {
    if (w.other_kind != sim::PartnerKind::kLink) step_min_clearance_ = std::min(step_min_clearance_, w.distance);
  }
}

bool ManipulatorEnv::AdvancePhysics() {
  const double timestep = config_.episode.physics_timestep;
  const bool per_physics_step = config_.episode.scenario_update == ScenarioUpdate::kPhysicsStep;
  bool ok = true;
  for (int s = 0; s < physics_steps_ && ok; ++s) {
    if (per_physics_step) {
      scenario_->Advance(timestep, *report_, *world_);
    } else if (s == 0) {
      scenario_->Advance(control_period_, *report_, *world_);
    }
    ok = world_->Step(1).ok;
    ++physics_step_;
    report_ = &world_->QueryContacts();
    CountCollisions(*report_);
  }
  scenario_->FillScene(&scene_);
  p_WT_ = scenario_->target().p_WT;
  v_WT_ = scenario_->target().v_WT;
  return ok;
}

void ManipulatorEnv::UpdateKinematics() {
  const kinematics::Model& m = robot_->model;
  const kinematics::EndEffector& ee = robot_->end_effector;
  kinematics::CalcVelocityKinematics(m, world_->q(), world_->qd(), &kin_);
  p_WE_ = kinematics::CalcPointPosition(kin_, ee.link, ee.X_LE.translation());
  v_WE_ = kinematics::CalcPointVelocity(kin_, ee.link, ee.X_LE.translation());
  kinematics::CalcPointJacobian(m, kin_, ee.link, ee.X_LE.translation(), J_WE_);

  for (JointWarning& w : warnings_) w = JointWarning{};
  const bool all_warnings = config_.options.warnings == OptionWarnings::kAll;
  std::fill(option_warning_.begin(), option_warning_.end(), 0);
  for (const sim::WarningContact& c : report_->warnings) {
    const int other_link = c.other_kind == sim::PartnerKind::kLink ? c.other_index : -1;
    for (int i = 0; i < nq_; ++i) {
      const bool moves_robot_side = m.DofMovesLink(i, c.link);
      const bool moves_other_side = other_link >= 0 && m.DofMovesLink(i, other_link);
      if (moves_robot_side == moves_other_side) continue;  // joint i moves both rigidly, or neither
      // W_i of the options: what the collision RMPs act on (obstacles), or every warning (options.warnings: all)
      if (all_warnings || c.other_kind == sim::PartnerKind::kObstacle) option_warning_[i] = 1;
      JointWarning& w = warnings_[i];
      if (c.distance >= w.distance) continue;
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
        w.link = other_link;
        w.p_W1 = c.p_W2;
        w.p_W2 = c.p_W1;
        w.n_W = -c.n_W;
        w.partner = sim::PartnerKind::kLink;
        w.partner_index = c.link;
      }
    }
  }
  for (int i = 0; i < nq_; ++i) {
    JointWarning& w = warnings_[i];
    if (!w.present) continue;
    Eigen::Vector3d v_other = Eigen::Vector3d::Zero();
    if (w.partner == sim::PartnerKind::kObstacle) {
      v_other = scenario_->obstacles()[w.partner_index].v_WO();
    } else if (w.partner == sim::PartnerKind::kLink) {
      v_other = MaterialVelocity(kin_, w.partner_index, w.p_W2);
    }
    w.closing_speed = -w.n_W.dot(MaterialVelocity(kin_, w.link, w.p_W1) - v_other);
    w.gradient = w.n_W.dot(kinematics::CalcPointJacobianColumn(m, kin_, i, w.link, w.p_W1));
  }
  if (config_.observation.lookahead > 0.0 && config_.interface != InterfaceMode::kDirect) UpdateLookahead();
}

void ManipulatorEnv::UpdateLookahead() {
  // Each moving obstacle j sweeps the segment [c_j, c_j + T v_j] over the horizon (straight, constant speed, the arm
  // held still). The closest points of that segment and a capsule's axis give the smallest distance between the
  // obstacle's centre and the axis over [0, T], and when (the parameter along the swept segment × T); the clearance
  // subtracts the capsule radius and the obstacle's bounding radius (a conservative sphere around a box).
  const kinematics::Model& m = robot_->model;
  const double horizon = config_.observation.lookahead;
  for (Lookahead& l : lookahead_) l = Lookahead{};
  for (const kinematics::LinkCapsule& lc : robot_->capsules) {
    const Eigen::Isometry3d& X_WL = kin_.X_WL[lc.link];
    const Eigen::Vector3d p_WA = X_WL * lc.p_LA, p_WB = X_WL * lc.p_LB;
    for (const rmp::Obstacle& obstacle : scene_.obstacles) {
      const double speed = obstacle.v_WO.norm();
      if (!(speed > 0.0)) continue;  // static obstacles are the warning features' business
      const Eigen::Vector3d c_W = rmp::Centre(obstacle);
      const math::SegmentClosestPoints pass =
          math::ClosestPointsSegmentSegment(c_W, c_W + horizon * obstacle.v_WO, p_WA, p_WB);
      const double clearance = pass.distance - lc.radius - rmp::BoundingRadius(obstacle);
      const double time = pass.s * horizon;
      for (int i = 0; i < nq_; ++i) {
        if (!m.DofMovesLink(i, lc.link)) continue;
        Lookahead& l = lookahead_[i];
        if (clearance < l.clearance || (clearance == l.clearance && time < l.time)) l = {clearance, time, speed};
      }
    }
  }
}

bool ManipulatorEnv::PassesClear(double clearance) const {
  if (!std::isfinite(clearance)) return true;  // −inf: not gated (validated: never +inf)
  for (const Lookahead& l : lookahead_) {
    if (l.clearance <= clearance) return false;
  }
  return true;
}

void ManipulatorEnv::WriteLocal(int i, float* o) const {
  const kinematics::Model& m = robot_->model;
  const ObservationConfig& oc = config_.observation;
  const double l = oc.length_scale, vs = oc.speed_scale;
  const int link = m.dof_link(i);
  const Eigen::Matrix3d R_JW = kin_.X_WL[link].linear().transpose();
  const Eigen::Vector3d o_W = kin_.X_WL[link].translation();
  const Eigen::Vector3d e = p_WE_ - p_WT_;
  Put3(o + LocalObs::kEeToTarget, R_JW * e / l);
  o[LocalObs::kLogDistance] = static_cast<float>(LogDistance(e.norm()));
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
    o[LocalObs::kWarningIsSelf] = w.partner == sim::PartnerKind::kLink ? 1.0f : 0.0f;
  } else {
    std::fill(o + LocalObs::kWarningFlag, o + LocalObs::kJointPosition, 0.0f);
  }
  const double q = world_->q()[i];
  const kinematics::DofLimits& lim = m.limits()[i];
  const double q_norm = std::isfinite(lim.lower) && std::isfinite(lim.upper) && lim.upper > lim.lower
                            ? 2.0 * (q - lim.lower) / (lim.upper - lim.lower) - 1.0
                            : std::atan2(std::sin(q), std::cos(q)) / M_PI;
  o[LocalObs::kJointPosition] = static_cast<float>(q_norm);
  o[LocalObs::kJointSin] = static_cast<float>(std::sin(q));
  o[LocalObs::kJointCos] = static_cast<float>(std::cos(q));
  o[LocalObs::kJointVelocity] = static_cast<float>(world_->qd()[i] / v_max_[i]);
  o[LocalObs::kJointIndex] = nq_ > 1 ? static_cast<float>(i) / static_cast<float>(nq_ - 1) : 0.0f;
  o[LocalObs::kProgress] = static_cast<float>(steps_) / static_cast<float>(config_.episode.max_steps);
  if (config_.interface == InterfaceMode::kPerJointRmp) {
    const OptionMachine& om = options_[i];
    for (int k = 0; k < kNumRmpOptions; ++k) o[LocalObs::kOption + k] = om.option() == k ? 1.0f : 0.0f;
    o[LocalObs::kOptionPhaseB] = om.phase_b() ? 1.0f : 0.0f;
    o[LocalObs::kOptionAge] =
        std::min(1.0f, static_cast<float>(om.age()) / static_cast<float>(config_.options.horizon));
  }
  if (config_.observation.lookahead > 0.0) {
    const Lookahead& la = lookahead_[i];
    WriteLookaheadBlock(la.clearance, la.time, la.speed, oc, o + LookaheadOffset(config_.interface));
  }
}

void ManipulatorEnv::WriteGlobal(float* s) const {
  const GlobalStateLayout& g = context_->global_layout();
  const kinematics::Model& m = robot_->model;
  const ObservationConfig& oc = config_.observation;
  const double l = oc.length_scale, vs = oc.speed_scale;
  for (int i = 0; i < nq_; ++i) {
    const double q = world_->q()[i];
    const kinematics::DofLimits& lim = m.limits()[i];
    s[g.joint_position + i] = static_cast<float>(std::isfinite(lim.lower) && std::isfinite(lim.upper) &&
                                                         lim.upper > lim.lower
                                                     ? 2.0 * (q - lim.lower) / (lim.upper - lim.lower) - 1.0
                                                     : std::atan2(std::sin(q), std::cos(q)) / M_PI);
    s[g.joint_velocity + i] = static_cast<float>(world_->qd()[i] / v_max_[i]);
    s[g.joint_warning + 2 * i] = warnings_[i].present ? 1.0f : 0.0f;
    s[g.joint_warning + 2 * i + 1] =
        warnings_[i].present ? static_cast<float>(warnings_[i].distance / oc.warning_distance) : 0.0f;
    if (g.has_options) {
      const OptionMachine& om = options_[i];
      for (int k = 0; k < kNumRmpOptions; ++k) s[g.joint_option + 4 * i + k] = om.option() == k ? 1.0f : 0.0f;
      s[g.joint_option + 4 * i + 3] = om.phase_b() ? 1.0f : 0.0f;
    }
  }
  Put3(s + g.ee_position, p_WE_ / l);
  Put3(s + g.ee_velocity, v_WE_ / vs);
  Put3(s + g.target_position, p_WT_ / l);
  Put3(s + g.target_velocity, v_WT_ / vs);
  Put3(s + g.ee_to_target, (p_WE_ - p_WT_) / l);
  s[g.log_distance] = static_cast<float>(LogDistance((p_WE_ - p_WT_).norm()));
  const sim::SceneSpec& spec = world_->model().scene();
  for (int j = 0; j < g.max_obstacles; ++j) {
    float* slot = s + g.obstacles + GlobalStateLayout::kObstacleSlot * j;
    if (j >= context_->num_obstacles()) {
      std::fill(slot, slot + GlobalStateLayout::kObstacleSlot, 0.0f);
      continue;
    }
    const sim::ObstacleState& o = scenario_->obstacles()[j];
    slot[0] = 1.0f;
    Put3(slot + 1, o.p_WO() / l);
    Put3(slot + 4, o.v_WO() / vs);
    Put3(slot + 7, o.R_WO.col(0));
    Put3(slot + 10, o.R_WO.col(1));
    const sim::ObstacleSpec& os = spec.obstacles[j];
    Put3(slot + 13, os.shape == sim::ObstacleShape::kBox ? Eigen::Vector3d(os.half_size / l)
                                                          : Eigen::Vector3d::Constant(os.radius / l));
  }
  s[g.robot_reach] = static_cast<float>(scenario_->workspace().reach / l);
  s[g.progress] = static_cast<float>(steps_) / static_cast<float>(config_.episode.max_steps);
}

void ManipulatorEnv::WriteObservation(const StepOutput& out) const {
  const int dim = spec().local_obs_dim;
  if (config_.interface == InterfaceMode::kDirect) {
    WriteGlobal(out.local_obs);
  } else {
    for (int i = 0; i < num_agents_; ++i) WriteLocal(i, out.local_obs + static_cast<size_t>(i) * dim);
  }
  WriteGlobal(out.global_state);
}

void ManipulatorEnv::SanitiseOutputs(const StepOutput& out) {
  const EnvSpec& s = spec();
  bool bad = false;
  const auto clean = [&bad](float* p, size_t n) {
    for (size_t k = 0; k < n; ++k) {
      if (!std::isfinite(p[k])) {
        p[k] = 0.0f;
        bad = true;
      }
    }
  };
  clean(out.local_obs, static_cast<size_t>(num_agents_) * s.local_obs_dim);
  clean(out.global_state, static_cast<size_t>(s.global_state_dim));
  clean(out.reward_terms, s.reward_terms.size());
  clean(out.reward, 1);
  if (bad && active_) {  // never propagate: end the episode as invalid
    *out.terminated = 1;
    info_.invalid = true;
    metrics_.invalid = true;
    metrics_.success = false;
    active_ = false;
    if (out.metrics != nullptr) *out.metrics = metrics_;
  }
}

void ManipulatorEnv::Finish(const StepOutput& out, bool terminated, bool truncated, bool invalid) {
  WriteObservation(out);
  const RewardTerms& r = info_.reward;
  out.reward_terms[0] = static_cast<float>(r.joint_reach);
  out.reward_terms[1] = static_cast<float>(r.distance);
  out.reward_terms[2] = static_cast<float>(r.time);
  out.reward_terms[3] = static_cast<float>(r.collision);
  *out.reward = static_cast<float>(r.total());
  *out.terminated = terminated ? 1 : 0;
  *out.truncated = truncated && !terminated ? 1 : 0;
  info_.invalid = invalid;
  if (terminated || truncated) {
    metrics_.invalid = invalid;
    metrics_.length = steps_;
    metrics_.mean_tracking_error_mm = steps_ > 0 ? tracking_sum_mm_ / steps_ : 1000.0 * (p_WE_ - p_WT_).norm();
    metrics_.final_tracking_error_mm = 1000.0 * (p_WE_ - p_WT_).norm();
    metrics_.settled_tracking_error_mm = settled_steps_ > 0 ? settled_sum_mm_ / settled_steps_ : kNaN;
    metrics_.time_in_collision_s = collision_physics_steps_ * config_.episode.physics_timestep;
    metrics_.mean_control_us = steps_ > 0 ? control_us_sum_ / steps_ : 0.0;
    metrics_.success = !invalid && metrics_.collisions == 0 &&
                       metrics_.final_tracking_error_mm <= 1000.0 * config_.episode.success_max_final_error;
    if (out.metrics != nullptr) *out.metrics = metrics_;
    active_ = false;
  }
  SanitiseOutputs(out);
}

void ManipulatorEnv::Step(std::span<const float> actions, std::mt19937_64& rng, const StepOutput& out) {
  const size_t expected = static_cast<size_t>(num_agents_) * spec().action.size();
  if (actions.size() != expected) {
    info_.reward = RewardTerms{};
    info_.collision_events = 0;
    Finish(out, /*terminated=*/true, false, /*invalid=*/true);
    std::fill(out.option_started, out.option_started + num_agents_, 0.0f);
    return;
  }
  Step(actions.data(), rng, out);
}

void ManipulatorEnv::Step(const float* actions, std::mt19937_64& /*rng*/, const StepOutput& out) {
  info_.reward = RewardTerms{};
  info_.collision_events = 0;
  if (!active_ || (external_controller_ == nullptr && (actions == nullptr || !ValidActions(actions)))) {
    std::fill(out.option_started, out.option_started + num_agents_, 0.0f);
    Finish(out, /*terminated=*/true, false, /*invalid=*/true);
    return;
  }
  e_before_ = p_WT_ - p_WE_;
  J_WE_before_ = J_WE_;
  info_.distance_before = e_before_.norm();

  ApplyActions(actions, out.option_started, out.parameters_read);
  step_collisions_ = 0;
  step_min_clearance_ = kInf;
  const bool ok = AdvancePhysics();
  UpdateKinematics();
  ++steps_;
  if (config_.interface == InterfaceMode::kPerJointRmp && external_controller_ == nullptr) {
    for (int i = 0; i < nq_; ++i) options_[i].End(terminate_flags_[i] != 0, option_warning_[i] != 0);
  }
  if (!ok) {  // MuJoCo diverged (the World reset the robot): the episode is invalid
    Finish(out, /*terminated=*/true, false, /*invalid=*/true);
    return;
  }

  // reward, eq (14)
  const RewardConfig& rc = config_.reward;
  const double d = (p_WE_ - p_WT_).norm();
  info_.distance_after = d;
  JointReachRewards(e_before_, J_WE_before_, info_.dq_command, rc.joint_reach_tolerance, info_.joint_reach);
  RewardTerms& r = info_.reward;
  r.joint_reach = joint_weights_.dot(info_.joint_reach);
  // R_d (eq 14) and the optional dense precision terms − tracking_weight · d and + precision_weight · exp(−d/δ)
  // (RewardConfig::tracking_weight, precision_weight)
  r.distance = rc.distance_weight * DistanceReward(info_.distance_before, d, rc.distance_unit) - rc.tracking_weight * d;
  if (rc.precision_weight > 0.0 && PassesClear(rc.precision_pass_clearance)) {
    r.distance += rc.precision_weight * std::exp(-d / rc.precision_length);
  }
  r.time = cycles_.Update(d);
  r.collision = -rc.collision_penalty * step_collisions_;
  info_.collision_events = step_collisions_;

  // metrics
  metrics_.collisions += step_collisions_;
  metrics_.min_clearance_m = std::min(metrics_.min_clearance_m, step_min_clearance_);
  metrics_.episode_return += r.total();
  tracking_sum_mm_ += 1000.0 * d;
  if (steps_ * control_period_ >= kSettleTime - 1e-9) {
    settled_sum_mm_ += 1000.0 * d;
    ++settled_steps_;
  }

  const bool collided = step_collisions_ > 0;
  const bool terminated = collided && config_.episode.terminate_on_collision;
  const bool truncated = steps_ >= config_.episode.max_steps;
  Finish(out, terminated, truncated, /*invalid=*/false);
}

EnvFactory MakeManipulatorEnvFactory(std::shared_ptr<const TaskContext> context) {
  RMPMARL_ASSERT(context != nullptr, "MakeManipulatorEnvFactory: null context");
  return [context](int /*env_id*/) -> std::unique_ptr<Env> { return std::make_unique<ManipulatorEnv>(context); };
}

}  // namespace rmpmarl::rl
