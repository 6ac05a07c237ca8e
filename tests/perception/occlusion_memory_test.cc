// The memory of hidden static obstacles on ray-cast depth images: a point's visibility, a cube kept while an
// occluder hides it and forgotten once the camera sees through its place, no trail behind a moving cube.
#include "rmpmarl/perception/occlusion_memory.h"

#include <gtest/gtest.h>

#include <limits>
#include <optional>

#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/robot.h"

namespace rmpmarl::perception {
namespace {

struct Box {
  Eigen::Vector3d centre;
  Eigen::Vector3d half;
};

// a depth image of axis-aligned boxes by ray casting (slab test): depth z along the optical axis of each pixel's ray
DepthImage RayCast(const std::vector<Box>& boxes, const Eigen::Isometry3d& X_WC, double time) {
  DepthImage image;
  image.intrinsics = {.width = 160, .height = 120, .fx = 100.0, .fy = 100.0, .cx = 79.5, .cy = 59.5};
  image.X_WC = X_WC;
  image.time = time;
  const CameraIntrinsics& k = image.intrinsics;
  image.depth.assign(static_cast<size_t>(k.width) * k.height, 0.0f);
  const Eigen::Vector3d p_WC = X_WC.translation();
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      // p(z) = p_WC + z d_W: the ray's parameter is the depth, its optical-axis component is 1
      const Eigen::Vector3d d_W = X_WC.linear() * Eigen::Vector3d((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
      double best = std::numeric_limits<double>::infinity();
      for (const Box& b : boxes) {
        double lo = 0.0, hi = std::numeric_limits<double>::infinity();
        for (int a = 0; a < 3; ++a) {
          const double o = p_WC[a], d = d_W[a], mn = b.centre[a] - b.half[a], mx = b.centre[a] + b.half[a];
          if (std::abs(d) < 1e-12) {
            if (o < mn || o > mx) hi = -1.0;
            continue;
          }
          double t0 = (mn - o) / d, t1 = (mx - o) / d;
          if (t0 > t1) std::swap(t0, t1);
          lo = std::max(lo, t0);
          hi = std::min(hi, t1);
        }
        if (lo <= hi && lo > 0.0) best = std::min(best, lo);
      }
      if (best < 3.0) image.depth[static_cast<size_t>(v) * k.width + u] = static_cast<float>(best);
    }
  }
  return image;
}

// beside the Panda (its base at the origin), beyond its reach: a camera looking along −x at a cube before a wall
const Eigen::Isometry3d kCamera = LookAt({1.5, 1.0, 0.5}, {0.3, 1.0, 0.5});
const Box kWall{{-0.3, 1.0, 0.5}, {0.02, 1.0, 0.6}};
const Box kCube{{0.3, 1.0, 0.5}, {0.04, 0.04, 0.04}};
const Box kOccluder{{0.9, 1.0, 0.5}, {0.05, 0.15, 0.15}};  // stands between the camera and the cube

TEST(OcclusionMemoryTest, ClassifiesPointsAgainstTheImage) {
  const DepthImage image = RayCast({kWall, kCube, kOccluder}, kCamera, 0.0);
  const double tol = 0.03, lo = 0.1, hi = 3.0;
  // the occluder's face, the cube behind it, the wall behind both
  EXPECT_EQ(ClassifyPoint(image, {0.95, 1.0, 0.5}, tol, 1, lo, hi), PointVisibility::kSeen);
  EXPECT_EQ(ClassifyPoint(image, {0.34, 1.0, 0.5}, tol, 1, lo, hi), PointVisibility::kHidden);
  // the wall beside the occluder's shadow is seen
  EXPECT_EQ(ClassifyPoint(image, {-0.28, 1.6, 0.5}, tol, 1, lo, hi), PointVisibility::kSeen);
  // a point in the air between the occluder and the wall, off the occluder's shadow: the camera sees past it
  EXPECT_EQ(ClassifyPoint(image, {0.3, 1.45, 0.5}, tol, 1, lo, hi), PointVisibility::kFree);
  // the image has no depth there (beyond the wall's edge: nothing within 3 m)
  EXPECT_EQ(ClassifyPoint(image, {0.0, 1.0, 1.3}, tol, 1, lo, hi), PointVisibility::kNoDepth);
  // behind the camera, outside its field of view, beyond its range
  EXPECT_EQ(ClassifyPoint(image, {2.0, 1.0, 0.5}, tol, 1, lo, hi), PointVisibility::kOutside);
  EXPECT_EQ(ClassifyPoint(image, {0.3, -1.0, 0.5}, tol, 1, lo, hi), PointVisibility::kOutside);
  EXPECT_EQ(ClassifyPoint(image, {0.3, 1.0, 0.5}, tol, 1, lo, 1.0), PointVisibility::kOutside);
  // within the tolerance of the surface is seen, beyond it in front is free, beyond it behind is hidden
  EXPECT_EQ(ClassifyPoint(image, {0.96, 1.0, 0.5}, 0.02, 0, lo, hi), PointVisibility::kSeen);
  EXPECT_EQ(ClassifyPoint(image, {0.98, 1.0, 0.5}, 0.02, 0, lo, hi), PointVisibility::kFree);
  EXPECT_EQ(ClassifyPoint(image, {0.92, 1.0, 0.5}, 0.02, 0, lo, hi), PointVisibility::kHidden);
  // with a pixel stride, only the pixels the cloud was made of see a point: a stride-4 image whose other pixels are
  // blanked classifies like the full one
  DepthImage strided = image;
  for (int v = 0; v < strided.intrinsics.height; ++v) {
    for (int u = 0; u < strided.intrinsics.width; ++u) {
      if (u % 4 != 0 || v % 4 != 0) strided.depth[static_cast<size_t>(v) * strided.intrinsics.width + u] = 0.0f;
    }
  }
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(0.95, 1.0, 0.5), Eigen::Vector3d(0.34, 1.0, 0.5),
                                   Eigen::Vector3d(-0.28, 1.6, 0.5), Eigen::Vector3d(0.3, 1.45, 0.5)}) {
    EXPECT_EQ(ClassifyPoint(strided, p, tol, 1, lo, hi, 4), ClassifyPoint(image, p, tol, 1, lo, hi)) << p.transpose();
  }
  // an image whose depths do not match its size, a stride below 1
  DepthImage broken = image;
  broken.depth.pop_back();
  EXPECT_THROW(ClassifyPoint(broken, {0.95, 1.0, 0.5}, tol, 1, lo, hi), InputError);
  EXPECT_THROW(ClassifyPoint(image, {0.95, 1.0, 0.5}, tol, 1, lo, hi, 0), InputError);
}

// the least distance from p to the update's obstacle points (infinity when there are none)
double Nearest(const control::CloudObstacles& cloud, const Eigen::Vector3d& p) {
  double d = std::numeric_limits<double>::infinity();
  for (Eigen::Index i = 0; i < cloud.points().cols(); ++i) d = std::min(d, (cloud.points().col(i) - p).norm());
  return d;
}

// one camera frame as DepthPerception runs it: forget, cloud + memory, update, remember
class Pipeline {
 public:
  explicit Pipeline(bool memory)
      : robot_(kinematics::LoadShippedRobot("panda")),
        cloud_(robot_),
        memory_(OcclusionMemoryOptions{.enabled = memory}, cloud_.options().voxel_size),
        q_(Eigen::VectorXd::Zero(robot_.model.nq())) {}
  void Frame(const std::vector<Box>& boxes, double time) {
    images_ = {RayCast(boxes, kCamera, time)};
    Eigen::Matrix3Xd fresh;
    const int n = DepthToWorldPoints(images_[0], 1, &fresh);
    memory_.Forget(images_, ranges_, time);
    cloud_.Update(fresh.leftCols(n), time, q_, memory_.points(), memory_.counts());
    memory_.Remember(cloud_, time);
  }
  const control::CloudObstacles& cloud() const { return cloud_; }
  const OcclusionMemory& memory() const { return memory_; }

 private:
  kinematics::Robot robot_;
  control::CloudObstacles cloud_;
  OcclusionMemory memory_;
  Eigen::VectorXd q_;
  std::vector<DepthImage> images_;
  std::vector<Eigen::Vector2d> ranges_{Eigen::Vector2d(0.1, 3.0)};
};

TEST(OcclusionMemoryTest, KeepsAHiddenCubeUntilTheCameraSeesThroughItsPlace) {
  const Eigen::Vector3d face = kCube.centre + Eigen::Vector3d(kCube.half.x(), 0.0, 0.0);  // the face the camera sees
  for (bool on : {true, false}) {
    SCOPED_TRACE(on ? "memory on" : "memory off");
    Pipeline p(on);
    double t = 0.0;
    for (int k = 0; k < 4; ++k, t += 1.0 / 30.0) p.Frame({kWall, kCube}, t);
    EXPECT_LT(Nearest(p.cloud(), face), 0.02) << "the camera sees the cube";
    // the occluder comes between: only memory knows the cube, for as long as it stays hidden
    for (int k = 0; k < 30; ++k, t += 1.0 / 30.0) {
      p.Frame({kWall, kCube, kOccluder}, t);
      if (on) {
        ASSERT_LT(Nearest(p.cloud(), face), 0.02) << "frame " << k << " behind the occluder";
        EXPECT_GT(p.memory().stats().hidden, 20);
        EXPECT_EQ(p.memory().stats().forgotten_free, 0);
      } else {
        ASSERT_GT(Nearest(p.cloud(), face), 0.1) << "frame " << k << ": without memory the cube is gone";
      }
    }
    // the cube is taken away and the occluder with it: the camera sees the wall through its place
    p.Frame({kWall}, t);
    EXPECT_GT(Nearest(p.cloud(), face), 0.1) << "a cube seen through is forgotten";
    if (on) {
      EXPECT_GT(p.memory().stats().forgotten_free, 10);
    }
  }
}

TEST(OcclusionMemoryTest, AHalfHiddenCubeKeepsItsCentroidAndStaysAtRest) {
  // covers the cube's half at y > 1 (the camera looks along −x from y = 1)
  const Box half_occluder{{0.9, 1.1, 0.5}, {0.05, 0.1, 0.15}};
  for (bool on : {true, false}) {
    SCOPED_TRACE(on ? "memory on" : "memory off");
    Pipeline p(on);
    double t = 0.0;
    for (int k = 0; k < 4; ++k, t += 1.0 / 30.0) p.Frame({kWall, kCube}, t);
    auto cube = [&]() -> const control::CloudCluster& {
      const control::CloudCluster* best = nullptr;
      for (const control::CloudCluster& c : p.cloud().clusters()) {
        if (best == nullptr || (c.centroid_W - kCube.centre).norm() < (best->centroid_W - kCube.centre).norm()) best = &c;
      }
      return *best;
    };
    const Eigen::Vector3d before = cube().centroid_W;
    double shift = 0.0;
    for (int k = 0; k < 10; ++k, t += 1.0 / 30.0) {
      p.Frame({kWall, kCube, half_occluder}, t);
      shift = std::max(shift, (cube().centroid_W - before).norm());
      if (on) {
        EXPECT_TRUE(cube().v_WO.isZero(0.0)) << "frame " << k << ": v " << cube().v_WO.transpose();
      }
    }
    // with memory the hidden half weighs as it did when seen; without, the centroid jumps to the visible half
    if (on) {
      EXPECT_LT(shift, 1e-9);
    } else {
      EXPECT_GT(shift, 0.01);
    }
  }
}

TEST(OcclusionMemoryTest, ForgetsAHiddenPointAfterTheHoldTime) {
  Pipeline p(true);
  const Eigen::Vector3d face = kCube.centre + Eigen::Vector3d(kCube.half.x(), 0.0, 0.0);
  double t = 0.0;
  for (int k = 0; k < 4; ++k, t += 1.0 / 30.0) p.Frame({kWall, kCube}, t);
  const double last_seen = t - 1.0 / 30.0;
  const double hold = p.memory().options().hold_time;
  for (; t < last_seen + hold - 0.05; t += 0.1) p.Frame({kWall, kCube, kOccluder}, t);
  EXPECT_LT(Nearest(p.cloud(), face), 0.02) << "hidden for less than the hold time";
  t = last_seen + hold + 0.05;
  p.Frame({kWall, kCube, kOccluder}, t);
  EXPECT_GT(Nearest(p.cloud(), face), 0.1) << "not seen for longer than the hold time";
  EXPECT_GT(p.memory().stats().forgotten_old, 20);
}

TEST(OcclusionMemoryTest, AMovingCubeLeavesNoTrail) {
  Pipeline p(true);
  double t = 0.0;
  Box cube = kCube;
  cube.centre.y() = 0.8;
  // at 0.6 m/s across the camera's view, then behind the occluder, where it stops unseen
  for (int k = 0; k < 12; ++k, t += 1.0 / 30.0) {
    p.Frame({kWall, cube}, t);
    cube.centre.y() += 0.6 / 30.0;
  }
  ASSERT_FALSE(p.cloud().clusters().empty());
  p.Frame({kWall, cube, kOccluder}, t);
  const Eigen::Vector3d face = cube.centre + Eigen::Vector3d(cube.half.x(), 0.0, 0.0);
  EXPECT_GT(Nearest(p.cloud(), face), 0.1) << "a moving object is not remembered";
}

TEST(OcclusionMemoryTest, BadOptionsAreRefused) {
  EXPECT_THROW(OcclusionMemory(OcclusionMemoryOptions{.hold_time = 0.0}, 0.02), InputError);
  EXPECT_THROW(OcclusionMemory(OcclusionMemoryOptions{.depth_tolerance = -1.0}, 0.02), InputError);
  EXPECT_THROW(OcclusionMemory(OcclusionMemoryOptions{.window = 9}, 0.02), InputError);
  EXPECT_THROW(OcclusionMemory(OcclusionMemoryOptions{.min_age = 0}, 0.02), InputError);
  EXPECT_THROW(OcclusionMemory(OcclusionMemoryOptions{.max_points = 0}, 0.02), InputError);
  EXPECT_THROW(OcclusionMemory(OcclusionMemoryOptions{}, 0.0), InputError);
  try {
    ValidateOcclusionMemoryOptions(OcclusionMemoryOptions{.hold_time = -2.0});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("hold_time"), std::string::npos) << e.what();
  }
  OcclusionMemory memory(OcclusionMemoryOptions{}, 0.02);
  EXPECT_THROW(memory.Forget({DepthImage{}}, {}, 0.0), InputError) << "one range per image";
}

}  // namespace
}  // namespace rmpmarl::perception
