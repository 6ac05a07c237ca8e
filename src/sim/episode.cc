// RunEpisode: scenario + controller + physics at their rates, with tracking, clearance and collision-event metrics.
#include "rmpmarl/sim/episode.h"
#include "rmpmarl/sim/controlled_world.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "rmpmarl/common/error.h"

namespace rmpmarl::sim {

ObstacleSensor::~ObstacleSensor() = default;

namespace {

void CheckOptions(const EpisodeOptions& o) {
  if (!std::isfinite(o.duration) || !(o.duration > 0.0)) {
    throw InputError(fmt::format("EpisodeOptions.duration: expected a finite time > 0 s, got {}", o.duration));
  }
  if (!std::isfinite(o.video_fps) || o.video_fps < 0.0) {
    throw InputError(fmt::format("EpisodeOptions.video_fps: expected a finite rate >= 0 Hz, got {}", o.video_fps));
  }
  if (!std::isfinite(o.reach_tolerance) || !(o.reach_tolerance > 0.0)) {
    throw InputError(fmt::format("EpisodeOptions.reach_tolerance: expected a finite distance > 0 m, got {}",
                                 o.reach_tolerance));
  }
  if (!std::isfinite(o.tracking_warmup) || o.tracking_warmup < 0.0) {
    throw InputError(fmt::format("EpisodeOptions.tracking_warmup: expected a finite time >= 0 s, got {}",
                                 o.tracking_warmup));
  }
}

// Collision events: a (link, partner) pair entering penetration. Partners are indexed obstacles first, then links,
// then the floor; the flags live in preallocated arrays, so a step allocates nothing.
class CollisionTracker {
 public:
  CollisionTracker(int num_links, int num_obstacles)
      : num_obstacles_(num_obstacles),
        partners_(num_obstacles + num_links + 1),
        now_(static_cast<size_t>(num_links) * partners_, 0),
        before_(now_.size(), 0),
        ever_(now_.size(), 0) {}

  // updates from the report; returns true when some pair is in penetration.
  bool Update(const ContactReport& report, EpisodeResult* r) {
    std::swap(now_, before_);
    std::fill(now_.begin(), now_.end(), 0);
    for (const CollidingPair& p : report.colliding_pairs) {
      const int partner = p.other_kind == PartnerKind::kObstacle ? p.other_index
                          : p.other_kind == PartnerKind::kLink   ? num_obstacles_ + p.other_index
                                                                 : partners_ - 1;
      const size_t key = static_cast<size_t>(p.link) * partners_ + partner;
      if (now_[key]) continue;
      now_[key] = 1;
      if (!before_[key]) {
        ++r->collision_events;
        if (p.other_kind == PartnerKind::kLink) {
          ++r->self_collision_events;
        } else {
          ++r->obstacle_collision_events;
        }
      }
      if (!ever_[key]) {
        ever_[key] = 1;
        ++r->colliding_pairs;
      }
    }
    return !report.colliding_pairs.empty();
  }

 private:
  int num_obstacles_;
  int partners_;
  std::vector<char> now_, before_, ever_;
};

// Welford running mean and variance.
struct RunningStats {
  long n = 0;
  double mean = 0.0, m2 = 0.0, max = 0.0;
  void Add(double x) {
    ++n;
    const double d = x - mean;
    mean += d / static_cast<double>(n);
    m2 += d * (x - mean);
    max = std::max(max, x);
  }
  double std() const { return n > 0 ? std::sqrt(m2 / static_cast<double>(n)) : 0.0; }
};

}  // namespace

EpisodeResult RunEpisode(const EpisodeOptions& options, World& world, control::ReactiveController& controller,
                         Scenario& scenario, const FrameCallback& on_frame) {
  CheckOptions(options);
  if (controller.nq() != world.nq()) {
    throw InputError(fmt::format("RunEpisode: expected a controller for the world's {} joints, got one for {}",
                                 world.nq(), controller.nq()));
  }
  const auto wall_start = std::chrono::steady_clock::now();
  EpisodeResult r;
  r.scenario = scenario.name();
  r.policy = controller.policy().name();
  r.seed = options.seed;

  scenario.Reset(options.seed, world);
  sim::ResetController(controller, world);
  rmp::Scene scene;
  scenario.FillScene(&scene);
  if (options.sensor != nullptr) options.sensor->Reset(world);

  const WorldModel& model = world.model();
  const kinematics::Robot& robot = model.robot();
  auto end_effector = [&] { return world.EndEffectorPosition(); };

  const double dt = world.mj_model()->opt.timestep;
  const long total_steps = std::max(1L, std::lround(options.duration / dt));
  const int control_every = controller.physics_steps_per_control();
  const double frame_period = options.video_fps > 0.0 ? 1.0 / options.video_fps : 0.0;
  CollisionTracker collisions(robot.model.num_links(), model.num_obstacles());
  RunningStats tracking;
  double error = 0.0;
  int next_frame = 0;

  // metrics of the current state; calls the frame callback when a frame is due at `time`.
  auto observe = [&](const ContactReport& contacts, double time) {
    error = (end_effector() - scenario.target().p_WT).norm();
    if (time >= options.tracking_warmup - 0.5 * dt) tracking.Add(error);
    if (r.time_to_reach < 0.0 && error < options.reach_tolerance) r.time_to_reach = time;
    for (const WarningContact& c : contacts.warnings) {
      double& slot = c.other_kind == PartnerKind::kLink ? r.min_self_clearance_mm : r.min_clearance_mm;
      slot = std::min(slot, 1000.0 * c.distance);
    }
    if (frame_period > 0.0 && on_frame && time >= next_frame * frame_period - 0.5 * dt) {
      on_frame(FrameInfo{next_frame, time, &world, &scenario, &contacts, error, options.sensor});
      ++next_frame;
    }
  };

  const ContactReport* contacts = &world.QueryContacts();  // also brings the mocap poses of Reset into mjData
  collisions.Update(*contacts, &r);
  observe(*contacts, 0.0);
  bool collided = contacts->num_collisions > 0;
  for (long step = 0; step < total_steps; ++step) {
    if (options.stop_on_collision && collided) break;
    if (step % control_every == 0) {
      scenario.FillScene(&scene);
      if (options.sensor != nullptr) options.sensor->Sense(world, &scene);
      sim::StepController(controller, world, scene);
      ++r.control_steps;
    }
    const StepResult stepped = world.Step();
    ++r.physics_steps;
    if (!stepped.ok) {
      r.diverged = true;
      break;
    }
    contacts = &world.QueryContacts();
    collided = collisions.Update(*contacts, &r) || collided;
    if (!contacts->colliding_pairs.empty()) r.time_in_collision += dt;
    observe(*contacts, world.time());
    scenario.Advance(dt, *contacts, world);
  }

  r.duration = r.physics_steps * dt;
  r.frames = next_frame;
  r.tracking_error_mean_mm = 1000.0 * tracking.mean;
  r.tracking_error_std_mm = 1000.0 * tracking.std();
  r.tracking_error_max_mm = 1000.0 * tracking.max;
  r.final_tracking_error_mm = 1000.0 * error;
  const control::ControllerStats& stats = controller.stats();
  r.nonfinite_policy_outputs = stats.nonfinite_outputs;
  r.resyncs = stats.resyncs;
  r.control_step_mean_us = stats.mean_compute_us();
  r.control_step_max_us = stats.max_compute_us;
  if (options.sensor != nullptr) r.sensor = options.sensor->Summary();
  r.success = r.collision_events == 0 && !r.diverged;
  r.wall_time = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return r;
}

}  // namespace rmpmarl::sim
