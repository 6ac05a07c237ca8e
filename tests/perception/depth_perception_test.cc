// Obstacles through a simulated depth camera and through recorded clouds, in MuJoCo episodes: the sensed distances
// against the true shapes, tracked velocities against the scenario's, and controllers that never see the truth.
#include "rmpmarl/perception/depth_perception.h"
#include "rmpmarl/sim/controlled_world.h"

#include <gtest/gtest.h>

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <limits>

#include "rmpmarl/common/error.h"
#include "rmpmarl/control/cloud_io.h"
#include "rmpmarl/perception/recorded_cloud.h"
#include "rmpmarl/control/controller.h"
#include "rmpmarl/sim/episode.h"
#include "rmpmarl/sim/scenario.h"

namespace rmpmarl::perception {
namespace {

std::unique_ptr<DepthPerception> MakeOrSkip(const sim::WorldModel& model, const DepthPerceptionOptions& options) {
  std::string why_not;
  std::unique_ptr<DepthPerception> p = DepthPerception::Create(model, options, &why_not);
  return p;
}

// the smallest signed distance from any robot capsule to the sensed obstacles and to the true ones
struct Clearances {
  double sensed, truth;
};
Clearances MinClearances(const sim::World& world, const rmp::Scene& sensed, const rmp::Scene& truth) {
  const kinematics::Robot& robot = world.model().robot();
  kinematics::Data data(robot.model);
  kinematics::CalcForwardKinematics(robot.model, world.q(), &data);
  Clearances c{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  for (const auto& lc : robot.capsules) {
    const math::Capsule cap{data.X_WL[lc.link] * lc.p_LA, data.X_WL[lc.link] * lc.p_LB, lc.radius};
    for (const rmp::Obstacle& o : sensed.obstacles) c.sensed = std::min(c.sensed, rmp::CapsuleObstacleDistance(cap, o).distance);
    for (const rmp::Obstacle& o : truth.obstacles) c.truth = std::min(c.truth, rmp::CapsuleObstacleDistance(cap, o).distance);
  }
  return c;
}

TEST(DepthPerceptionTest, SensedClearancesFollowTheTrueShapesThroughACrossingEpisode) {
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  std::unique_ptr<sim::Scenario> scenario = sim::MakeScenario("crossing", robot, {.num_obstacles = 2});
  auto model = std::make_shared<const sim::WorldModel>(robot, scenario->scene_spec());
  DepthPerceptionOptions options;
  options.cameras[0].noise = {.sigma_at_1m = 0.002, .dropout = 0.01, .seed = 4};
  options.cloud.point_margin = 0.0;  // the geometry the camera sees, without the controllers' safety margin
  std::unique_ptr<DepthPerception> sensor = MakeOrSkip(*model, options);
  if (!sensor) GTEST_SKIP() << "offscreen rendering is not available here";
  sim::World world(model);
  control::ReactiveController controller(model->servos(), std::make_unique<control::RmpflowAccelerationPolicy>(robot, 8));
  // a frame callback compares, at every frame, what the controller was told with the truth
  int compared = 0;
  double min_truth = 1e9;
  std::vector<double> errors;
  sim::EpisodeOptions episode{.duration = 4.0, .seed = 1, .video_fps = 30.0};
  episode.sensor = sensor.get();
  const sim::EpisodeMetrics r = sim::RunEpisode(episode, world, controller, *scenario, [&](const sim::FrameInfo& f) {
    if (f.index == 0) return;
    rmp::Scene truth, sensed;
    f.scenario->FillScene(&truth);
    sensed = truth;
    sensor->cloud().FillScene(&sensed);
    const Clearances c = MinClearances(*f.world, sensed, truth);
    ++compared;
    // where an obstacle is near the arm, the sensed clearance is the true one to within the voxel (2 cm: a centroid
    // stands for points half a voxel around it, each point a sphere of half a voxel) and the noise
    min_truth = std::min(min_truth, c.truth);
    if (c.truth < 0.15) errors.push_back(std::abs(c.sensed - c.truth));
  });
  EXPECT_GT(compared, 100);
  ASSERT_GT(errors.size(), 5u) << "the obstacles never came near the arm (closest " << min_truth << " m)";
  // where an obstacle is within 15 cm of the arm the sensed clearance is the true one to within the voxel (2 cm: a
  // centroid stands for points half a voxel around it, each a sphere of half a voxel), the noise and the frame's age
  // (up to 33 ms of motion); where the arm hides part of the obstacle from the camera the nearest visible surface is
  // farther, so the tail is longer
  std::sort(errors.begin(), errors.end());
  EXPECT_LT(errors[errors.size() / 2], 0.015) << "median |sensed − true clearance| [m]";
  EXPECT_LT(errors[errors.size() * 9 / 10], 0.03) << "90th percentile [m]";
  EXPECT_EQ(r.nonfinite_policy_outputs, 0);
  // the camera runs at its 30 Hz in simulated time
  const sim::SensorSummary seen = sensor->Summary();
  EXPECT_NEAR(static_cast<double>(seen.updates), 4.0 * 30.0, 2.0);
  EXPECT_GT(seen.velocity_samples, 50);
  EXPECT_LT(seen.velocity_error_mean, 0.15) << "mean |v_sensed − v_true| [m/s]";
}

// the cluttered scene on the Panda, RMPflow, and the default depth sensor (null where offscreen rendering is not)
struct ClutteredRig {
  kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  std::unique_ptr<sim::Scenario> scenario = sim::MakeScenario("cluttered", robot);
  std::shared_ptr<const sim::WorldModel> model = std::make_shared<const sim::WorldModel>(robot, scenario->scene_spec());
  std::unique_ptr<DepthPerception> sensor = MakeOrSkip(*model, {});
  sim::World world{model};
  control::ReactiveController controller{model->servos(), std::make_unique<control::RmpflowAccelerationPolicy>(robot, 8)};
};

TEST(DepthPerceptionTest, ControllersAvoidWhatTheyOnlySeeThroughTheCamera) {
  ClutteredRig rig;
  if (!rig.sensor) GTEST_SKIP() << "offscreen rendering is not available here";
  DepthPerception* sensor = rig.sensor.get();
  int successes = 0;
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    sim::EpisodeOptions episode{.duration = 3.0, .seed = seed};
    episode.sensor = sensor;
    const sim::EpisodeMetrics r = sim::RunEpisode(episode, rig.world, rig.controller, *rig.scenario);
    EXPECT_EQ(r.nonfinite_policy_outputs, 0);
    const sim::SensorSummary seen = sensor->Summary();
    EXPECT_GT(seen.obstacles_mean, 2.0) << "the camera sees the clutter";
    // static clutter is at rest: its centroids jitter below min_speed, but for a cube the arm occludes in part
    EXPECT_LT(seen.velocity_error_mean, 0.02) << "static clutter is at rest";
    successes += r.success;
  }
  EXPECT_GE(successes, 2);
}

TEST(DepthPerceptionTest, MemoryHoldsOnlyTheClutterTheArmHides) {
  ClutteredRig rig;
  if (!rig.sensor) GTEST_SKIP() << "offscreen rendering is not available here";
  DepthPerception* sensor = rig.sensor.get();
  long remembered = 0, hidden_frames = 0;
  double worst = 0.0;
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    sim::EpisodeOptions episode{.duration = 3.0, .seed = seed, .video_fps = 30.0};
    episode.sensor = sensor;
    sim::RunEpisode(episode, rig.world, rig.controller, *rig.scenario, [&](const sim::FrameInfo& f) {
      rmp::Scene truth;
      f.scenario->FillScene(&truth);
      const Eigen::Matrix3Xd& p = sensor->memory().points();
      remembered += p.cols();
      if (sensor->memory().stats().hidden > 0) ++hidden_frames;
      // every remembered point lies on a true cube: within the voxel (a centroid is up to a half-diagonal off the
      // surface) and the depth noise of its surface
      for (Eigen::Index i = 0; i < p.cols(); ++i) {
        double d = std::numeric_limits<double>::infinity();
        for (const rmp::Obstacle& o : truth.obstacles) {
          d = std::min(d, rmp::CapsuleObstacleDistance(math::Capsule{p.col(i), p.col(i), 0.0}, o).distance);
        }
        worst = std::max(worst, d);
      }
    });
  }
  EXPECT_GT(remembered, 0) << "the static cubes are remembered";
  EXPECT_GT(hidden_frames, 0) << "the arm hides part of the clutter from the camera in some frames";
  EXPECT_LT(worst, 0.02) << "a remembered point off every cube [m]";
}

TEST(DepthPerceptionTest, BadOptionsAreRefused) {
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  const sim::WorldModel model(robot);
  DepthPerceptionOptions two;
  two.cameras.push_back(DepthCameraOptions{});
  two.cameras[1].rate = 15.0;
  std::string why;
  EXPECT_THROW(DepthPerception::Create(model, two, &why), InputError);
  DepthPerceptionOptions none, stride;
  none.cameras.clear();
  stride.stride = 0;
  EXPECT_THROW(DepthPerception::Create(model, none, &why), InputError);
  EXPECT_THROW(DepthPerception::Create(model, stride, &why), InputError);
  DepthPerceptionOptions hold;
  hold.memory.hold_time = 0.0;
  EXPECT_THROW(DepthPerception::Create(model, hold, &why), InputError);
  for (double margin : {-0.01, 0.25, std::numeric_limits<double>::quiet_NaN()}) {
    DepthPerceptionOptions o;
    o.cloud.point_margin = margin;
    try {
      DepthPerception::Create(model, o, &why);
      ADD_FAILURE() << "point_margin " << margin << " was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("point_margin"), std::string::npos) << e.what();
    }
  }
}

TEST(RecordedCloudTest, AFileOrAFolderOfFramesReplaysAsObstacles) {
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  std::unique_ptr<sim::Scenario> scenario = sim::MakeScenario("crossing", robot, {.num_obstacles = 0});
  auto model = std::make_shared<const sim::WorldModel>(robot, scenario->scene_spec());
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "rmpmarl_recorded_cloud_test";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "frames");
  // a 10 cm box's surface, moving 1 cm per frame along y in the folder, still in the single file
  auto box = [](double y) {
    Eigen::Matrix3Xd p(3, 6 * 100);
    int k = 0;
    for (int axis = 0; axis < 3; ++axis)
      for (int sign : {-1, 1})
        for (int i = 0; i < 10; ++i)
          for (int j = 0; j < 10; ++j) {
            Eigen::Vector3d q;
            q[axis] = 0.05 * sign;
            q[(axis + 1) % 3] = -0.05 + 0.01 * (i + 0.5);
            q[(axis + 2) % 3] = -0.05 + 0.01 * (j + 0.5);
            p.col(k++) = Eigen::Vector3d(0.5, y, 0.6) + q;
          }
    return p;
  };
  control::WritePly(dir / "still.ply", box(0.3));
  for (int f = 0; f < 10; ++f) control::WritePcd(dir / "frames" / fmt::format("{:03d}.pcd", f), box(0.3 + 0.01 * f));
  sim::World world(model);
  scenario->Reset(0, world);
  RecordedCloud still(robot, dir / "still.ply");
  still.Reset(world);
  rmp::Scene scene;
  still.Sense(world, &scene);
  ASSERT_EQ(scene.obstacles.size(), 1u);
  EXPECT_LT((rmp::Centre(scene.obstacles[0]) - Eigen::Vector3d(0.5, 0.3, 0.6)).norm(), 0.02);
  RecordedCloudOptions rate;
  rate.rate = 30.0;
  RecordedCloud frames(robot, dir / "frames", rate);
  EXPECT_EQ(frames.num_frames(), 10);
  EXPECT_EQ(frames.total_points(), 6000);
  // a RunEpisode with it: the frames advance at 30 Hz and the box's velocity is 0.01 m × 30 Hz = 0.3 m/s
  control::ReactiveController controller(model->servos(), std::make_unique<control::RmpflowAccelerationPolicy>(robot, 8));
  sim::EpisodeOptions episode{.duration = 0.25};
  episode.sensor = &frames;
  sim::RunEpisode(episode, world, controller, *scenario);
  EXPECT_NEAR(static_cast<double>(frames.Summary().updates), 0.25 * 30.0, 1.0);
  rmp::Scene last;
  frames.Sense(world, &last);
  ASSERT_EQ(last.obstacles.size(), 1u);
  EXPECT_NEAR(last.obstacles[0].v_WO.y(), 0.3, 0.05);
  // bad paths
  EXPECT_THROW(RecordedCloud(robot, dir / "missing.ply"), InputError);
  std::filesystem::create_directories(dir / "empty");
  EXPECT_THROW(RecordedCloud(robot, dir / "empty"), InputError);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace rmpmarl::perception
