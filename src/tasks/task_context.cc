// A task's shared part: the variant pool (one WorldModel per link-length variant), the EnvSpec, the scenario maker.
#include "rmpmarl/tasks/task_context.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <random>

#include "rmpmarl/common/error.h"
#include "rmpmarl/setup/robot_setup.h"

namespace rmpmarl::tasks {
namespace {

std::atomic<long> g_world_models_built{0};

double Uniform(std::mt19937_64& rng, double lo, double hi) {
  return hi > lo ? std::uniform_real_distribution<double>(lo, hi)(rng) : lo;
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
  for (std::vector<kinematics::LinkCapsule>* set : {&out.capsules, &out.self_capsules}) {
    for (kinematics::LinkCapsule& c : *set) {
      c.p_LA *= s;
      c.p_LB *= s;
      c.radius *= s;
    }
  }
  out.end_effector.X_LE.translation() *= s;
  return out;
}

kinematics::Robot NominalTaskRobot(const TaskConfig& config) {
  // a user's URDF (its YAML beside it, else fitted in memory as `demo --urdf` does), else a shipped robot's name
  if (IsUrdfPath(config.robot)) return setup::LoadOrFitRobot(config.robot, config.collision);
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
    sim::SceneOptions options = config_.scenario;
    if (config_.task == TaskKind::kLineCrossing) options.line_crossing.speed = config_.scenario.line_speeds[setting];
    return sim::MakeScenario(TaskSceneName(config_.task), robot, {}, options);
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
  // the warning contacts are sensed once per control step by the episode loop, from the capsules and the scene;
  // the physics step looks for touching pairs only
  world_options.warning_margin = 0.0;
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

}  // namespace rmpmarl::tasks
