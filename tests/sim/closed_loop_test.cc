// Closed loop in MuJoCo (RMPflow + ReactiveController + scenario) on every shipped arm and planar2: static targets are
// reached, an obstacle on the straight path is gone around without collision, singular and joint-limit starts stay
// finite, the line-crossing stops a colliding obstacle at the point of impact, and the same seed gives the same run.
// Thresholds are the measured behaviour with margin; the numbers are printed (docs/control.md quotes them).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "control_test_util.h"
#include "rmpmarl/sim/episode.h"
#include "sim_test_util.h"

namespace rmpmarl::sim {
namespace {

std::vector<kinematics::Robot> Arms() {
  std::vector<kinematics::Robot> arms;
  for (const std::string& name : kinematics::ShippedRobotNames()) arms.push_back(kinematics::LoadShippedRobot(name));
  return arms;
}

std::vector<kinematics::Robot> ArmsAndPlanar2() {
  std::vector<kinematics::Robot> robots = Arms();
  robots.push_back(kinematics::MakePlanar2());
  return robots;
}

// a world for the scenario and an RMPflow controller (robot's shipped config) with default options.
struct Rig {
  Rig(const Scenario& scenario, control::ControllerOptions options = {})
      : model(std::make_shared<const WorldModel>(scenario.robot(), scenario.scene_spec())),
        world(model),
        controller(model->servos(), std::make_unique<control::RmpflowAccelerationPolicy>(scenario.robot(), scenario.num_obstacles()),
                   options) {}
  std::shared_ptr<const WorldModel> model;
  World world;
  control::ReactiveController controller;
};

Eigen::Vector3d EndEffector(const World& world) { return world.EndEffectorPosition(); }

// (a) the end effector of a random well-conditioned configuration near the start posture, 3 seeds per robot.
TEST(ClosedLoopTest, ReachesStaticTargetsWithin1cmOnEveryArm) {
  for (const kinematics::Robot& robot : ArmsAndPlanar2()) {
    StaticReachScenario scenario(robot);
    Rig rig(scenario);
    double worst = 0.0, slowest = 0.0, self = INFINITY, step_us = 0.0;
    for (std::uint64_t seed = 0; seed < 3; ++seed) {
      const EpisodeMetrics r = RunEpisode({.duration = 6.0, .seed = seed}, rig.world, rig.controller, scenario);
      EXPECT_LT(1000.0 * r.final_tracking_error, 10.0) << robot.name << " seed " << seed;
      EXPECT_GT(r.time_to_reach, 0.0) << robot.name << " seed " << seed;
      EXPECT_EQ(r.collisions, 0) << robot.name << " seed " << seed;
      EXPECT_EQ(r.nonfinite_policy_outputs, 0);
      EXPECT_FALSE(r.invalid);
      EXPECT_TRUE(r.success);
      worst = std::max(worst, 1000.0 * r.final_tracking_error);
      slowest = std::max(slowest, r.time_to_reach);
      self = std::min(self, 1000.0 * r.min_self_clearance);
      step_us = std::max(step_us, r.mean_control_us);
    }
    std::printf("[ reach    ] %-7s 3 static targets: worst final error %.2f mm, within 1 cm after <= %.2f s, min self "
                "clearance %.0f mm, control step %.1f us\n", robot.name.c_str(), worst, slowest, self, step_us);
  }
}

// (b) a 4 cm sphere at the middle of the straight segment from the start end effector to the target: the arm goes
// around it (the end effector leaves the segment by more than the radius) without collision and reaches within 1 cm.
// Not on planar2: in its plane an obstacle on the segment leaves two links no way around (measured: trapped 5/5).
TEST(ClosedLoopTest, GoesAroundAnObstacleOnTheStraightPathOnEveryArm) {
  for (const kinematics::Robot& robot : Arms()) {
    StaticReachScenario scenario(robot, {.obstacle_on_path = true});
    Rig rig(scenario);
    const double radius = scenario.options().obstacle.radius;
    double worst = 0.0, slowest = 0.0, clearance = INFINITY, detour = INFINITY;
    for (std::uint64_t seed = 0; seed < 3; ++seed) {
      Eigen::Vector3d a, b, c;
      double max_off_segment = 0.0, min_to_centre = INFINITY;
      const EpisodeMetrics r = RunEpisode(
          {.duration = 6.0, .seed = seed, .video_fps = 100.0}, rig.world, rig.controller, scenario,
          [&](const FrameInfo& f) {
            const Eigen::Vector3d p = EndEffector(*f.world);
            if (f.index == 0) {
              a = p;
              b = f.scenario->target().p_WT;
              c = f.world->ObstaclePose(0).translation();
            }
            const double t = std::clamp((p - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
            max_off_segment = std::max(max_off_segment, (p - (a + t * (b - a))).norm());
            min_to_centre = std::min(min_to_centre, (p - c).norm());
          });
      EXPECT_LT((c - 0.5 * (a + b)).norm(), 1e-9);  // the obstacle blocks the straight line
      EXPECT_LT(1000.0 * r.final_tracking_error, 10.0) << robot.name << " seed " << seed;
      EXPECT_EQ(r.collisions, 0) << robot.name << " seed " << seed;
      EXPECT_GT(1000.0 * r.min_clearance, 0.0) << robot.name << " seed " << seed;
      EXPECT_GT(max_off_segment, radius) << robot.name << " seed " << seed;
      EXPECT_GT(min_to_centre, radius) << robot.name << " seed " << seed;
      EXPECT_TRUE(r.success);
      worst = std::max(worst, 1000.0 * r.final_tracking_error);
      slowest = std::max(slowest, r.time_to_reach);
      clearance = std::min(clearance, 1000.0 * r.min_clearance);
      detour = std::min(detour, max_off_segment);
    }
    std::printf("[ obstacle ] %-7s 3 targets behind a 4 cm sphere: worst final error %.2f mm, within 1 cm after <= "
                "%.2f s, min clearance %.1f mm, end effector off the segment by >= %.0f mm\n", robot.name.c_str(),
                worst, slowest, clearance, 1000.0 * detour);
  }
}

// (c) starts at all-zero (upright / stretched singular postures), at the upper and at the lower joint limits, with a
// moving target and crossing cubes, and stretched towards an unreachable target.
TEST(ClosedLoopTest, StaysFiniteFromSingularPosturesAndJointLimits) {
  for (const kinematics::Robot& robot : ArmsAndPlanar2()) {
    const kinematics::Model& m = robot.model;
    const Eigen::VectorXd lower = m.LowerLimits().cwiseMax(-M_PI), upper = m.UpperLimits().cwiseMin(M_PI);
    const std::vector<Eigen::VectorXd> starts = {Eigen::VectorXd::Zero(m.nq()).cwiseMax(m.LowerLimits()).cwiseMin(
                                                     m.UpperLimits()), upper, lower};
    int episodes = 0;
    for (const Eigen::VectorXd& q0 : starts) {
      CrossingScenario crossing(robot, {.q_start = q0});
      const Workspace& w = crossing.workspace();
      StaticScenario unreachable(robot, {.q_start = q0,
                                         .p_WT = w.p_WS + 1.5 * w.reach * w.front});  // stretches out: singular
      for (Scenario* scenario : std::vector<Scenario*>{&crossing, &unreachable}) {
        Rig rig(*scenario);
        long frames = 0;
        const EpisodeMetrics r = RunEpisode(
            {.duration = 3.0, .seed = 1, .video_fps = 100.0}, rig.world, rig.controller, *scenario,
            [&](const FrameInfo& f) {
              ++frames;
              const control::ReactiveController& c = rig.controller;
              ASSERT_TRUE(f.world->q().allFinite() && f.world->qd().allFinite()) << robot.name;
              ASSERT_TRUE(c.q_cmd().allFinite() && c.qd_cmd().allFinite() && c.servo_target().allFinite());
              ASSERT_TRUE(c.qdd().allFinite()) << robot.name << " " << scenario->name() << " t " << f.time;
              // the command respects the limits exactly (the measured q may not: a start at all-upper limits can be
              // in self-penetration, whose contact forces push joints past MuJoCo's soft limits)
              EXPECT_TRUE((c.q_cmd().array() <= m.UpperLimits().array()).all()) << robot.name;
              EXPECT_TRUE((c.q_cmd().array() >= m.LowerLimits().array()).all()) << robot.name;
            });
        EXPECT_FALSE(r.invalid) << robot.name << " " << scenario->name();
        EXPECT_EQ(r.nonfinite_policy_outputs, 0) << robot.name << " " << scenario->name();
        EXPECT_TRUE(std::isfinite(r.mean_tracking_error) && std::isfinite(r.final_tracking_error));
        EXPECT_EQ(frames, 301);
        ++episodes;
      }
    }
    EXPECT_EQ(episodes, 6);
  }
}

// (d) a fast line (2.8 m/s) through the start end-effector position and a robot that holds still: the obstacles that
// hit stop at the point of impact for the rest of the episode, the others pass on.
TEST(ClosedLoopTest, LineCrossingStopsACollidingObstacleAtThePointOfImpact) {
  for (const std::string name : {"panda", "ur5e", "irb120"}) {
    const kinematics::Robot robot = kinematics::LoadShippedRobot(name);
    const Eigen::VectorXd q0 = ReadyConfiguration(robot);
    World probe(std::make_shared<const WorldModel>(robot));
    probe.Reset(q0);
    const Eigen::Vector3d p_E0 = EndEffector(probe);
    for (const LineArrangement arrangement : {LineArrangement::kAcrossMotion, LineArrangement::kAlongMotion}) {
      for (const bool stop : {true, false}) {
        LineCrossingScenario scenario(robot, {.arrangement = arrangement, .spacing = 0.3, .speed = 2.8,
                                              .target_speed = 0.0, .stop_on_impact = stop, .repeat = false,
                                              .through = p_E0});
        auto model = std::make_shared<const WorldModel>(robot, scenario.scene_spec());
        World world(model);
        control::ReactiveController controller(model->servos(), std::make_unique<testing::HoldPolicy>(robot.model.nq()));
        const int n = scenario.num_obstacles();
        std::vector<std::vector<Eigen::Vector3d>> poses(n);
        std::vector<int> first_hit(n, -1);
        std::vector<double> hit_time(n, -1.0);
        // a frame after every control period (10 ms)
        const double period = controller.control_period();
        const EpisodeMetrics r = RunEpisode(
            {.duration = 2.0, .seed = 4, .video_fps = 500.0}, world, controller, scenario, [&](const FrameInfo& f) {
              for (int j = 0; j < n; ++j) poses[j].push_back(f.world->ObstaclePose(j).translation());
              for (const CollidingPair& p : f.contacts->colliding_pairs) {
                if (p.other_kind == PartnerKind::kObstacle && first_hit[p.other_index] < 0) {
                  first_hit[p.other_index] = f.index;
                  hit_time[p.other_index] = f.time;
                }
              }
            });
        EXPECT_GE(r.obstacle_collisions, 1) << name;
        EXPECT_FALSE(r.success);
        int stopped = 0, passed = 0;
        for (int j = 0; j < n; ++j) {
          const ObstacleState& s = scenario.obstacles()[j];
          const std::vector<Eigen::Vector3d>& p = poses[j];
          if (s.stopped) {
            ASSERT_TRUE(stop);
            ASSERT_GE(first_hit[j], 1);
            ++stopped;
            // moving up to the impact, fixed from the state where the collision was seen to the end
            EXPECT_GT((p[first_hit[j]] - p[first_hit[j] - 1]).norm(), 0.0) << name << " " << j;
            for (size_t k = first_hit[j]; k < p.size(); ++k) ASSERT_EQ(p[k], p[first_hit[j]]) << name << " " << j;
            // it stopped at the physics step of the impact, within the control period before the frame that saw it
            EXPECT_LE(s.stop_time, hit_time[j] + 1e-9) << name << " " << j;
            EXPECT_GT(s.stop_time, hit_time[j] - period - 1e-9) << name << " " << j;
          } else {
            // never stopped: it went all the way to the end of its path
            EXPECT_LT((p.back() - (s.p_start + s.path_length * s.direction)).norm(), 1e-9) << name << " " << j;
            ++passed;
            if (stop) {
              EXPECT_LT(first_hit[j], 0) << name << " obstacle " << j << " hit but did not stop";
            }
          }
        }
        if (!stop) {
          EXPECT_EQ(stopped, 0);
        }
        if (stop && arrangement == LineArrangement::kAcrossMotion) {
          EXPECT_GE(stopped, 1) << name;
          EXPECT_GE(passed, 1) << name;  // side by side: the ones that miss the arm keep going
        }
        if (stop && arrangement == LineArrangement::kAlongMotion) {
          EXPECT_GE(stopped, 1) << name;
        }
        std::printf("[ line     ] %-7s %s, stop_on_impact %d: %d of %d obstacles stopped, %d collision events\n",
                    name.c_str(), arrangement == LineArrangement::kAlongMotion ? "train" : "rake ", stop, stopped, n,
                    r.collisions);
      }
    }
  }
}

// (e) the same seed gives bit-identical runs, on fresh objects and on reused ones (Reset restores everything).
TEST(ClosedLoopTest, SameSeedGivesTheSameTrajectory) {
  for (const std::string& scenario_name : {std::string("crossing"), std::string("line-crossing")}) {
    const kinematics::Robot robot = kinematics::LoadShippedRobot(scenario_name == "crossing" ? "panda" : "gen3");
    auto record = [&](Rig& rig, Scenario& scenario, std::uint64_t seed, EpisodeMetrics* result) {
      std::vector<double> trace;
      *result = RunEpisode({.duration = 4.0, .seed = seed, .video_fps = 50.0}, rig.world, rig.controller, scenario,
                           [&](const FrameInfo& f) {
                             const Eigen::Vector3d p = EndEffector(*f.world);
                             trace.insert(trace.end(), {f.time, p.x(), p.y(), p.z(), f.tracking_error});
                             trace.insert(trace.end(), f.world->q().data(), f.world->q().data() + f.world->nq());
                             for (int j = 0; j < f.scenario->num_obstacles(); ++j) {
                               const Eigen::Vector3d o = f.world->ObstaclePose(j).translation();
                               trace.insert(trace.end(), {o.x(), o.y(), o.z()});
                             }
                           });
      return trace;
    };
    auto same = [](const EpisodeMetrics& a, const EpisodeMetrics& b) {
      return a.mean_tracking_error == b.mean_tracking_error && a.max_tracking_error == b.max_tracking_error &&
             a.final_tracking_error == b.final_tracking_error && a.min_clearance == b.min_clearance &&
             a.min_self_clearance == b.min_self_clearance && a.collisions == b.collisions &&
             a.time_in_collision == b.time_in_collision && a.physics_steps == b.physics_steps &&
             a.time_to_reach == b.time_to_reach && a.nonfinite_policy_outputs == b.nonfinite_policy_outputs;
    };
    const std::unique_ptr<Scenario> s1 = MakeScenario(scenario_name, robot), s2 = MakeScenario(scenario_name, robot);
    Rig rig1(*s1), rig2(*s2);
    EpisodeMetrics r1, r2, r3, r4;
    const std::vector<double> t1 = record(rig1, *s1, 9, &r1);
    const std::vector<double> t2 = record(rig2, *s2, 9, &r2);
    EXPECT_EQ(t1.size(), 201u * (5 + robot.model.nq() + 3 * s1->num_obstacles()));
    EXPECT_TRUE(t1 == t2) << scenario_name << ": fresh objects, same seed";
    EXPECT_TRUE(same(r1, r2));
    const std::vector<double> t3 = record(rig1, *s1, 10, &r3);
    EXPECT_FALSE(t1 == t3) << scenario_name << ": another seed";
    const std::vector<double> t4 = record(rig1, *s1, 9, &r4);
    EXPECT_TRUE(t1 == t4) << scenario_name << ": reused objects, same seed";
    EXPECT_TRUE(same(r1, r4));
  }
}

}  // namespace
}  // namespace rmpmarl::sim
