// The manipulator environment: variant pool, scenario, per-joint basic layer or direct Δq, observations, eq (14).
#include "rmpmarl/tasks/manipulator_env.h"
#include "rmpmarl/sim/controlled_world.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/kinematics/robot_setup.h"
#include "rmpmarl/tasks/pretrain_scenario.h"
#include "rmpmarl/rmp/joint_layer.h"
#include "rmpmarl/rmp/rmpflow.h"

namespace rmpmarl::tasks {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
std::atomic<long> g_world_models_built{0};

double Uniform(std::mt19937_64& rng, double lo, double hi) {
  return hi > lo ? std::uniform_real_distribution<double>(lo, hi)(rng) : lo;
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
  if (IsUrdfPath(config.robot)) return kinematics::LoadOrFitRobot(config.robot, config.collision);
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
  spec_.num_agents = control::NumAgents(config_.interface, nq_);
  global_layout_ = control::GlobalStateLayout(config_.interface, nq_, config_.observation.max_obstacles);
  spec_.global_state_dim = global_layout_.size;
  spec_.global_state_names = global_layout_.Names();
  if (config_.interface == InterfaceMode::kDirect) {
    spec_.local_obs_names = spec_.global_state_names;  // the single agent sees the whole state
  } else {
    spec_.local_obs_names = control::PerJointObservationNames(config_.interface, config_.observation.lookahead > 0.0);
  }
  spec_.local_obs_dim = static_cast<int>(spec_.local_obs_names.size());
  spec_.action = control::MakeActionSpec(AgentConfigOf(config_), nq_);
  spec_.reward_terms = control::RewardTermNames();
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

// ------------------------------------------------------------------------------------------------- the env

ManipulatorEnv::ManipulatorEnv(std::shared_ptr<const TaskContext> context)
    : context_(std::move(context)),
      config_(context_->config()),
      nq_(context_->nq()),
      num_agents_(context_->num_agents()) {
  const TaskContext& c = *context_;
  const int K = c.num_variants();
  scenarios_.resize(static_cast<size_t>(K) * c.num_scenario_settings());
  world_ = std::make_unique<sim::World>(c.variant(0).world_model);
  variant_ = 0;
  robot_ = &world_->model().robot();
  const double timestep = config_.episode.physics_timestep;
  physics_steps_ = static_cast<int>(std::lround(1.0 / (config_.episode.control_rate * timestep)));
  control_period_ = physics_steps_ * timestep;
  agents_ = std::make_unique<control::JointAgents>(AgentConfigOf(config_), robot_);
  if (config_.interface == InterfaceMode::kPerJointRmp) {
    controller_ = std::make_unique<control::ReactiveController>(world_->model().servos(), agents_->MakeLayerPolicy(), config_.controller);
  }
  scene_.obstacles.reserve(c.num_obstacles());
  const kinematics::Model& m = robot_->model;
  q_cmd_.setZero(nq_);
  q_cmd_before_.setZero(nq_);
  v_max_ = agents_->velocity_limits();
  dq_max_ = config_.direct.max_speed_fraction * control_period_ * v_max_;
  J_WE_before_.setZero(3, nq_);
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
  control::ValidateControllerOptions(external_.options, config_.episode.physics_timestep);
  external_controllers_.resize(context_->num_variants());
  sensors_.resize(context_->num_variants());
  // the agents' basic layer is never stepped when a baseline drives the robot: not reset every episode either
  controller_.reset();
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
    agents_->set_robot(robot_);
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
    std::unique_ptr<control::ReactiveController>& ext = external_controllers_[variant_];
    if (!ext) {
      ext = std::make_unique<control::ReactiveController>(world_->model().servos(), external_.make_policy(*robot_),
                                                      external_.options);
    }
    external_controller_ = ext.get();
    sim::ResetController(*external_controller_, *world_);
    if (external_.make_sensor) {
      std::unique_ptr<sim::ObstacleSensor>& sensor = sensors_[variant_];
      if (!sensor) sensor = external_.make_sensor(world_->model());
      sensor_ = sensor.get();
    }
  }
  if (controller_) sim::ResetController(*controller_, *world_);
  q_cmd_ = world_->q();

  agents_->Reset();
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

  report_ = &world_->QueryContacts();
  step_collisions_ = 0;
  step_min_clearance_ = kInf;
  CountCollisions(*report_);  // pairs touching at the start are not new events later
  step_collisions_ = 0;
  collision_physics_steps_ = 0;
  metrics_.min_clearance_m = step_min_clearance_;
  scenario_->FillScene(&scene_);
  if (sensor_ != nullptr) sensor_->Reset(*world_);
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
      if (control::DecodeOptionIndex(actions[agent * size], a.num_options) < 0) return false;
    }
  }
  return true;
}

void ManipulatorEnv::ApplyActions(const float* actions, float* option_started, float* parameters_read) {
  const ActionSpec& a = spec().action;
  const int size = a.size();
  if (external_controller_ != nullptr) {  // a baseline drives the robot; the actions are ignored
    q_cmd_before_ = external_controller_->q_cmd();
    if (sensor_ != nullptr) {
      sensed_scene_.has_target = scene_.has_target;
      sensed_scene_.p_WT = scene_.p_WT;
      sensed_scene_.v_WT = scene_.v_WT;
      sensed_scene_.obstacles = scene_.obstacles;  // the truth, for the sensor to score itself; replaced by Sense
      sensor_->Sense(*world_, &sensed_scene_);
    }
    control_us_sum_ += sim::StepController(*external_controller_, *world_, sensor_ != nullptr ? sensed_scene_ : scene_).compute_us;
    info_.qdd = external_controller_->qdd();
    info_.dq_command = external_controller_->q_cmd() - q_cmd_before_;
    std::fill(option_started, option_started + num_agents_, 0.0f);
    return;
  }
  switch (config_.interface) {
    case InterfaceMode::kPerJointRmp: {
      q_cmd_before_ = controller_->q_cmd();
      agents_->Apply(actions, option_started, parameters_read);
      control_us_sum_ += sim::StepController(*controller_, *world_, scene_).compute_us;
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
  agents_->Sense(world_->q(), world_->qd(), p_WT_, v_WT_, report_->warnings, scene_);
}

void ManipulatorEnv::WriteGlobal(float* s) const {
  const control::GlobalStateLayout& g = context_->global_layout();
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
    s[g.joint_warning + 2 * i] = agents_->warning(i).present ? 1.0f : 0.0f;
    s[g.joint_warning + 2 * i + 1] =
        agents_->warning(i).present ? static_cast<float>(agents_->warning(i).distance / oc.warning_distance) : 0.0f;
    if (g.has_options) {
      const control::OptionMachine& om = agents_->option_machine(i);
      for (int k = 0; k < control::kNumRmpOptions; ++k) s[g.joint_option + 4 * i + k] = om.option() == k ? 1.0f : 0.0f;
      s[g.joint_option + 4 * i + 3] = om.phase_b() ? 1.0f : 0.0f;
    }
  }
  Put3(s + g.ee_position, agents_->p_WE() / l);
  Put3(s + g.ee_velocity, agents_->v_WE() / vs);
  Put3(s + g.target_position, p_WT_ / l);
  Put3(s + g.target_velocity, v_WT_ / vs);
  Put3(s + g.ee_to_target, (agents_->p_WE() - p_WT_) / l);
  s[g.log_distance] = static_cast<float>(control::LogDistanceFeature((agents_->p_WE() - p_WT_).norm()));
  const sim::SceneSpec& spec = world_->model().scene();
  for (int j = 0; j < g.max_obstacles; ++j) {
    float* slot = s + g.obstacles + control::GlobalStateLayout::kObstacleSlot * j;
    if (j >= context_->num_obstacles()) {
      std::fill(slot, slot + control::GlobalStateLayout::kObstacleSlot, 0.0f);
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
    for (int i = 0; i < num_agents_; ++i) agents_->WriteLocal(i, steps_, out.local_obs + static_cast<size_t>(i) * dim);
  }
  WriteGlobal(out.global_state);
  if (out.next_action_read != nullptr) {  // which actions the next Step reads (an actor may skip the others)
    for (int i = 0; i < num_agents_; ++i) {
      bool read = true;
      if (external_controller_ != nullptr) {
        read = false;
      } else if (config_.interface == InterfaceMode::kPerJointRmp) {
        read = agents_->ReadsAction(i);
      }
      out.next_action_read[i] = read ? 1.0f : 0.0f;
    }
  }
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

EpisodeMetrics ManipulatorEnv::MetricsSoFar() const {
  EpisodeMetrics m = metrics_;
  const double d_mm = 1000.0 * (agents_->p_WE() - p_WT_).norm();
  m.length = steps_;
  m.mean_tracking_error_mm = steps_ > 0 ? tracking_sum_mm_ / steps_ : d_mm;
  m.final_tracking_error_mm = d_mm;
  m.settled_tracking_error_mm = settled_steps_ > 0 ? settled_sum_mm_ / settled_steps_ : kNaN;
  m.time_in_collision_s = collision_physics_steps_ * config_.episode.physics_timestep;
  m.mean_control_us = steps_ > 0 ? control_us_sum_ / steps_ : 0.0;
  m.success = !m.invalid && m.collisions == 0 &&
              m.final_tracking_error_mm <= 1000.0 * config_.episode.success_max_final_error;
  return m;
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
    metrics_ = MetricsSoFar();
    metrics_.invalid = invalid;
    metrics_.success = metrics_.success && !invalid;
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
  e_before_ = p_WT_ - agents_->p_WE();
  J_WE_before_ = agents_->J_WE();
  info_.distance_before = e_before_.norm();

  ApplyActions(actions, out.option_started, out.parameters_read);
  step_collisions_ = 0;
  step_min_clearance_ = kInf;
  const bool ok = AdvancePhysics();
  UpdateKinematics();
  ++steps_;
  if (config_.interface == InterfaceMode::kPerJointRmp && external_controller_ == nullptr) {
    agents_->End();
  }
  if (!ok) {  // MuJoCo diverged (the World reset the robot): the episode is invalid
    Finish(out, /*terminated=*/true, false, /*invalid=*/true);
    return;
  }

  // reward, eq (14)
  const RewardConfig& rc = config_.reward;
  const double d = (agents_->p_WE() - p_WT_).norm();
  info_.distance_after = d;
  JointReachRewards(e_before_, J_WE_before_, info_.dq_command, rc.joint_reach_tolerance, info_.joint_reach);
  RewardTerms& r = info_.reward;
  r.joint_reach = joint_weights_.dot(info_.joint_reach);
  // R_d (eq 14) and the optional dense precision terms − tracking_weight · d and + precision_weight · exp(−d/δ)
  // (RewardConfig::tracking_weight, precision_weight)
  r.distance = rc.distance_weight * DistanceReward(info_.distance_before, d, rc.distance_unit) - rc.tracking_weight * d;
  if (rc.precision_weight > 0.0 && agents_->PassesClear(rc.precision_pass_clearance)) {
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

}  // namespace rmpmarl::tasks
