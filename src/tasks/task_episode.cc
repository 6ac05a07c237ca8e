// A task's episodes on the one loop: the draw every user of the task shares, the agents' sensing, the reward of
// eq (14); and a controller driving them (ControllerEpisodes).
#include "rmpmarl/tasks/task_episode.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "rmpmarl/common/error.h"
#include "rmpmarl/control/learned_controller.h"
#include "rmpmarl/sim/pretrain_scenario.h"

namespace rmpmarl::tasks {
namespace {

double Uniform(std::mt19937_64& rng, double lo, double hi) {
  return hi > lo ? std::uniform_real_distribution<double>(lo, hi)(rng) : lo;
}

}  // namespace

sim::LoopOptions TaskLoopOptions(const TaskConfig& config) {
  sim::LoopOptions o;
  o.settle_time = kSettleTime;
  o.warning_margin = config.observation.warning_distance;
  o.scenario_update = config.episode.scenario_update;
  o.success_max_final_error = config.episode.success_max_final_error;
  if (std::isfinite(config.episode.success_max_final_error)) o.reach_tolerance = config.episode.success_max_final_error;
  return o;
}

TaskEpisode::TaskEpisode(std::shared_ptr<const TaskContext> context) : context_(std::move(context)) {
  RMPMARL_ASSERT(context_ != nullptr, "TaskEpisode: null context");
  const TaskContext& c = *context_;
  const TaskConfig& config = c.config();
  nq_ = c.nq();
  scenarios_.resize(static_cast<size_t>(c.num_variants()) * c.num_scenario_settings());
  world_ = std::make_unique<sim::World>(c.variant(0).world_model);
  variant_ = 0;
  agents_ = std::make_unique<control::JointAgents>(AgentConfigOf(config), &world_->model().robot());
  const double timestep = config.episode.physics_timestep;
  physics_steps_ = static_cast<int>(std::lround(1.0 / (config.episode.control_rate * timestep)));
  loop_options_ = TaskLoopOptions(config);
  joint_weights_.resize(nq_);
  const std::vector<double>& w = config.reward.joint_reach_weights;
  for (int i = 0; i < nq_; ++i) joint_weights_[i] = w.size() == 1 ? w[0] : w[i];
  const RewardConfig& rc = config.reward;
  cycles_ = ReachCycleTracker(rc.reach_tolerance, rc.reach_release, rc.time_reward);
  J_WE_before_.setZero(3, nq_);
  score_.joint_reach.setZero(nq_);
}

TaskEpisode::~TaskEpisode() = default;

bool TaskEpisode::Draw(std::mt19937_64& rng) {
  const TaskContext& c = *context_;
  const int variant = std::uniform_int_distribution<int>(0, c.num_variants() - 1)(rng);
  setting_ = std::uniform_int_distribution<int>(0, c.num_scenario_settings() - 1)(rng);
  const std::uint64_t seed = rng();
  const bool changed = variant != variant_;
  if (changed) {
    world_ = std::make_unique<sim::World>(c.variant(variant).world_model);
    variant_ = variant;
    agents_->set_robot(&world_->model().robot());
  }
  std::unique_ptr<sim::Scenario>& slot = scenarios_[static_cast<size_t>(variant_) * c.num_scenario_settings() + setting_];
  if (!slot) slot = c.MakeScenario(variant_, setting_);
  scenario_ = slot.get();

  const RandomizationConfig& d = config().randomization;
  if (auto* pretrain = dynamic_cast<sim::PretrainScenario*>(scenario_); pretrain != nullptr) {
    Eigen::VectorXd q0 = pretrain->ready();
    if (d.initial_q_spread > 0.0) {
      for (int i = 0; i < nq_; ++i) q0[i] += Uniform(rng, -d.initial_q_spread, d.initial_q_spread);
    }
    pretrain->SetNextStart(q0);
  }
  scenario_->Reset(seed, *world_);
  if (d.initial_qd_fraction > 0.0) {
    const Eigen::VectorXd& v_max = agents_->velocity_limits();
    Eigen::VectorXd qd0(nq_);
    for (int i = 0; i < nq_; ++i) qd0[i] = Uniform(rng, -d.initial_qd_fraction, d.initial_qd_fraction) * v_max[i];
    const Eigen::VectorXd q0 = world_->q();
    world_->Reset(q0, qd0);
  }
  return changed;
}

void TaskEpisode::Begin(sim::ObstacleSensor* sensor) {
  agents_->Reset();
  cycles_.Reset();
  score_.reward = RewardTerms{};
  score_.joint_reach.setZero();
  score_.collision_events = 0;
  loop_.Begin(world_.get(), scenario_, physics_steps_, loop_options_, sensor);
  p_WT_ = scenario_->target().p_WT;
  v_WT_ = scenario_->target().v_WT;
  Sense();
}

void TaskEpisode::Sense() {
  // the loop's kinematics of the same state, computed once per control step for its own sensing
  agents_->SenseState(loop_.kinematics(), world_->q(), world_->qd(), p_WT_, v_WT_);
  agents_->SenseContacts(loop_.warnings(), loop_.scene());
}

void TaskEpisode::BeginStep() {
  e_before_ = p_WT_ - agents_->p_WE();
  J_WE_before_ = agents_->J_WE();
  score_.distance_before = e_before_.norm();
  score_.reward = RewardTerms{};
  score_.collision_events = 0;
}

bool TaskEpisode::Advance(bool end_options) {
  const bool ok = loop_.Advance();
  p_WT_ = scenario_->target().p_WT;
  v_WT_ = scenario_->target().v_WT;
  Sense();
  if (end_options) agents_->End();
  return ok;
}

const StepScore& TaskEpisode::Score(const Eigen::Ref<const Eigen::VectorXd>& dq_command) {
  const RewardConfig& rc = config().reward;
  const double d = (agents_->p_WE() - p_WT_).norm();
  score_.distance_after = d;
  JointReachRewards(e_before_, J_WE_before_, dq_command, rc.joint_reach_tolerance, score_.joint_reach);
  RewardTerms& r = score_.reward;
  r.joint_reach = joint_weights_.dot(score_.joint_reach);
  // R_d (eq 14) and the optional dense precision terms − tracking_weight · d and + precision_weight · exp(−d/δ)
  // (RewardConfig::tracking_weight, precision_weight)
  r.distance = rc.distance_weight * DistanceReward(score_.distance_before, d, rc.distance_unit) - rc.tracking_weight * d;
  if (rc.precision_weight > 0.0 && agents_->PassesClear(rc.precision_pass_clearance)) {
    r.distance += rc.precision_weight * std::exp(-d / rc.precision_length);
  }
  r.time = cycles_.Update(d);
  score_.collision_events = loop_.step_collisions();
  r.collision = -rc.collision_penalty * score_.collision_events;
  loop_.AddReward(r.total());
  return score_;
}

bool TaskEpisode::Terminated() const {
  return loop_.step_collisions() > 0 && config().episode.terminate_on_collision;
}

bool TaskEpisode::Truncated() const { return steps() >= config().episode.max_steps; }

// ------------------------------------------------------------------------------------------ a controller

ControllerMaker LearnedControllerMaker(const TaskConfig& config, const control::PolicyWeights& weights,
                                       std::string name, int max_obstacles) {
  ControllerMaker maker;
  maker.options = config.controller;
  control::LearnedControllerOptions options;
  options.max_obstacles = max_obstacles;
  options.name = std::move(name);
  maker.make_policy = [agent = AgentConfigOf(config), weights, options](const kinematics::Robot& robot) {
    return std::make_unique<control::LearnedController>(robot, agent, weights, options);
  };
  return maker;
}

ControllerEpisodes::ControllerEpisodes(std::shared_ptr<const TaskContext> context, ControllerMaker maker)
    : episode_(std::move(context)), maker_(std::move(maker)) {
  if (!maker_.make_policy) throw InputError("ControllerEpisodes: the controller maker has no policy maker");
  const TaskConfig& config = episode_.config();
  maker_.options.control_rate = config.episode.control_rate;
  control::ValidateControllerOptions(maker_.options, config.episode.physics_timestep);
  controllers_.resize(episode_.context().num_variants());
  sensors_.resize(episode_.context().num_variants());
}

ControllerEpisodes::~ControllerEpisodes() = default;

EpisodeMetrics ControllerEpisodes::Run(std::mt19937_64& rng, const RunOptions& options) {
  episode_.Draw(rng);
  sim::World& world = episode_.world();
  const int variant = episode_.variant();
  std::unique_ptr<control::ReactiveController>& controller = controllers_[variant];
  if (!controller) {
    controller = std::make_unique<control::ReactiveController>(world.model().servos(),
                                                               maker_.make_policy(episode_.robot()), maker_.options);
  }
  controller_ = controller.get();
  sim::ResetController(*controller_, world);
  sensor_ = nullptr;
  if (maker_.make_sensor) {
    std::unique_ptr<sim::ObstacleSensor>& sensor = sensors_[variant];
    if (!sensor) sensor = maker_.make_sensor(world.model());
    sensor_ = sensor.get();
  }
  episode_.Begin(sensor_);
  sim::EpisodeLoop& loop = episode_.loop();
  int next_frame = 0;
  sim::MaybeFrame(loop, options.video_fps, &next_frame, options.on_frame);
  while (true) {
    episode_.BeginStep();
    q_cmd_before_ = controller_->q_cmd();
    loop.StepController(*controller_);
    dq_command_ = controller_->q_cmd() - q_cmd_before_;
    if (!episode_.Advance(/*end_options=*/false)) break;  // diverged: the loop marked the episode invalid
    const StepScore& score = episode_.Score(dq_command_);
    if (!std::isfinite(score.reward.total())) {
      episode_.MarkInvalid();
      break;
    }
    sim::MaybeFrame(loop, options.video_fps, &next_frame, options.on_frame);
    if (episode_.Terminated() || episode_.Truncated()) break;
  }
  return episode_.Metrics();
}

}  // namespace rmpmarl::tasks
