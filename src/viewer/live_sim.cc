#include "rmpmarl/viewer/live_sim.h"

#include "rmpmarl/planning/plan_follow.h"
#include "rmpmarl/sim/controlled_world.h"

#include <fmt/format.h>
#include <mujoco/mjdata.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>

#include "rmpmarl/common/error.h"
#include "rmpmarl/control/learned_controller.h"
#include "rmpmarl/control/controller.h"
#include "rmpmarl/sim/episode.h"
#include "rmpmarl/sim/world.h"

namespace rmpmarl::viewer {

FrameSource::~FrameSource() = default;

namespace {

constexpr double kAddedCubeSide = 0.1;      // [m]
constexpr double kAddedSphereRadius = 0.05; // [m]
// a dragged obstacle's velocity estimate decays to zero when no drag update came for this long [s]
constexpr double kDragHold = 0.1;

}  // namespace

/// One obstacle of the arms' worlds: a scenario obstacle (scripted ≥ 0) or room for one the page adds.
struct LiveSim::Slot {
  sim::ObstacleSpec spec;  // shape and size (compiled into the world)
  int scripted = -1;       // scenario obstacle index it follows unless held; −1: added by the page
  bool active = false;
  bool held = false;
  Eigen::Vector3d p = Eigen::Vector3d::Zero(), v = Eigen::Vector3d::Zero();
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  double drag_time = -1.0;  // simulated time of the last drag update

  rmp::Obstacle AsRmp() const {
    Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
    X.linear() = R;
    X.translation() = p;
    return spec.AsRmp(X, v);
  }
};

/// What moves an arm's scene: the live scene every arm shares. The first arm's source moves it by one physics step;
/// every arm's source writes it into its world.
class LiveSim::ArmSource final : public sim::SceneSource {
 public:
  ArmSource(LiveSim* live, bool leader) : live_(live), leader_(leader) {}
  void Advance(double dt, const sim::ContactReport& /*contacts*/, sim::World& world) override {
    if (leader_) live_->AdvanceShared(dt);
    live_->PlaceInto(world);
  }
  void FillScene(rmp::Scene* scene) const override { live_->FillScene(scene); }
  const sim::TargetState& target() const override { return live_->live_target_; }

 private:
  LiveSim* live_;
  bool leader_;
};

/// One arm: its world, controller and episode loop.
struct LiveSim::Arm {
  std::string controller;  // "learned" or "rmpflow"
  std::string label;
  std::unique_ptr<sim::World> world;
  std::unique_ptr<control::ReactiveController> control;
  control::LearnedController* learned = nullptr;  // the controller's policy when learned
  std::unique_ptr<ArmSource> source;
  sim::EpisodeLoop loop;

  double clearance = std::numeric_limits<double>::infinity();
  long collisions_before = 0;  // events counted before the arm's loop last restarted
  double step_us = 0.0;

  long collisions() const { return collisions_before + loop.Metrics().collisions; }
};

LiveSim::LiveSim(kinematics::Robot robot, std::shared_ptr<const control::PolicyFile> policy, std::string policy_path,
                 LiveSimOptions options)
    : robot_(std::move(robot)), policy_(std::move(policy)), policy_path_(std::move(policy_path)),
      options_(std::move(options)) {
  if (options_.controller != "learned" && options_.controller != "rmpflow") {
    throw InputError(fmt::format("viewer: controller must be 'learned' or 'rmpflow', got '{}'", options_.controller));
  }
  if (policy_ == nullptr && (options_.controller == "learned" || options_.side_by_side)) {
    throw InputError("viewer: the learned controller needs a controller file (--policy FILE); without one only "
                     "--policy rmpflow runs");
  }
  if (options_.extra_boxes < 0 || options_.extra_spheres < 0 || options_.max_obstacles < 1 ||
      !(options_.arena > 0.0)) {
    throw InputError(fmt::format("viewer: extra_boxes and extra_spheres must be >= 0, max_obstacles >= 1 and arena "
                                 "> 0, got {}, {}, {}, {}", options_.extra_boxes, options_.extra_spheres,
                                 options_.max_obstacles, options_.arena));
  }
  policy_label_ = policy_ != nullptr ? std::filesystem::path(policy_path_).stem().string() : "";
  scenario_ = options_.scene ? std::make_unique<sim::StaticScenario>(robot_, *options_.scene)
                             : sim::MakeScenario(options_.scenario, robot_, options_.overrides);
  sim::SceneSpec spec = scenario_->scene_spec();
  shadow_model_ = std::make_shared<const sim::WorldModel>(robot_, spec);
  shadow_ = std::make_unique<sim::World>(shadow_model_);
  for (int j = 0; j < scenario_->num_obstacles(); ++j) {
    Slot s;
    s.spec = spec.obstacles[j];
    s.scripted = j;
    slots_.push_back(s);
  }
  for (int k = 0; k < options_.extra_boxes + options_.extra_spheres; ++k) {
    Slot s;
    s.spec = k < options_.extra_boxes ? sim::ObstacleSpec::Cube(kAddedCubeSide)
                                      : sim::ObstacleSpec::Sphere(kAddedSphereRadius);
    spec.obstacles.push_back(s.spec);
    slots_.push_back(s);
  }
  model_ = std::make_shared<const sim::WorldModel>(robot_, spec);
  obstacle_views_.reserve(slots_.size());

  limits_.arena = options_.arena;
  limits_.num_obstacle_ids = static_cast<int>(slots_.size());
  limits_.controllers = policy_ != nullptr ? std::vector<std::string>{"learned", "rmpflow"}
                                           : std::vector<std::string>{"rmpflow"};
  controller_ = options_.controller;
  side_by_side_ = options_.side_by_side;
  seed_ = options_.seed;
  Reset(seed_);
}

LiveSim::~LiveSim() = default;

std::unique_ptr<LiveSim::Arm> LiveSim::MakeArm(const std::string& controller, const Eigen::VectorXd& q,
                                               const Eigen::VectorXd& qd) const {
  auto arm = std::make_unique<Arm>();
  // a planning scene has its own surfaces (a cell's boards may lie below the base): the planner checks its obstacles
  // only, as benchmark mbm plans; a built-in scenario stands on the floor at z = 0
  planning::PlanFollowOptions plan;
  plan.planner.check_floor = !options_.scene.has_value();
  plan.plan_beside_loop = options_.plan_beside_loop;
  arm->controller = controller;
  arm->world = std::make_unique<sim::World>(model_);
  arm->world->Reset(q, qd);
  const int max_obstacles = static_cast<int>(slots_.size());
  if (controller == "learned") {
    std::unique_ptr<control::LearnedController> learned =
        control::MakeLearnedController(robot_, *policy_, policy_path_, max_obstacles);
    const control::ControllerOptions options = learned->controller_options();
    arm->learned = learned.get();
    arm->label = policy_label_;
    std::unique_ptr<control::AccelerationPolicy> policy = std::move(learned);
    if (options_.plan) policy = planning::MakePlanFollower(robot_, std::move(policy), options, plan);
    arm->control = std::make_unique<control::ReactiveController>(model_->servos(), std::move(policy), options);
  } else {
    arm->label = "RMPflow";
    std::unique_ptr<control::AccelerationPolicy> policy =
        std::make_unique<control::RmpflowAccelerationPolicy>(robot_, max_obstacles);
    if (options_.plan) {
      policy = planning::MakePlanFollower(robot_, std::move(policy), control::ControllerOptions{}, plan);
    }
    arm->control = std::make_unique<control::ReactiveController>(model_->servos(), std::move(policy));
  }
  if (options_.plan) arm->label = "plan + " + arm->label;
  sim::ResetController(*arm->control, *arm->world);
  return arm;
}

void LiveSim::BuildArms() {
  // the new arms start from the first arm's state (or the scenario's start posture); the old ones stay until every
  // new one is built
  Eigen::VectorXd q = scenario_->q_start(), qd = Eigen::VectorXd::Zero(robot_.model.nq());
  if (!arms_.empty()) {
    q = arms_[0]->world->q();
    qd = arms_[0]->world->qd();
  }
  const std::vector<std::string> wanted = side_by_side_ ? std::vector<std::string>{"learned", "rmpflow"}
                                                        : std::vector<std::string>{controller_};
  std::vector<std::unique_ptr<Arm>> arms;
  double period = 0.0;
  for (const std::string& c : wanted) {
    arms.push_back(MakeArm(c, q, qd));
    const double p = arms.back()->control->control_period();
    if (arms.size() == 1) period = p;
    if (std::abs(p - period) > 1e-12) {
      throw InputError(fmt::format("the {} controller runs at {:g} Hz, the {} controller at {:g} Hz; side by side "
                                   "needs one control rate", wanted[0], 1.0 / period, c, 1.0 / p));
    }
  }
  arms_ = std::move(arms);
  period_ = period;
  physics_steps_ = arms_[0]->control->physics_steps_per_control();
  dt_ = period_ / physics_steps_;
  PlaceObstacles();
  for (std::size_t a = 0; a < arms_.size(); ++a) {
    Arm& arm = *arms_[a];
    arm.source = std::make_unique<ArmSource>(this, a == 0);
    arm.loop.Begin(arm.world.get(), arm.source.get(), physics_steps_, sim::LoopOptions{});
  }
  UpdateHello();
}

void LiveSim::Reset(std::uint64_t seed) {
  seed_ = seed;
  scenario_->Reset(seed, *shadow_);
  for (Slot& s : slots_) {
    s.held = false;
    s.v.setZero();
    s.drag_time = -1.0;
    s.active = s.scripted >= 0;
    if (s.scripted >= 0) {
      const sim::ObstacleState& o = scenario_->obstacles()[s.scripted];
      s.p = o.p_WO();
      s.v = o.v_WO();
      s.R = o.R_WO;
    }
  }
  target_held_ = false;
  p_WT_ = scenario_->target().p_WT;
  v_WT_ = scenario_->target().v_WT;
  time_ = 0.0;
  arms_.clear();
  BuildArms();
}

void LiveSim::PlaceObstacles() {
  live_target_.p_WT = p_WT_;
  live_target_.v_WT = target_held_ ? Eigen::Vector3d::Zero() : v_WT_;
  for (const auto& arm : arms_) PlaceInto(*arm->world);
}

void LiveSim::PlaceInto(sim::World& world) const {
  for (std::size_t j = 0; j < slots_.size(); ++j) {
    const Slot& s = slots_[j];
    if (s.active) {
      world.SetObstaclePose(static_cast<int>(j), s.p, s.R);
    } else {
      world.SetObstaclePose(static_cast<int>(j), sim::ParkedPose());
    }
  }
  world.SetTargetPosition(p_WT_);
}

void LiveSim::FillObstacleViews() {
  obstacle_views_.clear();
  for (std::size_t j = 0; j < slots_.size(); ++j) {
    const Slot& s = slots_[j];
    if (s.active) obstacle_views_.push_back({static_cast<int>(j), s.AsRmp(), s.held});
  }
}

void LiveSim::FillScene(rmp::Scene* scene) const {
  scene->obstacles.clear();
  for (const Slot& s : slots_) {
    if (s.active) scene->obstacles.push_back(s.AsRmp());
  }
  scene->has_target = true;
  scene->p_WT = p_WT_;
  scene->v_WT = target_held_ ? Eigen::Vector3d::Zero() : v_WT_;
  // a motion-plan request's joint goal (--request): the controllers and the planner go for it, as a benchmark does
  scene->q_T = scenario_->joint_goal();
}

void LiveSim::AdvanceShared(double dt) {
  scenario_->Advance(dt, no_contacts_, *shadow_);
  time_ += dt;
  // the worlds get what the scenario moved; held and removed obstacles stay where they were placed
  for (Slot& s : slots_) {
    if (!s.active) continue;
    if (s.held) {
      if (s.drag_time >= 0.0 && time_ - s.drag_time > kDragHold) s.v.setZero();
    } else if (s.scripted >= 0) {
      const sim::ObstacleState& o = scenario_->obstacles()[s.scripted];
      s.p = o.p_WO();
      s.v = o.v_WO();
      s.R = o.R_WO;
    }
  }
  if (!target_held_) {
    p_WT_ = scenario_->target().p_WT;
    v_WT_ = scenario_->target().v_WT;
  }
  live_target_.p_WT = p_WT_;
  live_target_.v_WT = target_held_ ? Eigen::Vector3d::Zero() : v_WT_;
}

void LiveSim::ControlStep() {
  // the arms' loops in lockstep: every controller on the scene as the page left it, then each physics step of the
  // shared scene in every world, then the period's end
  for (const auto& arm : arms_) {
    arm->loop.RefreshScene();
    arm->step_us = arm->loop.StepController(*arm->control).compute_us;
  }
  for (int k = 0; k < physics_steps_; ++k) {
    for (const auto& arm : arms_) arm->loop.PhysicsStep();
  }
  for (const auto& arm : arms_) {
    if (!arm->loop.EndPeriod()) {
      // MuJoCo reset the robot state: start this arm again from the scenario's start posture
      fmt::print(stderr, "rmpmarl view: the {} arm's simulation became non-finite at t = {:.3f} s; it restarts "
                         "from the start posture\n", arm->label, time_);
      arm->collisions_before = arm->collisions();
      arm->world->Reset(scenario_->q_start());
      sim::ResetController(*arm->control, *arm->world);
      PlaceInto(*arm->world);
      arm->loop.Begin(arm->world.get(), arm->source.get(), physics_steps_, sim::LoopOptions{});
    }
  }
  FillObstacleViews();
  for (const auto& arm : arms_) {
    arm->clearance = Clearance(*arm->world, obstacle_views_);
  }
}

void LiveSim::AdvanceTo(double t) {
  // whole control steps while the next one ends at or before t (half a step of slack against rounding)
  while (next_time() <= t) ControlStep();
}

std::string LiveSim::ActiveIds() const {
  std::vector<int> ids = obstacle_ids();
  return ids.empty() ? std::string("none") : fmt::format("{}", fmt::join(ids, ", "));
}

std::string LiveSim::Apply(const Command& c) {
  const std::string_view name = CommandName(c.kind);
  auto slot_in_scene = [&](int id) -> Slot* {
    if (id < 0 || id >= static_cast<int>(slots_.size()) || !slots_[id].active) return nullptr;
    return &slots_[id];
  };
  switch (c.kind) {
    case CommandKind::kSetTarget:
      target_held_ = true;
      p_WT_ = c.p;
      v_WT_.setZero();
      PlaceObstacles();
      return {};
    case CommandKind::kReleaseTarget:
      target_held_ = false;
      p_WT_ = scenario_->target().p_WT;
      v_WT_ = scenario_->target().v_WT;
      PlaceObstacles();
      return {};
    case CommandKind::kSetObstacle: {
      Slot* s = slot_in_scene(c.id);
      if (s == nullptr) return fmt::format("{}: obstacle {} is not in the scene (ids: {})", name, c.id, ActiveIds());
      if (s->held && s->drag_time >= 0.0 && time_ > s->drag_time) {
        // the velocity the controllers see: the drag's, smoothed over updates
        const Eigen::Vector3d v = (c.p - s->p) / std::max(time_ - s->drag_time, period_);
        s->v = 0.5 * (s->v + v);
      } else if (!s->held || s->drag_time < 0.0) {
        s->v.setZero();
      }
      s->held = true;
      s->p = c.p;
      s->drag_time = time_;
      PlaceObstacles();
      return {};
    }
    case CommandKind::kAddObstacle: {
      const int active = static_cast<int>(std::count_if(slots_.begin(), slots_.end(),
                                                        [](const Slot& s) { return s.active; }));
      if (active >= options_.max_obstacles) {
        return fmt::format("{}: the scene holds {} obstacles, the most it takes", name, active);
      }
      const sim::ObstacleShape shape =
          c.shape == rmp::ObstacleShape::kSphere ? sim::ObstacleShape::kSphere : sim::ObstacleShape::kBox;
      for (Slot& s : slots_) {
        if (s.active || s.scripted >= 0 || s.spec.shape != shape) continue;
        s.active = true;
        s.held = true;
        s.p = c.p;
        s.v.setZero();
        s.R.setIdentity();
        s.drag_time = -1.0;
        PlaceObstacles();
        return {};
      }
      return fmt::format("{}: no room for another {} ({} at most; remove one first)", name,
                         shape == sim::ObstacleShape::kSphere ? "sphere" : "cube",
                         shape == sim::ObstacleShape::kSphere ? options_.extra_spheres : options_.extra_boxes);
    }
    case CommandKind::kRemoveObstacle: {
      Slot* s = slot_in_scene(c.id);
      if (s == nullptr) return fmt::format("{}: obstacle {} is not in the scene (ids: {})", name, c.id, ActiveIds());
      s->active = false;
      s->held = false;
      s->v.setZero();
      PlaceObstacles();
      return {};
    }
    case CommandKind::kReset:
      Reset(c.seed.value_or(seed_));
      return {};
    case CommandKind::kController:
    case CommandKind::kSideBySide: {
      if (c.kind == CommandKind::kSideBySide && c.on && policy_ == nullptr) {
        return fmt::format("{}: needs a learned controller (start with --policy FILE)", name);
      }
      const std::string controller = controller_;
      const bool side_by_side = side_by_side_;
      if (c.kind == CommandKind::kController) {
        if (c.name == controller_ && !side_by_side_) return {};
        controller_ = c.name;
        side_by_side_ = false;
      } else {
        if (c.on == side_by_side_) return {};
        side_by_side_ = c.on;
        if (!c.on) controller_ = "learned";
      }
      try {
        BuildArms();
      } catch (const InputError& e) {
        controller_ = controller;  // the arms as they were
        side_by_side_ = side_by_side;
        return fmt::format("{}: {}", name, e.what());
      }
      return {};
    }
    case CommandKind::kSeek:
      return fmt::format("{}: only a replay can seek", name);
    case CommandKind::kPause:
    case CommandKind::kResume:
    case CommandKind::kStep:
    case CommandKind::kSpeed:
      break;
  }
  return fmt::format("{}: not handled by the simulation", name);
}

void LiveSim::UpdateHello() {
  HelloInfo info;
  info.mode = "live";
  for (const auto& arm : arms_) info.arms.push_back({arm->label, arm->controller});
  info.controllers = limits_.controllers;
  info.controller = arms_.front()->controller;
  info.side_by_side = side_by_side_;
  info.workspace_min = scenario_->workspace().box.min();
  info.workspace_max = scenario_->workspace().box.max();
  info.max_obstacles = options_.max_obstacles;
  info.arena = options_.arena;
  info.min_speed = limits_.min_speed;
  info.max_speed = limits_.max_speed;
  info.control_rate = 1.0 / period_;
  info.scenario = scenario_->name();
  info.seed = seed_;
  info.visuals = options_.visuals;
  hello_ = EncodeHello(robot_, info);
  ++hello_version_;
}

void LiveSim::Frame(const FrameStats& stats, std::string* out) {
  FillObstacleViews();
  std::vector<ArmView> arms;
  arms.reserve(arms_.size());
  for (int a = 0; a < num_arms(); ++a) {
    const Arm& arm = *arms_[a];
    ArmView v;
    v.world = arm.world.get();
    v.warnings = arm.loop.warnings();
    v.learned = arm.learned;
    v.p_WE = end_effector(a);
    v.clearance = arm.clearance;
    v.collisions = arm.collisions();
    v.step_us = arm.step_us;
    arms.push_back(v);
  }
  FrameView f;
  f.seq = stats.seq;
  f.time = time_;
  f.paused = stats.paused;
  f.speed = stats.speed;
  f.rtf = stats.rtf;
  f.load = stats.load;
  f.refused = stats.refused;
  f.p_WT = p_WT_;
  f.target_held = target_held_;
  f.obstacles = obstacle_views_;
  f.arms = arms;
  EncodeFrame(f, out);
}

const sim::World& LiveSim::world(int arm) const {
  RMPMARL_ASSERT(arm >= 0 && arm < num_arms(), "LiveSim::world: arm index out of range");
  return *arms_[arm]->world;
}

const std::string& LiveSim::controller(int arm) const {
  RMPMARL_ASSERT(arm >= 0 && arm < num_arms(), "LiveSim::controller: arm index out of range");
  return arms_[arm]->controller;
}

Eigen::Vector3d LiveSim::end_effector(int arm) const { return world(arm).EndEffectorPosition(); }

std::vector<int> LiveSim::obstacle_ids() const {
  std::vector<int> ids;
  for (std::size_t j = 0; j < slots_.size(); ++j) {
    if (slots_[j].active) ids.push_back(static_cast<int>(j));
  }
  return ids;
}

Eigen::Vector3d LiveSim::obstacle_position(int id) const {
  RMPMARL_ASSERT(id >= 0 && id < static_cast<int>(slots_.size()) && slots_[id].active,
                 "LiveSim::obstacle_position: obstacle not in the scene");
  return slots_[id].p;
}

long LiveSim::collisions(int arm) const {
  RMPMARL_ASSERT(arm >= 0 && arm < num_arms(), "LiveSim::collisions: arm index out of range");
  return arms_[arm]->collisions();
}

}  // namespace rmpmarl::viewer
