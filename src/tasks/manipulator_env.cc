// The manipulator environment: the agents' actions (per-joint basic layer or direct Δq) and observations on a task
// episode, whose loop scores the step with eq (14).
#include "rmpmarl/tasks/manipulator_env.h"
#include "rmpmarl/sim/controlled_world.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "rmpmarl/common/error.h"

namespace rmpmarl::tasks {
namespace {

void Put3(float* o, const Eigen::Vector3d& v) {
  o[0] = static_cast<float>(v.x());
  o[1] = static_cast<float>(v.y());
  o[2] = static_cast<float>(v.z());
}

}  // namespace

// ------------------------------------------------------------------------------------------------- the env

ManipulatorEnv::ManipulatorEnv(std::shared_ptr<const TaskContext> context)
    : context_(std::move(context)),
      config_(context_->config()),
      nq_(context_->nq()),
      num_agents_(context_->num_agents()),
      episode_(context_) {
  const double timestep = config_.episode.physics_timestep;
  control_period_ = std::lround(1.0 / (config_.episode.control_rate * timestep)) * timestep;
  if (config_.interface == InterfaceMode::kPerJointRmp) {
    controller_ = std::make_unique<control::ReactiveController>(episode_.world().model().servos(),
                                                                episode_.agents().MakeLayerPolicy(),
                                                                config_.controller);
  }
  q_cmd_.setZero(nq_);
  q_cmd_before_.setZero(nq_);
  v_max_ = episode_.agents().velocity_limits();
  dq_max_ = config_.direct.max_speed_fraction * control_period_ * v_max_;
  info_.joint_reach.setZero(nq_);
  info_.dq_command.setZero(nq_);
  info_.qdd.setZero(nq_);
}

ManipulatorEnv::~ManipulatorEnv() = default;

void ManipulatorEnv::Reset(std::mt19937_64& rng, const StepOutput& out) {
  episode_.Draw(rng);
  if (controller_) sim::ResetController(*controller_, episode_.world());
  q_cmd_ = episode_.world().q();
  episode_.Begin();
  info_.invalid = false;
  info_.collision_events = 0;
  info_.reward = RewardTerms{};
  info_.joint_reach.setZero();
  info_.dq_command.setZero();
  info_.qdd.setZero();
  active_ = true;
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
  switch (config_.interface) {
    case InterfaceMode::kPerJointRmp: {
      q_cmd_before_ = controller_->q_cmd();
      episode_.agents().Apply(actions, option_started, parameters_read);
      episode_.loop().StepController(*controller_);
      info_.qdd = controller_->qdd();
      info_.dq_command = controller_->q_cmd() - q_cmd_before_;
      break;
    }
    case InterfaceMode::kDirect:
    case InterfaceMode::kPerJointDirect: {
      q_cmd_before_ = q_cmd_;
      sim::World& world = episode_.world();
      const Eigen::VectorXd& q = world.q();
      if ((q_cmd_ - q).cwiseAbs().maxCoeff() > config_.controller.resync_threshold) q_cmd_ = q;
      const sim::WorldModel& wm = world.model();
      for (int i = 0; i < nq_; ++i) {
        const float u = config_.interface == InterfaceMode::kDirect ? actions[a.continuous_offset() + i]
                                                                    : actions[i * size + a.continuous_offset()];
        const double dq = std::clamp(static_cast<double>(u), -1.0, 1.0) * dq_max_[i];
        q_cmd_[i] = std::clamp(q_cmd_[i] + dq, wm.lower_limits()[i], wm.upper_limits()[i]);
      }
      for (int k = 0; k < num_agents_; ++k) option_started[k] = 1.0f;
      world.SetJointTargets(q_cmd_);
      info_.dq_command = q_cmd_ - q_cmd_before_;
      break;
    }
  }
}

void ManipulatorEnv::WriteGlobal(float* s) const {
  const sim::World& world = episode_.world();
  const control::JointAgents& agents = episode_.agents();
  const sim::Scenario& scenario = episode_.scenario();
  const Eigen::Vector3d& p_WT = episode_.p_WT();
  const Eigen::Vector3d& v_WT = episode_.v_WT();
  const control::GlobalStateLayout& g = context_->global_layout();
  const kinematics::Model& m = episode_.robot().model;
  const ObservationConfig& oc = config_.observation;
  const double l = oc.length_scale, vs = oc.speed_scale;
  for (int i = 0; i < nq_; ++i) {
    const double q = world.q()[i];
    const kinematics::DofLimits& lim = m.limits()[i];
    s[g.joint_position + i] = static_cast<float>(std::isfinite(lim.lower) && std::isfinite(lim.upper) &&
                                                         lim.upper > lim.lower
                                                     ? 2.0 * (q - lim.lower) / (lim.upper - lim.lower) - 1.0
                                                     : std::atan2(std::sin(q), std::cos(q)) / M_PI);
    s[g.joint_velocity + i] = static_cast<float>(world.qd()[i] / v_max_[i]);
    s[g.joint_warning + 2 * i] = agents.warning(i).present ? 1.0f : 0.0f;
    s[g.joint_warning + 2 * i + 1] =
        agents.warning(i).present ? static_cast<float>(agents.warning(i).distance / oc.warning_distance) : 0.0f;
    if (g.has_options) {
      const control::OptionMachine& om = agents.option_machine(i);
      for (int k = 0; k < control::kNumRmpOptions; ++k) s[g.joint_option + 4 * i + k] = om.option() == k ? 1.0f : 0.0f;
      s[g.joint_option + 4 * i + 3] = om.phase_b() ? 1.0f : 0.0f;
    }
  }
  Put3(s + g.ee_position, agents.p_WE() / l);
  Put3(s + g.ee_velocity, agents.v_WE() / vs);
  Put3(s + g.target_position, p_WT / l);
  Put3(s + g.target_velocity, v_WT / vs);
  Put3(s + g.ee_to_target, (agents.p_WE() - p_WT) / l);
  s[g.log_distance] = static_cast<float>(control::LogDistanceFeature((agents.p_WE() - p_WT).norm()));
  const sim::SceneSpec& spec = world.model().scene();
  for (int j = 0; j < g.max_obstacles; ++j) {
    float* slot = s + g.obstacles + control::GlobalStateLayout::kObstacleSlot * j;
    if (j >= context_->num_obstacles()) {
      std::fill(slot, slot + control::GlobalStateLayout::kObstacleSlot, 0.0f);
      continue;
    }
    const sim::ObstacleState& o = scenario.obstacles()[j];
    slot[0] = 1.0f;
    Put3(slot + 1, o.p_WO() / l);
    Put3(slot + 4, o.v_WO() / vs);
    Put3(slot + 7, o.R_WO.col(0));
    Put3(slot + 10, o.R_WO.col(1));
    const sim::ObstacleSpec& os = spec.obstacles[j];
    Eigen::Vector3d half_size = Eigen::Vector3d::Constant(os.radius);
    if (os.shape == sim::ObstacleShape::kBox) half_size = os.half_size;
    if (os.shape == sim::ObstacleShape::kCylinder) half_size.z() = os.half_length;
    Put3(slot + 13, half_size / l);
  }
  s[g.robot_reach] = static_cast<float>(scenario.workspace().reach / l);
  s[g.progress] = static_cast<float>(episode_.steps()) / static_cast<float>(config_.episode.max_steps);
}

void ManipulatorEnv::WriteObservation(const StepOutput& out) const {
  const int dim = spec().local_obs_dim;
  if (config_.interface == InterfaceMode::kDirect) {
    WriteGlobal(out.local_obs);
  } else {
    for (int i = 0; i < num_agents_; ++i) episode_.agents().WriteLocal(i, episode_.steps(), out.local_obs + static_cast<size_t>(i) * dim);
  }
  WriteGlobal(out.global_state);
  if (out.next_action_read != nullptr) {  // which actions the next Step reads (an actor may skip the others)
    for (int i = 0; i < num_agents_; ++i) {
      bool read = true;
      if (config_.interface == InterfaceMode::kPerJointRmp) {
        read = episode_.agents().ReadsAction(i);
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
    episode_.MarkInvalid();
    active_ = false;
    if (out.metrics != nullptr) *out.metrics = episode_.Metrics();
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
  if (invalid) episode_.MarkInvalid();
  if (terminated || truncated) {
    if (out.metrics != nullptr) *out.metrics = episode_.Metrics();
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
  if (!active_ || actions == nullptr || !ValidActions(actions)) {
    std::fill(out.option_started, out.option_started + num_agents_, 0.0f);
    Finish(out, /*terminated=*/true, false, /*invalid=*/true);
    return;
  }
  episode_.BeginStep();
  info_.distance_before = episode_.last_score().distance_before;
  ApplyActions(actions, out.option_started, out.parameters_read);
  const bool ok = episode_.Advance(/*end_options=*/config_.interface == InterfaceMode::kPerJointRmp);
  if (!ok) {  // MuJoCo diverged (the World reset the robot): the episode is invalid
    Finish(out, /*terminated=*/true, false, /*invalid=*/true);
    return;
  }
  const StepScore& score = episode_.Score(info_.dq_command);
  info_.distance_after = score.distance_after;
  info_.joint_reach = score.joint_reach;
  info_.reward = score.reward;
  info_.collision_events = score.collision_events;
  Finish(out, episode_.Terminated(), episode_.Truncated(), /*invalid=*/false);
}

EnvFactory MakeManipulatorEnvFactory(std::shared_ptr<const TaskContext> context) {
  RMPMARL_ASSERT(context != nullptr, "MakeManipulatorEnvFactory: null context");
  return [context](int /*env_id*/) -> std::unique_ptr<Env> { return std::make_unique<ManipulatorEnv>(context); };
}

}  // namespace rmpmarl::tasks
