// `rmpmarl robots`: loads every shipped robot, builds its MuJoCo world, sweeps its joints through their ranges under
// the position servos and prints a table (kinematics vs MuJoCo, servo tracking, self-contacts, step time).
#include <fmt/core.h>
#include <mujoco/mujoco.h>

#include <chrono>
#include <cmath>

#include "commands.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/sim/world.h"

namespace rmpmarl::apps {
namespace {

struct SweepResult {
  double reach = 0.0;              // largest |p_WE| seen [m]
  double fk_error = 0.0;           // max |rmpmarl FK − MuJoCo body position| [m]
  double tracking_rms = 0.0;       // RMS of q_cmd − q over the sweep [rad]
  int self_collision_steps = 0;    // steps with a link–link penetration
  double min_self_clearance = std::numeric_limits<double>::infinity();
  double step_us = 0.0;            // wall time per physics step [µs]
  int steps = 0;
};

// sweeps every joint sinusoidally over 80 % of its range (speed within 60 % of its velocity limit) for `duration`.
SweepResult Sweep(const kinematics::Robot& robot, double duration) {
  auto world_model = std::make_shared<const sim::WorldModel>(robot);
  sim::World world(world_model);
  const kinematics::Model& model = robot.model;
  kinematics::Data data(model);
  const int nq = model.nq();
  Eigen::VectorXd mid(nq), amplitude(nq), omega(nq), q_cmd(nq);
  for (int i = 0; i < nq; ++i) {
    const auto& l = model.limits()[i];
    const bool bounded = std::isfinite(l.lower) && std::isfinite(l.upper);
    mid[i] = bounded ? 0.5 * (l.lower + l.upper) : 0.0;
    amplitude[i] = bounded ? 0.4 * (l.upper - l.lower) : M_PI;
    omega[i] = std::min(0.6 * l.velocity / amplitude[i], 2.0 * M_PI / duration * (1 + i % 3));
  }
  world.Reset(mid);
  const double dt = world_model->mj_model()->opt.timestep;
  const int steps = static_cast<int>(duration / dt);
  SweepResult result;
  double tracking_sq = 0.0;
  double step_seconds = 0.0;
  for (int s = 0; s < steps; ++s) {
    const double t = s * dt;
    for (int i = 0; i < nq; ++i) q_cmd[i] = mid[i] + amplitude[i] * std::sin(omega[i] * t);
    world.SetJointTargets(q_cmd);
    const auto start = std::chrono::steady_clock::now();
    world.Step();
    step_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    tracking_sq += (q_cmd - world.q()).squaredNorm() / nq;
    if (s % 25 == 0) {
      kinematics::CalcForwardKinematics(model, world.q(), &data);
      for (int k = 0; k < model.num_links(); ++k) {
        const mjtNum* xpos = world.mj_data()->xpos + 3 * world_model->link_body(k);
        result.fk_error = std::max(result.fk_error,
                                   (data.X_WL[k].translation() - Eigen::Vector3d(xpos[0], xpos[1], xpos[2])).norm());
      }
      const Eigen::Vector3d p_WE = data.X_WL[robot.end_effector.link] * robot.end_effector.X_LE.translation();
      result.reach = std::max(result.reach, p_WE.norm());
      const sim::ContactReport& report = world.QueryContacts();
      bool self_collision = false;
      for (const sim::WarningContact& c : report.warnings) {
        if (c.other_kind != sim::PartnerKind::kLink) continue;
        result.min_self_clearance = std::min(result.min_self_clearance, c.distance);
        self_collision |= c.distance < 0.0;
      }
      result.self_collision_steps += self_collision ? 25 : 0;
    }
  }
  result.steps = steps;
  result.tracking_rms = std::sqrt(tracking_sq / steps);
  result.step_us = 1e6 * step_seconds / steps;
  return result;
}

}  // namespace

void RunRobotsTable(double duration) {
  fmt::print("Sweeping every joint of each shipped robot over 80% of its range for {:.1f} s (MuJoCo {}, position "
             "servos, {:.0f} cm warning margin)\n\n", duration, mj_versionString(), 100 * sim::WorldOptions{}.warning_margin);
  fmt::print("{:<8} {:>3} {:>5} {:>8} {:>9} {:>12} {:>13} {:>14} {:>8}\n", "robot", "dof", "caps", "reach[m]",
             "FK err[m]", "track RMS[°]", "self-coll[%]", "min self[mm]", "step[µs]");
  std::vector<kinematics::Robot> robots;
  for (const std::string& name : kinematics::ShippedRobotNames()) robots.push_back(kinematics::LoadShippedRobot(name));
  robots.push_back(kinematics::MakePlanar2());
  for (const kinematics::Robot& robot : robots) {
    const SweepResult r = Sweep(robot, duration);
    // "–" where no checked link pair came within the warning margin (a two-link arm has none)
    const std::string self = std::isfinite(r.min_self_clearance) ? fmt::format("{:.1f}", 1000.0 * r.min_self_clearance)
                                                                   : std::string("–");
    fmt::print("{:<8} {:>3} {:>5} {:>8.3f} {:>9.1e} {:>12.3f} {:>13.1f} {:>14} {:>8.1f}\n", robot.name,
               robot.model.nq(), robot.capsules.size(), r.reach, r.fk_error, r.tracking_rms * 180.0 / M_PI,
               100.0 * r.self_collision_steps / r.steps, self, r.step_us);
  }
  fmt::print("\nself-coll: share of the sweep with a link–link penetration between non-excluded links (a blind sweep "
             "folds arms into themselves; the reactive controllers avoid this). min self: – where no checked pair of "
             "links came within the warning margin.\n");
}

void RegisterRobots(CLI::App& app) {
  auto* cmd = app.add_subcommand("robots", "Load every shipped robot, build its MuJoCo world, sweep its joints");
  static double duration = 4.0;
  cmd->add_option("--duration", duration, "sweep duration per robot [s]")->check(CLI::Range(0.001, 3600.0));
  cmd->callback([] { RunRobotsTable(duration); });
}

}  // namespace rmpmarl::apps
