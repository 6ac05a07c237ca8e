// RunEpisode metrics against references computed without MuJoCo (rmpmarl geometry and forward kinematics) on an arm
// held still: tracking error, clearances, collision events and time in collision, frames; stop_on_collision; errors.
#include "rmpmarl/sim/episode.h"

#include <gtest/gtest.h>

#include <cmath>

#include "control_test_util.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/forward_kinematics.h"

namespace rmpmarl::sim {
namespace {

struct Reference {
  Eigen::Vector3d p_WE;
  double obstacle_clearance = INFINITY;  // min over capsules and obstacles
  double self_clearance = INFINITY;      // min over checked link pairs
  int penetrating_pairs = 0;             // distinct (link, obstacle) pairs in penetration
  bool only_fixed_links_penetrate = true;
};

// the metrics of a robot standing at q among the obstacles, from rmpmarl's FK and geometry.
Reference ComputeReference(const kinematics::Robot& robot, const Eigen::VectorXd& q,
                           const std::vector<ObstacleSpec>& obstacles) {
  kinematics::Data data(robot.model);
  kinematics::CalcForwardKinematics(robot.model, q, &data);
  Reference r;
  r.p_WE = kinematics::CalcPointPosition(data, robot.end_effector.link, robot.end_effector.X_LE.translation());
  auto capsule = [&](const kinematics::LinkCapsule& c) {
    return math::Capsule{data.X_WL[c.link] * c.p_LA, data.X_WL[c.link] * c.p_LB, c.radius};
  };
  for (size_t j = 0; j < obstacles.size(); ++j) {
    const ObstacleSpec& o = obstacles[j];
    const rmp::Obstacle obstacle = o.shape == ObstacleShape::kSphere
                                       ? rmp::Obstacle::MakeSphere(o.X_WO.translation(), o.radius)
                                       : rmp::Obstacle::MakeBox(o.X_WO, o.half_size);
    std::vector<char> link_hit(robot.model.num_links(), 0);
    for (const kinematics::LinkCapsule& c : robot.capsules) {
      const double d = rmp::CapsuleObstacleDistance(capsule(c), obstacle).distance;
      r.obstacle_clearance = std::min(r.obstacle_clearance, d);
      if (d < 0.0 && !link_hit[c.link]) {
        link_hit[c.link] = 1;
        ++r.penetrating_pairs;
        r.only_fixed_links_penetrate &= robot.model.link_dofs(c.link).empty();
      }
    }
  }
  for (size_t a = 0; a < robot.capsules.size(); ++a) {
    for (size_t b = a + 1; b < robot.capsules.size(); ++b) {
      const auto& ca = robot.capsules[a];
      const auto& cb = robot.capsules[b];
      if (ca.link == cb.link || robot.IsExcludedPair(ca.link, cb.link)) continue;
      r.self_clearance = std::min(r.self_clearance, math::CapsuleCapsuleDistance(capsule(ca), capsule(cb)).distance);
    }
  }
  return r;
}

TEST(EpisodeTest, MetricsOfAHeldArmMatchDirectReferences) {
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  const Eigen::VectorXd q0 = ReadyConfiguration(robot);
  const Reference at_start = ComputeReference(robot, q0, {});
  StaticSceneOptions options;
  options.q_start = q0;
  const Eigen::Vector3d offset(0.10, 0.05, -0.02);
  options.p_WT = at_start.p_WE + offset;
  // a sphere 8 cm in front of the end effector (within the 15 cm margin, untouched) and a cube through the base
  options.obstacles.push_back(ObstacleSpec::Sphere(0.05, at_start.p_WE + Eigen::Vector3d(0.0, 0.0, -0.16)));
  options.obstacles.push_back(ObstacleSpec::Cube(0.1, Eigen::Isometry3d(Eigen::Translation3d(-0.12, 0.0, 0.02))));
  const Reference ref = ComputeReference(robot, q0, options.obstacles);
  ASSERT_GT(ref.penetrating_pairs, 0);
  ASSERT_TRUE(ref.only_fixed_links_penetrate);  // contact forces cannot move the arm
  ASSERT_GT(ref.self_clearance, 0.0);

  StaticScenario scenario(robot, options);
  auto model = std::make_shared<const WorldModel>(robot, scenario.scene_spec());
  World world(model);
  control::ReactiveController controller(model->servos(), std::make_unique<testing::HoldPolicy>(robot.model.nq()));
  const EpisodeMetrics r =
      RunEpisode({.duration = 1.0, .seed = 0, .video_fps = 25.0}, world, controller, scenario, {});
  EXPECT_EQ(r.physics_steps, 500);
  EXPECT_EQ(r.length, 100);
  EXPECT_NEAR(r.duration, 1.0, 1e-12);
  EXPECT_LT((world.q() - q0).cwiseAbs().maxCoeff(), 1e-9);  // held still
  EXPECT_NEAR(r.mean_tracking_error, offset.norm(), 1e-9);
  EXPECT_NEAR(r.final_tracking_error, offset.norm(), 1e-9);
  EXPECT_NEAR(r.max_tracking_error, offset.norm(), 1e-9);
  EXPECT_NEAR(r.settled_tracking_error, offset.norm(), 1e-9);
  EXPECT_EQ(r.time_to_reach, -1.0);
  EXPECT_FALSE(r.reached);
  EXPECT_NEAR(r.min_clearance, ref.obstacle_clearance, 1e-9);
  if (ref.self_clearance < WorldOptions{}.warning_margin) {
    EXPECT_NEAR(r.min_self_clearance, ref.self_clearance, 1e-9);
  } else {
    EXPECT_EQ(r.min_self_clearance, INFINITY);
  }
  EXPECT_EQ(r.collisions, ref.penetrating_pairs);  // entered penetration once, at t = 0, and stayed
  EXPECT_EQ(r.obstacle_collisions, ref.penetrating_pairs);
  EXPECT_EQ(r.self_collisions, 0);
  EXPECT_NEAR(r.time_in_collision, 1.0, 1e-9);
  EXPECT_FALSE(r.success);
  EXPECT_FALSE(r.invalid);
  EXPECT_GT(r.mean_control_us, 0.0);
  EXPECT_GE(r.max_control_us, r.mean_control_us);

  // frames at 25 fps from t = 0: 26 in 1 s, evenly spaced, showing the state after a control period
  std::vector<double> times;
  RunEpisode({.duration = 1.0, .video_fps = 25.0}, world, controller, scenario,
             [&](const FrameInfo& f) {
               EXPECT_EQ(f.index, static_cast<int>(times.size()));
               EXPECT_EQ(f.time, f.world->time());
               EXPECT_NEAR(f.tracking_error, offset.norm(), 1e-9);
               EXPECT_EQ(f.contacts->num_collisions, ref.penetrating_pairs);
               times.push_back(f.time);
             });
  ASSERT_EQ(times.size(), 26u);
  for (size_t k = 0; k < times.size(); ++k) EXPECT_NEAR(times[k], 0.04 * k, 1e-9);

  // stop_on_collision: the start is already in collision, nothing runs
  const EpisodeMetrics stopped =
      RunEpisode({.duration = 1.0, .stop_on_collision = true}, world, controller, scenario);
  EXPECT_EQ(stopped.physics_steps, 0);
  EXPECT_EQ(stopped.length, 0);
  EXPECT_EQ(stopped.collisions, ref.penetrating_pairs);
}

TEST(EpisodeTest, StopOnCollisionEndsAtTheFirstImpact) {
  const kinematics::Robot robot = kinematics::LoadShippedRobot("xarm6");
  const Eigen::VectorXd q0 = ReadyConfiguration(robot);
  const Eigen::Vector3d p_E0 = ComputeReference(robot, q0, {}).p_WE;
  LineCrossingScenario scenario(robot, {.speed = 2.8, .target_speed = 0.0, .repeat = false, .through = p_E0});
  auto model = std::make_shared<const WorldModel>(robot, scenario.scene_spec());
  World world(model);
  control::ReactiveController controller(model->servos(), std::make_unique<testing::HoldPolicy>(robot.model.nq()));
  double first_impact = -1.0;
  const EpisodeMetrics full = RunEpisode({.duration = 2.0, .video_fps = 500.0}, world, controller, scenario,
                                        [&](const FrameInfo& f) {
                                          if (first_impact < 0.0 && f.contacts->num_collisions > 0) {
                                            first_impact = f.time;
                                          }
                                        });
  ASSERT_GT(first_impact, 0.0);
  ASSERT_GT(full.collisions, 1);
  const EpisodeMetrics stopped = RunEpisode({.duration = 2.0, .stop_on_collision = true}, world, controller, scenario);
  // the loop stops at the control step after the first event; frames come at control steps too
  EXPECT_LE(stopped.duration, first_impact + 1e-9);
  EXPECT_GE(stopped.duration, first_impact - controller.control_period() - 1e-9);
  EXPECT_GE(stopped.collisions, 1);
  EXPECT_LT(stopped.collisions, full.collisions);
  EXPECT_FALSE(stopped.success);
}

TEST(EpisodeTest, BadInputThrowsInputError) {
  const kinematics::Robot robot = kinematics::MakePlanar2();
  StaticReachScenario scenario(robot);
  auto model = std::make_shared<const WorldModel>(robot, scenario.scene_spec());
  World world(model);
  control::ReactiveController controller(model->servos(), std::make_unique<testing::HoldPolicy>(2));
  EXPECT_THROW(RunEpisode({.duration = 0.0}, world, controller, scenario), InputError);
  EXPECT_THROW(RunEpisode({.duration = NAN}, world, controller, scenario), InputError);
  EXPECT_THROW(RunEpisode({.video_fps = -1.0}, world, controller, scenario), InputError);
  EXPECT_THROW(RunEpisode({.loop = {.reach_tolerance = 0.0}}, world, controller, scenario), InputError);
  EXPECT_THROW(RunEpisode({.loop = {.settle_time = -1.0}}, world, controller, scenario), InputError);
  EXPECT_THROW(RunEpisode({.loop = {.success_max_final_error = NAN}}, world, controller, scenario), InputError);
  const kinematics::Robot panda = kinematics::LoadShippedRobot("panda");
  auto panda_model = std::make_shared<const WorldModel>(panda, scenario.scene_spec());
  control::ReactiveController panda_controller(panda_model->servos(), std::make_unique<testing::HoldPolicy>(7));
  EXPECT_THROW(RunEpisode({}, world, panda_controller, scenario), InputError);
  World panda_world(panda_model);
  EXPECT_THROW(RunEpisode({}, panda_world, panda_controller, scenario), InputError);  // scenario of planar2
}

}  // namespace
}  // namespace rmpmarl::sim
