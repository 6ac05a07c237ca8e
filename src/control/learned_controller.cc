// The learned per-joint agents as an acceleration policy: warning contacts from the capsules and the scene, the
// agents' observations and actions at the control rate, their basic layer at every substep.
#include "rmpmarl/control/learned_controller.h"

#include <fmt/format.h>

#include <cmath>

#include "rmpmarl/common/error.h"
#include "rmpmarl/math/geometry.h"

namespace rmpmarl::control {

LearnedController::LearnedController(const kinematics::Robot& robot, const AgentConfig& config,
                                     const PolicyWeights& weights, LearnedControllerOptions options)
    : options_(std::move(options)),
      robot_(robot),
      agents_(config, &robot),
      runtime_(weights, robot.model.nq()),
      warnings_(robot, {.margin = config.observation.warning_distance, .floor_height = options_.floor_height,
                        .max_obstacles = std::max(options_.max_obstacles, 0)}) {
  if (config.interface != InterfaceMode::kPerJointRmp) {
    throw InputError(fmt::format("learned controller '{}': the per-joint-rmp interface runs as a controller, got {} "
                                 "(evaluate it in its task with `rmpmarl eval`)", options_.name,
                                 InterfaceModeName(config.interface)));
  }
  if (!(options_.max_obstacles >= 0)) {
    throw InputError(fmt::format("learned controller '{}': max_obstacles: expected >= 0, got {}", options_.name,
                                 options_.max_obstacles));
  }
  const int nq = robot.model.nq();
  obs_dim_ = static_cast<int>(PerJointObservationNames(config.interface, config.observation.lookahead > 0.0).size());
  action_size_ = MakeActionSpec(config, nq).size();
  if (runtime_.obs_dim() != obs_dim_ || runtime_.action_size() != action_size_) {
    throw InputError(fmt::format("learned controller '{}': the actor takes {} observations and gives {} action "
                                 "floats; its task ({}, lookahead {}) has {} and {}", options_.name,
                                 runtime_.obs_dim(), runtime_.action_size(), InterfaceModeName(config.interface),
                                 config.observation.lookahead, obs_dim_, action_size_));
  }
  layer_ = agents_.MakeLayerPolicy();
  obs_.assign(static_cast<size_t>(nq) * obs_dim_, 0.0f);
  hold_scene_.obstacles.reserve(options_.max_obstacles);
  actions_.assign(static_cast<size_t>(nq) * action_size_, 0.0f);
  reads_.assign(nq, 1.0f);
}

LearnedController::~LearnedController() = default;

int LearnedController::nq() const { return robot_.model.nq(); }

ControllerOptions LearnedController::controller_options() const {
  ControllerOptions o = agents_.config().controller;
  o.control_rate = agents_.config().episode.control_rate;
  return o;
}

void LearnedController::Reset(const Eigen::Ref<const Eigen::VectorXd>& /*q0*/) {
  agents_.Reset();
  steps_ = 0;
  started_ = false;
  holding_ = false;
}

void LearnedController::BeginControlStep(const Eigen::Ref<const Eigen::VectorXd>& q,
                                         const Eigen::Ref<const Eigen::VectorXd>& qd, const rmp::Scene& scene) {
  if (static_cast<int>(scene.obstacles.size()) > options_.max_obstacles) {
    throw InputError(fmt::format("learned controller '{}': the scene holds {} obstacles, the controller was made for "
                                 "at most {} (LearnedControllerOptions::max_obstacles)", options_.name,
                                 scene.obstacles.size(), options_.max_obstacles));
  }
  // the kinematics first (the warnings need the capsules where the arm is), then the joints' warnings. Without a
  // target the agents hold the end effector where it was at the first step without one (a target that followed the
  // end effector would let the layer's posture and obstacle terms carry it away).
  if (scene.has_target) {
    holding_ = false;
    agents_.SenseState(q, qd, scene.p_WT, scene.v_WT);
  } else {
    if (!holding_) {
      agents_.SenseState(q, qd, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
      p_hold_ = agents_.p_WE();
      holding_ = true;
    }
    agents_.SenseState(q, qd, p_hold_, Eigen::Vector3d::Zero());
  }
  warnings_.Sense(agents_.kinematics(), scene);
  agents_.SenseContacts(warnings_.contacts(), scene);
  if (started_) agents_.End();  // the last step's options end on what is sensed now, as in the env
  const int n = nq();
  for (int i = 0; i < n; ++i) agents_.WriteLocal(i, steps_, obs_.data() + static_cast<size_t>(i) * obs_dim_);
  // the network for the agents whose action Apply reads (with held parameters, at most steps none)
  for (int i = 0; i < n; ++i) reads_[i] = agents_.ReadsAction(i) ? 1.0f : 0.0f;
  runtime_.ActWhere(obs_.data(), n, reads_.data(), actions_.data());
  agents_.Apply(actions_.data(), nullptr, nullptr);
  started_ = true;
  // the progress feature saturates at the task's episode length; the count stops there too (no overflow)
  if (steps_ < agents_.config().episode.max_steps) ++steps_;
}

void LearnedController::Evaluate(const Eigen::Ref<const Eigen::VectorXd>& q,
                                 const Eigen::Ref<const Eigen::VectorXd>& qd, const rmp::Scene& scene,
                                 Eigen::Ref<Eigen::VectorXd> qdd) {
  if (!holding_ || scene.has_target) {
    layer_->Evaluate(q, qd, scene, qdd);
    return;
  }
  // the held position is the layer's target too (the obstacles copied into reserved storage: no allocation)
  hold_scene_.obstacles = scene.obstacles;
  hold_scene_.q_T = scene.q_T;
  hold_scene_.q_T_metric = scene.q_T_metric;
  hold_scene_.qd_T = scene.qd_T;
  hold_scene_.qdd_T = scene.qdd_T;
  hold_scene_.has_target = true;
  hold_scene_.p_WT = p_hold_;
  hold_scene_.v_WT.setZero();
  layer_->Evaluate(q, qd, hold_scene_, qdd);
}

std::unique_ptr<LearnedController> MakeLearnedController(const kinematics::Robot& robot, const PolicyFile& file,
                                                         const std::string& path, LearnedControllerOptions options) {
  const AgentConfig config = PolicyAgentConfig(file, path);
  if (options.name == "learned") options.name = std::filesystem::path(path).stem().string();
  try {
    return std::make_unique<LearnedController>(robot, config, file.weights, options);
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}: {}", path, e.what()));
  }
}

std::unique_ptr<LearnedController> MakeLearnedController(const kinematics::Robot& robot, const PolicyFile& file,
                                                         const std::string& path, int max_obstacles) {
  LearnedControllerOptions options;
  options.max_obstacles = max_obstacles;
  return MakeLearnedController(robot, file, path, options);
}

}  // namespace rmpmarl::control
