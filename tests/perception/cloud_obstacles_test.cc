// Point-cloud obstacles: distances equal brute force on every shipped arm, the self filter, clustering, tracking and
// bad clouds.
#include "rmpmarl/control/cloud_obstacles.h"

#include <gtest/gtest.h>

#include <random>

#include "../kinematics/test_robots.h"
#include "rmpmarl/common/error.h"

namespace rmpmarl::perception {
namespace {

std::vector<math::Capsule> WorldCapsules(const kinematics::Robot& robot, const Eigen::VectorXd& q) {
  kinematics::Data data(robot.model);
  kinematics::CalcForwardKinematics(robot.model, q, &data);
  std::vector<math::Capsule> out;
  for (const auto& c : robot.capsules) out.push_back({data.X_WL[c.link] * c.p_LA, data.X_WL[c.link] * c.p_LB, c.radius});
  return out;
}

double DistanceToRobot(const std::vector<math::Capsule>& capsules, const Eigen::Vector3d& p) {
  double d = std::numeric_limits<double>::infinity();
  for (const auto& c : capsules) d = std::min(d, math::CapsuleSphereDistance(c, math::Sphere{p, 0.0}).distance);
  return d;
}

// a point on capsule c's surface at a random axis parameter and direction, offset `off` outward.
Eigen::Vector3d OnCapsule(const math::Capsule& c, double off, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> g;
  const Eigen::Vector3d axis = c.p_WB - c.p_WA;
  Eigen::Vector3d dir(g(rng), g(rng), g(rng));
  const double t = u(rng);
  // on the cylinder part the direction is perpendicular to the axis; near the ends any direction (the caps)
  if (axis.norm() > 1e-9 && t > 0.05 && t < 0.95) dir -= dir.dot(axis) / axis.squaredNorm() * axis;
  dir.normalize();
  return c.p_WA + t * axis + (c.radius + off) * dir;
}

Eigen::Matrix3Xd BoxSurface(const Eigen::Vector3d& centre, double half, int per_face_side) {
  Eigen::Matrix3Xd p(3, 6 * per_face_side * per_face_side);
  int k = 0;
  for (int axis = 0; axis < 3; ++axis)
    for (int sign : {-1, 1})
      for (int i = 0; i < per_face_side; ++i)
        for (int j = 0; j < per_face_side; ++j) {
          Eigen::Vector3d q;
          q[axis] = sign * half;
          q[(axis + 1) % 3] = -half + 2 * half * (i + 0.5) / per_face_side;
          q[(axis + 2) % 3] = -half + 2 * half * (j + 0.5) / per_face_side;
          p.col(k++) = centre + q;
        }
  return p;
}

TEST(CloudObstaclesTest, DistancesAndWitnessPointsEqualBruteForceOnEveryShippedArm) {
  std::mt19937_64 rng(5);
  for (const std::string& name : kinematics::ShippedRobotNames()) {
    SCOPED_TRACE(name);
    const kinematics::Robot robot = kinematics::LoadShippedRobot(name);
    for (int trial = 0; trial < 4; ++trial) {
      const Eigen::VectorXd q = testing::RandomConfiguration(robot.model, rng);
      const std::vector<math::Capsule> capsules = WorldCapsules(robot, q);
      // 20 000 points in the arm's bounding box grown by 0.3 m: some inside the capsules, most around them
      Eigen::AlignedBox3d box;
      for (const auto& c : capsules) box.extend(c.p_WA).extend(c.p_WB);
      std::uniform_real_distribution<double> ux(box.min().x() - 0.3, box.max().x() + 0.3),
          uy(box.min().y() - 0.3, box.max().y() + 0.3), uz(box.min().z() - 0.3, box.max().z() + 0.3);
      Eigen::Matrix3Xd p(3, 20000);
      for (int i = 0; i < p.cols(); ++i) p.col(i) = Eigen::Vector3d(ux(rng), uy(rng), uz(rng));
      const math::PointCloudIndex index(p);
      const rmp::Obstacle obstacle = rmp::Obstacle::MakePoints(index, 0.01);
      for (const math::Capsule& c : capsules) {
        const math::DistanceResult d = rmp::CapsuleObstacleDistance(c, obstacle);
        const math::SegmentNearestPoint ref = math::NearestToSegmentBruteForce(p, c.p_WA, c.p_WB);
        ASSERT_GE(ref.index, 0);
        EXPECT_NEAR(d.distance, ref.distance - c.radius - 0.01, 1e-9);
        EXPECT_LT((d.p_W2 - 0.01 * d.n_W - ref.p_Wpoint).norm(), 1e-9);
        EXPECT_LT((d.p_W1 + c.radius * d.n_W - ref.p_Wsegment).norm(), 1e-9);
      }
    }
  }
}

TEST(CloudObstaclesTest, SelfFilterRemovesEveryPointOnTheRobotAndNoneTwoCentimetresOff) {
  std::mt19937_64 rng(6);
  for (const std::string& name : kinematics::ShippedRobotNames()) {
    SCOPED_TRACE(name);
    const kinematics::Robot robot = kinematics::LoadShippedRobot(name);
    // 1 mm voxels and single-voxel clusters: the filter's decision is seen point by point
    control::CloudObstacles cloud(robot, {.voxel_size = 0.001,
                                 .workspace = Eigen::AlignedBox3d(Eigen::Vector3d::Constant(-3), Eigen::Vector3d::Constant(3)),
                                 .self_filter_margin = 0.01, .min_cluster_voxels = 1, .max_obstacles = 256});
    const Eigen::VectorXd q = testing::RandomConfiguration(robot.model, rng);
    const std::vector<math::Capsule> capsules = WorldCapsules(robot, q);
    std::vector<Eigen::Vector3d> on, off, all;
    // points at least 2 mm apart lie in different 1 mm voxels: every voxel is one point
    auto apart = [&all](const Eigen::Vector3d& p) {
      for (const Eigen::Vector3d& o : all) {
        if ((o - p).squaredNorm() < 4e-6) return false;
      }
      all.push_back(p);
      return true;
    };
    std::uniform_int_distribution<int> pick(0, static_cast<int>(capsules.size()) - 1);
    std::uniform_real_distribution<double> inside(-0.02, 0.0);
    while (on.size() < 1500) {
      const Eigen::Vector3d p = OnCapsule(capsules[pick(rng)], on.size() % 2 ? 0.0 : inside(rng), rng);
      if (apart(p)) on.push_back(p);
    }
    while (off.size() < 1500) {
      const Eigen::Vector3d p = OnCapsule(capsules[pick(rng)], 0.02, rng);
      if (DistanceToRobot(capsules, p) >= 0.02 - 1e-12 && apart(p)) off.push_back(p);  // 2 cm off every capsule
    }
    Eigen::Matrix3Xd p(3, on.size() + off.size());
    for (size_t i = 0; i < on.size(); ++i) p.col(i) = on[i];
    for (size_t i = 0; i < off.size(); ++i) p.col(on.size() + i) = off[i];
    const control::CloudUpdateStats& s = cloud.Update(p, 0.0, q);
    ASSERT_EQ(s.voxels, s.input_points);
    EXPECT_EQ(s.robot_voxels, static_cast<long>(on.size())) << "every point on the robot is dropped";
    const Eigen::Matrix3Xd& kept = cloud.points();
    EXPECT_EQ(kept.cols(), static_cast<long>(off.size())) << "no point 2 cm off the robot is dropped";
    for (long i = 0; i < kept.cols(); ++i) EXPECT_GE(DistanceToRobot(capsules, kept.col(i)), 0.02 - 1e-9);
  }
}

TEST(CloudObstaclesTest, ClustersBecomeObstaclesWithTrackedVelocities) {
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  control::CloudObstacles cloud(robot, {});
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(robot.model.nq());
  const Eigen::Vector3d v(0.0, 0.6, 0.0);  // m/s
  Eigen::Vector3d a(0.6, -0.4, 0.4);
  const Eigen::Vector3d b(0.3, 0.5, 0.3);
  for (int k = 0; k < 10; ++k) {
    const double t = k / 30.0;
    const Eigen::Vector3d pa = a + t * v;
    Eigen::Matrix3Xd p(3, 2 * 600);
    p << BoxSurface(pa, 0.05, 10), BoxSurface(b, 0.05, 10);
    cloud.Update(p, t, q);
    ASSERT_EQ(cloud.num_obstacles(), 2);
    rmp::Scene scene;
    cloud.FillScene(&scene);
    ASSERT_EQ(scene.obstacles.size(), 2u);
    ASSERT_NO_THROW(rmp::ValidateScene(scene, "cloud scene"));
    for (int j = 0; j < 2; ++j) {
      const control::CloudCluster& c = cloud.clusters()[j];
      const bool moving = (c.centroid_W - pa).norm() < 0.03;
      EXPECT_TRUE(moving || (c.centroid_W - b).norm() < 0.03);
      EXPECT_LT((rmp::Centre(scene.obstacles[j]) - (moving ? pa : b)).norm(), 0.03);
      // each point a sphere of half a 2 cm voxel plus the default 2 cm margin
      EXPECT_DOUBLE_EQ(scene.obstacles[j].point_radius, 0.03);
      if (k >= 4) {  // the smoothed estimate has converged: the box moves 2 cm per frame, 1 voxel
        EXPECT_LT((c.v_WO - (moving ? v : Eigen::Vector3d::Zero())).norm(), 0.1 * v.norm()) << "frame " << k;
      }
    }
  }
  // the same track ids throughout; Reset forgets them
  const int first = cloud.clusters()[0].track;
  EXPECT_LT(first, 2);
  cloud.Reset();
  EXPECT_EQ(cloud.num_obstacles(), 0);
}

TEST(CloudObstaclesTest, ClustersBeyondTheSlotsAreMergedIntoTheLastAndNoPointIsLost) {
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  control::CloudObstacles cloud(robot, {.max_obstacles = 3});
  Eigen::Matrix3Xd p(3, 5 * 600);
  for (int j = 0; j < 5; ++j) p.middleCols(600 * j, 600) = BoxSurface(Eigen::Vector3d(0.3 + 0.2 * j, 0.6, 0.3), 0.04, 10);
  const control::CloudUpdateStats& s = cloud.Update(p, 0.0, Eigen::VectorXd::Zero(robot.model.nq()));
  EXPECT_EQ(s.clusters, 5);
  EXPECT_EQ(s.merged_clusters, 3);
  ASSERT_EQ(cloud.num_obstacles(), 3);
  int voxels = 0;
  for (const control::CloudCluster& c : cloud.clusters()) voxels += c.voxels;
  EXPECT_EQ(voxels, s.voxels - s.robot_voxels);
  EXPECT_EQ(cloud.points().cols(), voxels);
  EXPECT_LE(cloud.clusters()[0].clearance, cloud.clusters()[1].clearance) << "nearest the arm first";
  EXPECT_EQ(cloud.clusters()[2].v_WO, Eigen::Vector3d::Zero());
}

// the default crop keeps everything the arm can reach, below its base too (a table it is mounted above, as in
// MotionBenchMaker's box and table cells): a bound of the reach, checked against sampled configurations
TEST(CloudObstaclesTest, TheDefaultCropIsTheArmsReachAboveAndBelowItsBase) {
  for (const std::string& name : kinematics::ShippedRobotNames()) {
    SCOPED_TRACE(name);
    const kinematics::Robot robot = kinematics::LoadShippedRobot(name);
    const Eigen::AlignedBox3d box = control::ReachCrop(robot, 0.0);
    kinematics::Data data(robot.model);
    std::mt19937_64 rng(1);
    double reach = 0.0;
    for (int k = 0; k < 2000; ++k) {
      Eigen::VectorXd q(robot.model.nq());
      for (int i = 0; i < q.size(); ++i) {
        const kinematics::DofLimits& l = robot.model.limits()[i];
        const double lo = std::isfinite(l.lower) ? l.lower : -M_PI, hi = std::isfinite(l.upper) ? l.upper : M_PI;
        q[i] = std::uniform_real_distribution<double>(lo, hi)(rng);
      }
      kinematics::CalcForwardKinematics(robot.model, q, &data);
      for (const kinematics::LinkCapsule& c : robot.capsules) {
        for (const Eigen::Vector3d& p : {c.p_LA, c.p_LB}) {
          reach = std::max(reach, (data.X_WL[c.link] * p).norm() + c.radius);
        }
      }
    }
    EXPECT_GE(box.max().x(), reach);          // a bound
    EXPECT_LE(box.max().x(), 1.6 * reach);    // not a loose one
    EXPECT_DOUBLE_EQ(box.min().z(), -box.max().z());
  }
  const kinematics::Robot panda = kinematics::LoadShippedRobot("panda");
  control::CloudObstacles cloud(panda);
  EXPECT_TRUE(cloud.workspace().isApprox(control::ReachCrop(panda)));
  // a table top half a metre below the base stays; the far wall of the room goes
  Eigen::Matrix3Xd p = BoxSurface(Eigen::Vector3d(0.5, 0.0, -0.5), 0.05, 10);
  p.col(0) = Eigen::Vector3d(6.0, 0.0, 0.0);
  const control::CloudUpdateStats& s = cloud.Update(p, 0.0, Eigen::VectorXd::Zero(panda.model.nq()));
  EXPECT_EQ(s.outside_points, 1);
  EXPECT_EQ(cloud.num_obstacles(), 1);
  const Eigen::AlignedBox3d floor = control::FloorCrop(0.1);
  EXPECT_DOUBLE_EQ(floor.min().z(), 0.13);
}

TEST(CloudObstaclesTest, BadCloudsAreDroppedOrRefusedWithAMessage) {
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(robot.model.nq());
  control::CloudObstacles cloud(robot, {.max_points = 100000});
  // empty: no obstacles
  EXPECT_EQ(cloud.Update(Eigen::Matrix3Xd(3, 0), 0.0, q).voxels, 0);
  EXPECT_EQ(cloud.num_obstacles(), 0);
  // NaN and infinite points are dropped and counted; points outside the workspace too
  Eigen::Matrix3Xd p = BoxSurface(Eigen::Vector3d(0.5, 0.5, 0.4), 0.05, 10);
  p(0, 3) = std::numeric_limits<double>::quiet_NaN();
  p(2, 7) = std::numeric_limits<double>::infinity();
  p(0, 9) = 4.0;  // beyond the arm's reach
  const control::CloudUpdateStats& s = cloud.Update(p, 0.1, q);
  EXPECT_EQ(s.nonfinite_points, 2);
  EXPECT_EQ(s.outside_points, 1);
  EXPECT_EQ(cloud.num_obstacles(), 1);
  // millimetres
  const Eigen::Matrix3Xd mm = 1000.0 * BoxSurface(Eigen::Vector3d(0.5, 0.5, 0.4), 0.05, 10);
  try {
    cloud.Update(mm, 0.2, q);
    ADD_FAILURE() << "a cloud in millimetres was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("millimetres"), std::string::npos) << e.what();
  }
  // too many points
  try {
    cloud.Update(Eigen::Matrix3Xd::Zero(3, 100001), 0.3, q);
    ADD_FAILURE() << "a cloud past max_points was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("100001"), std::string::npos) << e.what();
  }
  EXPECT_THROW(cloud.Update(p, 0.05, q), InputError) << "time went backwards";
  EXPECT_THROW(cloud.Update(p, 0.5, Eigen::VectorXd::Zero(3)), InputError);
  for (const control::CloudObstacleOptions& bad : {control::CloudObstacleOptions{.voxel_size = 0.0}, control::CloudObstacleOptions{.min_cluster_voxels = 0},
                                          control::CloudObstacleOptions{.max_obstacles = 0}, control::CloudObstacleOptions{.velocity_window = 1}}) {
    EXPECT_THROW(control::CloudObstacles(robot, bad), InputError);
  }
  // a cloud of ten million points, downsampled by the caller's limit: handled when the limit allows it
  control::CloudObstacles big(robot, {.max_points = 10'000'000});
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Eigen::Matrix3Xd many(3, 10'000'000);
  for (long i = 0; i < many.cols(); ++i) many.col(i) = Eigen::Vector3d(0.5 + 0.1 * u(rng), 0.5 + 0.1 * u(rng), 0.4 + 0.1 * u(rng));
  const control::CloudUpdateStats& sb = big.Update(many, 0.0, q);
  EXPECT_EQ(sb.input_points, 10'000'000);
  EXPECT_LE(sb.voxels, 6 * 6 * 6);
  EXPECT_EQ(big.num_obstacles(), 1);
}

}  // namespace
}  // namespace rmpmarl::perception
