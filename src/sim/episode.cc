// The one episode loop: EpisodeLoop's stages (scene, control, physics with the scenario moving, contacts, collision
// events, the end effector's error) and RunEpisode, which drives them for a controller alone.
#include "rmpmarl/sim/episode.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/forward_kinematics.h"

namespace rmpmarl::sim {

ObstacleSensor::~ObstacleSensor() = default;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

void CheckLoopOptions(const LoopOptions& o, std::string_view what) {
  if (!std::isfinite(o.reach_tolerance) || !(o.reach_tolerance > 0.0)) {
    throw InputError(fmt::format("{}.reach_tolerance: expected a finite distance > 0 m, got {}", what,
                                 o.reach_tolerance));
  }
  if (std::isnan(o.success_max_final_error) || !(o.success_max_final_error > 0.0)) {
    throw InputError(fmt::format("{}.success_max_final_error: expected a distance > 0 m (inf: any), got {}", what,
                                 o.success_max_final_error));
  }
  if (!std::isfinite(o.settle_time) || o.settle_time < 0.0) {
    throw InputError(fmt::format("{}.settle_time: expected a finite time >= 0 s, got {}", what, o.settle_time));
  }
  if (!std::isfinite(o.warning_margin) || !(o.warning_margin > 0.0)) {
    throw InputError(fmt::format("{}.warning_margin: expected a finite distance > 0 m, got {}", what,
                                 o.warning_margin));
  }
  if (std::isinf(o.floor_height)) {
    throw InputError(fmt::format("{}.floor_height: expected a finite height or NaN (no floor), got {}", what,
                                 o.floor_height));
  }
}

void CheckOptions(const EpisodeOptions& o) {
  if (!std::isfinite(o.duration) || !(o.duration > 0.0)) {
    throw InputError(fmt::format("EpisodeOptions.duration: expected a finite time > 0 s, got {}", o.duration));
  }
  if (!std::isfinite(o.video_fps) || o.video_fps < 0.0) {
    throw InputError(fmt::format("EpisodeOptions.video_fps: expected a finite rate >= 0 Hz, got {}", o.video_fps));
  }
  CheckLoopOptions(o.loop, "EpisodeOptions.loop");
}

}  // namespace

// ------------------------------------------------------------------------------------------- collision events

CollisionCounter::CollisionCounter(int num_links, int num_obstacles)
    : num_obstacles_(num_obstacles),
      partners_(num_obstacles + num_links + 1),
      last_seen_(static_cast<size_t>(num_links) * partners_, -10) {}

void CollisionCounter::Reset() { std::fill(last_seen_.begin(), last_seen_.end(), -10); }

CollisionCounter::Events CollisionCounter::Count(const ContactReport& report, long physics_step) {
  Events events;
  for (const CollidingPair& p : report.colliding_pairs) {
    int partner = partners_ - 1;  // the floor
    if (p.other_kind == PartnerKind::kObstacle) partner = p.other_index;
    if (p.other_kind == PartnerKind::kLink) partner = num_obstacles_ + p.other_index;
    const size_t key = static_cast<size_t>(p.link) * partners_ + partner;
    RMPMARL_ASSERT(key < last_seen_.size(), "CollisionCounter: a pair outside the counter's links and obstacles");
    long& seen = last_seen_[key];
    if (seen != physics_step - 1) {  // the pair enters penetration
      if (p.other_kind == PartnerKind::kLink) {
        ++events.self;
      } else {
        ++events.obstacle;
      }
    }
    seen = physics_step;
  }
  return events;
}

// ----------------------------------------------------------------------------------------------- the loop

void EpisodeLoop::Begin(World* world, Scenario* scenario, int physics_steps, const LoopOptions& options,
                        ObstacleSensor* sensor) {
  Begin(world, static_cast<SceneSource*>(scenario), physics_steps, options, sensor);
  scenario_ = scenario;
}

void EpisodeLoop::Begin(World* world, SceneSource* source, int physics_steps, const LoopOptions& options,
                        ObstacleSensor* sensor) {
  RMPMARL_ASSERT(world != nullptr && source != nullptr, "EpisodeLoop::Begin: null world or scene source");
  if (physics_steps < 1) {
    throw InputError(fmt::format("EpisodeLoop: expected >= 1 physics steps per control period, got {}",
                                 physics_steps));
  }
  CheckLoopOptions(options, "LoopOptions");
  world_ = world;
  source_ = source;
  scenario_ = nullptr;
  sensor_ = sensor;
  options_ = options;
  physics_steps_ = physics_steps;
  timestep_ = world->mj_model()->opt.timestep;
  const kinematics::Robot& robot = world->model().robot();
  const kinematics::Model& model = robot.model;
  const control::WarningSensorOptions sensing{options.warning_margin, options.floor_height,
                                              world->model().num_obstacles()};
  if (kin_model_ != &model) {
    kin_.emplace(model);
    kin_model_ = &model;
    counter_ = CollisionCounter(model.num_links(), world->model().num_obstacles());
    warnings_.reset();
  }
  const auto same = [](double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); };
  if (!warnings_ || warnings_->options().margin != sensing.margin ||
      !same(warnings_->options().floor_height, sensing.floor_height) ||
      warnings_->options().max_obstacles != sensing.max_obstacles) {
    warnings_.emplace(robot, sensing);
  }
  counter_.Reset();
  physics_step_ = 0;
  steps_ = 0;
  tracking_sum_ = settled_sum_ = 0.0;
  settled_steps_ = 0;
  collision_physics_steps_ = 0;
  control_us_sum_ = 0.0;
  period_step_ = 0;
  metrics_ = EpisodeMetrics{};

  contacts_ = &world->QueryContacts();
  Observe(*contacts_);  // pairs in penetration at the start are collision events at t = 0, not again later
  metrics_.collisions = observed_.total();
  metrics_.obstacle_collisions = observed_.obstacle;
  metrics_.self_collisions = observed_.self;
  collision_physics_steps_ = 0;
  step_events_ = {};
  source->FillScene(&scene_);
  if (sensor_ != nullptr) sensor_->Reset(*world);
  SenseState();
  metrics_.min_clearance = warnings_->min_clearance();
  metrics_.min_self_clearance = warnings_->min_self_clearance();
  if (error_ < options_.reach_tolerance) metrics_.time_to_reach = 0.0;
}

const Scenario& EpisodeLoop::scenario() const {
  RMPMARL_ASSERT(scenario_ != nullptr, "EpisodeLoop::scenario: the episode's scene source is not a Scenario");
  return *scenario_;
}

void EpisodeLoop::Observe(const ContactReport& report) {
  observed_ = counter_.Count(report, physics_step_);
  if (!report.colliding_pairs.empty()) ++collision_physics_steps_;
}

void EpisodeLoop::SenseState() {
  const kinematics::Robot& robot = world_->model().robot();
  kinematics::CalcVelocityKinematics(robot.model, world_->q(), world_->qd(), &*kin_);
  const Eigen::Vector3d p_WE =
      kinematics::CalcPointPosition(*kin_, robot.end_effector.link, robot.end_effector.X_LE.translation());
  error_ = (p_WE - source_->target().p_WT).norm();
  warnings_->Sense(*kin_, scene_);
}

void EpisodeLoop::RefreshScene() {
  RMPMARL_ASSERT(world_ != nullptr, "EpisodeLoop: Begin first");
  source_->FillScene(&scene_);
}

const rmp::Scene& EpisodeLoop::SenseScene() {
  RMPMARL_ASSERT(world_ != nullptr, "EpisodeLoop: Begin first");
  if (sensor_ == nullptr) return scene_;
  sensed_.has_target = scene_.has_target;
  sensed_.p_WT = scene_.p_WT;
  sensed_.v_WT = scene_.v_WT;
  sensed_.obstacles = scene_.obstacles;  // the truth, for the sensor to score itself; replaced by Sense
  sensor_->Sense(*world_, &sensed_);
  return sensed_;
}

control::ControlStepResult EpisodeLoop::StepController(control::ReactiveController& controller) {
  const control::ControlStepResult r = sim::StepController(controller, *world_, SenseScene());
  AddControlTime(r.compute_us);
  if (!r.finite) ++metrics_.nonfinite_policy_outputs;
  return r;
}

void EpisodeLoop::AddControlTime(double us) {
  control_us_sum_ += us;
  metrics_.max_control_us = std::max(metrics_.max_control_us, us);
}

bool EpisodeLoop::Advance() {
  for (int s = 0; s < physics_steps_; ++s) {
    if (!PhysicsStep()) break;
  }
  return EndPeriod();
}

bool EpisodeLoop::PhysicsStep() {
  RMPMARL_ASSERT(world_ != nullptr, "EpisodeLoop: Begin first");
  if (period_step_ == 0) {
    period_events_ = {};
    period_ok_ = true;
  }
  if (options_.scenario_update == ScenarioUpdate::kPhysicsStep) {
    source_->Advance(timestep_, *contacts_, *world_);
  } else if (period_step_ == 0) {
    source_->Advance(physics_steps_ * timestep_, *contacts_, *world_);
  }
  const bool ok = world_->Step(1).ok;
  ++physics_step_;
  ++period_step_;
  contacts_ = &world_->QueryContacts();
  Observe(*contacts_);
  period_events_.obstacle += observed_.obstacle;
  period_events_.self += observed_.self;
  period_ok_ = period_ok_ && ok;
  return ok;
}

bool EpisodeLoop::EndPeriod() {
  RMPMARL_ASSERT(world_ != nullptr, "EpisodeLoop: Begin first");
  period_step_ = 0;
  step_events_ = period_events_;
  source_->FillScene(&scene_);
  ++steps_;
  SenseState();
  if (!period_ok_) {  // MuJoCo diverged (the World reset the robot): the episode is invalid, this step is not scored
    metrics_.invalid = true;
    return false;
  }
  metrics_.collisions += step_events_.total();
  metrics_.obstacle_collisions += step_events_.obstacle;
  metrics_.self_collisions += step_events_.self;
  metrics_.min_clearance = std::min(metrics_.min_clearance, warnings_->min_clearance());
  metrics_.min_self_clearance = std::min(metrics_.min_self_clearance, warnings_->min_self_clearance());
  tracking_sum_ += error_;
  metrics_.max_tracking_error = std::max(metrics_.max_tracking_error, error_);
  if (steps_ * (physics_steps_ * timestep_) >= options_.settle_time - 1e-9) {
    settled_sum_ += error_;
    ++settled_steps_;
  }
  if (metrics_.time_to_reach < 0.0 && error_ < options_.reach_tolerance) metrics_.time_to_reach = time();
  return true;
}

double EpisodeLoop::time() const { return world_->time(); }

EpisodeMetrics EpisodeLoop::Metrics() const {
  EpisodeMetrics m = metrics_;
  m.length = steps_;
  m.physics_steps = physics_step_;
  m.duration = physics_step_ * timestep_;
  m.mean_tracking_error = steps_ > 0 ? tracking_sum_ / steps_ : error_;
  m.final_tracking_error = error_;
  m.settled_tracking_error = settled_steps_ > 0 ? settled_sum_ / settled_steps_ : kNaN;
  m.time_in_collision = collision_physics_steps_ * timestep_;
  m.mean_control_us = steps_ > 0 ? control_us_sum_ / steps_ : 0.0;
  m.reached = error_ <= options_.reach_tolerance;
  m.success = !m.invalid && m.collisions == 0 && m.final_tracking_error <= options_.success_max_final_error;
  return m;
}

// ------------------------------------------------------------------------------------------- RunEpisode

void MaybeFrame(const EpisodeLoop& loop, double fps, int* next_frame, const FrameCallback& on_frame) {
  if (!(fps > 0.0) || !on_frame || loop.time() + 1e-9 < *next_frame / fps) return;
  on_frame(FrameInfo{*next_frame, loop.time(), &loop.world(), loop.scenario_or_null(), &loop.contacts(),
                     loop.tracking_error(), loop.sensor(), loop.warnings(), &loop.kinematics(), &loop.scene()});
  ++*next_frame;
}

EpisodeMetrics RunEpisode(const EpisodeOptions& options, World& world, control::ReactiveController& controller,
                          Scenario& scenario, const FrameCallback& on_frame) {
  CheckOptions(options);
  if (controller.nq() != world.nq()) {
    throw InputError(fmt::format("RunEpisode: expected a controller for the world's {} joints, got one for {}",
                                 world.nq(), controller.nq()));
  }
  scenario.Reset(options.seed, world);
  sim::ResetController(controller, world);
  EpisodeLoop loop;
  loop.Begin(&world, &scenario, controller.physics_steps_per_control(), options.loop, options.sensor);
  const long control_steps = std::max(1L, std::lround(options.duration / controller.control_period()));
  int next_frame = 0;
  MaybeFrame(loop, options.video_fps, &next_frame, on_frame);
  for (long k = 0; k < control_steps; ++k) {
    if (options.stop_on_collision && (loop.Metrics().collisions > 0 || loop.contacts().num_collisions > 0)) break;
    loop.StepController(controller);
    if (!loop.Advance()) break;
    MaybeFrame(loop, options.video_fps, &next_frame, on_frame);
  }
  return loop.Metrics();
}

}  // namespace rmpmarl::sim
