// The simulated depth camera against independent references: analytic ray casts through boxes, planes and spheres,
// the robot's capsules in MuJoCo's data, and the noise model's statistics.
#include "rmpmarl/perception/depth_camera.h"

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#if defined(__SANITIZE_ADDRESS__)
#include <dlfcn.h>
#include <link.h>

#include <cstring>
#endif

#include <algorithm>
#include <cmath>
#include <functional>
#include <iostream>
#include <limits>
#include <memory>

#include "../support/alloc_counter.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/sim/render.h"
#include "rmpmarl/sim/world.h"

namespace rmpmarl::perception {
namespace {

using Eigen::Vector3d;
constexpr double kInf = std::numeric_limits<double>::infinity();

// keeps Mesa's dlopen-ed driver loaded at exit under ASan, so LeakSanitizer can name it (tests/sim/render_test.cc).
void KeepGraphicsLibrariesLoaded() {
#if defined(__SANITIZE_ADDRESS__)
  dl_iterate_phdr(
      [](dl_phdr_info* info, size_t, void*) {
        const char* name = info->dlpi_name;
        if (name != nullptr && (std::strstr(name, "dri") || std::strstr(name, "mesa") ||
                                std::strstr(name, "gallium") || std::strstr(name, "LLVM") ||
                                std::strstr(name, "libGL") || std::strstr(name, "libgbm"))) {
          dlopen(name, RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE);
        }
        return 0;
      },
      nullptr);
#endif
}

// a Panda world (robot at the origin, at q = 0) with the given scene, and one World on it.
struct TestWorld {
  explicit TestWorld(const sim::SceneSpec& scene)
      : model(std::make_shared<const sim::WorldModel>(kinematics::LoadShippedRobot("panda"), scene)), world(model) {}
  std::shared_ptr<const sim::WorldModel> model;
  sim::World world;
};

// the camera, or nullptr (the caller skips) when offscreen rendering is unavailable here.
std::unique_ptr<DepthCamera> MakeCamera(const TestWorld& w, const DepthCameraOptions& options) {
  std::string why_not;
  auto camera = DepthCamera::Create(*w.model, options, &why_not);
  if (camera == nullptr) std::cerr << "offscreen rendering unavailable: " << why_not << "\n";
  KeepGraphicsLibrariesLoaded();
  return camera;
}

#define CAMERA_OR_SKIP(camera)                                                  \
  if ((camera) == nullptr) GTEST_SKIP() << "offscreen rendering unavailable"

// the ray of pixel (u, v) in world, scaled so that its parameter is the depth along the optical axis.
Vector3d PixelRay(const DepthImage& image, int u, int v) {
  const CameraIntrinsics& k = image.intrinsics;
  return image.X_WC.linear() * Vector3d((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
}

// depth (ray parameter) where o + t d first enters the box of half sizes h at X_WB; +inf when it misses.
double RayBoxDepth(const Vector3d& o_W, const Vector3d& d_W, const Eigen::Isometry3d& X_WB, const Vector3d& h) {
  const Vector3d o = X_WB.inverse() * o_W, d = X_WB.linear().transpose() * d_W;
  double t_near = -kInf, t_far = kInf;
  for (int i = 0; i < 3; ++i) {
    const double t1 = (-h[i] - o[i]) / d[i], t2 = (h[i] - o[i]) / d[i];
    t_near = std::max(t_near, std::min(t1, t2));
    t_far = std::min(t_far, std::max(t1, t2));
  }
  return (t_near <= t_far && t_near > 0.0) ? t_near : kInf;
}

// signed distance from p_W to the surface of the box of half sizes h at X_WB.
double BoxSignedDistance(const Vector3d& p_W, const Eigen::Isometry3d& X_WB, const Vector3d& h) {
  const Vector3d q = (X_WB.inverse() * p_W).cwiseAbs() - h;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

// pixel coordinates of p_W in `image` (OpenCV convention).
Eigen::Vector2d Project(const DepthImage& image, const Vector3d& p_W) {
  const Vector3d p_C = image.X_WC.inverse() * p_W;
  const CameraIntrinsics& k = image.intrinsics;
  return {k.fx * p_C.x() / p_C.z() + k.cx, k.fy * p_C.y() / p_C.z() + k.cy};
}

// area [px²] of the image of the box of half sizes h at X_WB: the sum of its faces that face the camera, each a
// projected quadrilateral (shoelace formula).
double ProjectedBoxArea(const DepthImage& image, const Eigen::Isometry3d& X_WB, const Vector3d& h) {
  double area = 0.0;
  for (int axis = 0; axis < 3; ++axis) {
    for (double sign : {-1.0, 1.0}) {
      const Vector3d c_B = sign * h[axis] * Vector3d::Unit(axis);  // face centre; its outward normal is along c_B
      if ((X_WB * c_B - image.X_WC.translation()).dot(X_WB.linear() * c_B) >= 0.0) continue;  // faces away
      const int a = (axis + 1) % 3, b = (axis + 2) % 3;
      auto corner = [&](int i) {  // counter-clockwise around the face in its (a, b) axes
        const double sa = (i == 1 || i == 2) ? 1.0 : -1.0, sb = i >= 2 ? 1.0 : -1.0;
        return Project(image, X_WB * (c_B + sa * h[a] * Vector3d::Unit(a) + sb * h[b] * Vector3d::Unit(b)));
      };
      double twice_area = 0.0;
      for (int i = 0; i < 4; ++i) {
        const Eigen::Vector2d q_i = corner(i), q_j = corner((i + 1) % 4);
        twice_area += q_i.x() * q_j.y() - q_j.x() * q_i.y();
      }
      area += 0.5 * std::abs(twice_area);
    }
  }
  return area;
}

// distance from p_W to the surface of the nearest robot geom (capsule or sphere) in the world's current state.
double RobotSurfaceDistance(const sim::World& world, const Vector3d& p_W) {
  const mjModel* m = world.mj_model();
  const mjData* d = world.mj_data();
  double best = kInf;
  for (int g = 0; g < m->ngeom; ++g) {
    if (world.model().geom_info(g).role != sim::GeomRole::kRobot) continue;
    const Vector3d c(d->geom_xpos + 3 * g);
    const Vector3d axis(d->geom_xmat[9 * g + 2], d->geom_xmat[9 * g + 5], d->geom_xmat[9 * g + 8]);
    const double half_length = m->geom_type[g] == mjGEOM_CAPSULE ? m->geom_size[3 * g + 1] : 0.0;
    const double s = std::clamp((p_W - c).dot(axis), -half_length, half_length);
    best = std::min(best, (p_W - (c + s * axis)).norm() - m->geom_size[3 * g]);
  }
  return best;
}

TEST(DepthCameraTest, BoxMatchesAnalyticRayCastsAndProjectedArea) {
  const Vector3d h(0.15, 0.2, 0.1);
  Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();
  X_WB.linear() = (Eigen::AngleAxisd(0.5, Vector3d::UnitZ()) * Eigen::AngleAxisd(0.3, Vector3d::UnitX())).matrix();
  X_WB.translation() = Vector3d(-2.0, 0.1, 0.5);
  sim::SceneSpec scene;
  scene.obstacles.push_back(sim::ObstacleSpec::Box(h, X_WB));
  TestWorld w(scene);
  DepthCameraOptions options;
  options.X_WC = LookAt(Vector3d(-1.0, -0.1, 0.9), X_WB.translation());  // the robot is behind the camera
  auto camera = MakeCamera(w, options);
  CAMERA_OR_SKIP(camera);
  DepthImage image;
  camera->Render(w.world.mj_data(), &image);
  const CameraIntrinsics& k = image.intrinsics;
  ASSERT_EQ(image.depth.size(), static_cast<size_t>(k.width * k.height));

  // every pixel against the analytic ray–box intersection
  int analytic_hits = 0, rendered_hits = 0, disagreements = 0;
  double max_depth_error = 0.0;
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const double t = RayBoxDepth(image.X_WC.translation(), PixelRay(image, u, v), X_WB, h);
      const double z = image.depth[v * k.width + u];
      analytic_hits += std::isfinite(t);
      rendered_hits += z > 0.0;
      if (std::isfinite(t) != (z > 0.0)) {
        ++disagreements;
      } else if (z > 0.0) {
        max_depth_error = std::max(max_depth_error, std::abs(z - t));
      }
    }
  }
  EXPECT_GT(analytic_hits, 3000);
  EXPECT_LT(disagreements, 0.02 * analytic_hits) << "silhouette pixels only";
  EXPECT_LT(max_depth_error, 1e-3);

  // every back-projected point on the box surface; as many points as the box's projected area in pixels
  Eigen::Matrix3Xd p_W;
  const int n = DepthToWorldPoints(image, 1, &p_W);
  EXPECT_EQ(n, rendered_hits);
  double max_surface_distance = 0.0;
  for (int i = 0; i < n; ++i) {
    max_surface_distance = std::max(max_surface_distance, std::abs(BoxSignedDistance(p_W.col(i), X_WB, h)));
  }
  EXPECT_LT(max_surface_distance, 2e-3);
  const double area = ProjectedBoxArea(image, X_WB, h);
  EXPECT_NEAR(n, area, 0.03 * area);
}

TEST(DepthCameraTest, FloorPointsLieOnTheFloorPlane) {
  sim::SceneSpec scene;
  scene.has_floor = true;
  scene.floor_height = 0.05;
  TestWorld w(scene);
  DepthCameraOptions options;
  options.X_WC = LookAt(Vector3d(-0.5, -1.0, 1.0), Vector3d(-1.5, -2.0, 0.05));  // away from the robot
  auto camera = MakeCamera(w, options);
  CAMERA_OR_SKIP(camera);
  DepthImage image;
  camera->Render(w.world.mj_data(), &image);
  Eigen::Matrix3Xd p_W;
  const int n = DepthToWorldPoints(image, 1, &p_W);
  EXPECT_GT(n, 0.5 * options.width * options.height);
  EXPECT_LT((p_W.row(2).head(n).array() - 0.05).abs().maxCoeff(), 2e-3);
  // each pixel against the analytic ray–plane depth, within [min_range, max_range]
  int disagreements = 0;
  double max_depth_error = 0.0;
  const Vector3d o = image.X_WC.translation();
  for (int v = 0; v < options.height; ++v) {
    for (int u = 0; u < options.width; ++u) {
      const Vector3d d = PixelRay(image, u, v);
      const double t = d.z() < 0.0 ? (0.05 - o.z()) / d.z() : kInf;
      const bool in_range = t >= options.min_range && t <= options.max_range;
      const double z = image.depth[v * options.width + u];
      if (in_range != (z > 0.0)) {
        ++disagreements;
      } else if (in_range) {
        max_depth_error = std::max(max_depth_error, std::abs(z - t));
      }
    }
  }
  EXPECT_LT(disagreements, options.width) << "only along the max_range contour";
  EXPECT_LT(max_depth_error, 1e-3);

  // looking straight down from 1 m: a constant depth of 0.95 m
  Eigen::Isometry3d X_WC = Eigen::Isometry3d::Identity();
  X_WC.linear() << 1, 0, 0, 0, -1, 0, 0, 0, -1;  // optical z down, image x along world +x
  X_WC.translation() = Vector3d(-1.5, -1.5, 1.0);
  camera->set_pose(X_WC);
  camera->Render(w.world.mj_data(), &image);
  const auto [lo, hi] = std::minmax_element(image.depth.begin(), image.depth.end());
  EXPECT_NEAR(*lo, 0.95, 1e-3);
  EXPECT_NEAR(*hi, 0.95, 1e-3);
}

TEST(DepthCameraTest, TargetMarkerIsInvisibleWhileRobotAndObstaclesAreSeen) {
  const Vector3d p_WT(0.9, -0.2, 0.6), p_WS(0.9, 0.2, 0.6);
  sim::SceneSpec scene;
  scene.has_target = true;
  scene.target_radius = 0.1;
  scene.p_WT = p_WT;
  scene.obstacles.push_back(sim::ObstacleSpec::Sphere(0.1, p_WS));
  TestWorld w(scene);
  DepthCameraOptions options;
  options.X_WC = LookAt(Vector3d(1.8, 0.0, 0.7), Vector3d(0.0, 0.0, 0.45));
  auto camera = MakeCamera(w, options);
  CAMERA_OR_SKIP(camera);
  DepthImage image;
  camera->Render(w.world.mj_data(), &image);
  const Eigen::Vector2d target_px = Project(image, p_WT);
  ASSERT_TRUE((target_px.array() > 20).all() && (target_px.array() < Eigen::Array2d(300, 220)).all())
      << "the target must be in view for this test to mean anything";
  Eigen::Matrix3Xd p_W;
  const int n = DepthToWorldPoints(image, 1, &p_W);
  int near_target = 0, on_sphere = 0, on_robot = 0, elsewhere = 0;
  for (int i = 0; i < n; ++i) {
    const Vector3d p = p_W.col(i);
    near_target += (p - p_WT).norm() < 0.11;
    const bool sphere = std::abs((p - p_WS).norm() - 0.1) < 3e-3;
    const bool robot = std::abs(RobotSurfaceDistance(w.world, p)) < 3e-3;
    on_sphere += sphere;
    on_robot += robot;
    elsewhere += !sphere && !robot;
  }
  EXPECT_EQ(near_target, 0);
  EXPECT_GT(on_sphere, 300);
  EXPECT_GT(on_robot, 1000);
  EXPECT_LT(elsewhere, 0.01 * n) << "every point is on the robot or the obstacle (tessellation within 3 mm)";
}

// a world with a box whose front face is 1 m in front of FaceCamera(), perpendicular to its optical axis, filling
// much of the image (the robot is behind the camera).
struct FlatFace : TestWorld {
  FlatFace() : TestWorld({.obstacles = {sim::ObstacleSpec::Box(Vector3d(0.1, 0.4, 0.3), Eigen::Isometry3d(
                                                                   Eigen::Translation3d(-2.1, 0.0, 0.5)))}}) {}
};
DepthCameraOptions FaceCamera() {
  DepthCameraOptions options;
  options.X_WC = LookAt(Vector3d(-1.0, 0.0, 0.5), Vector3d(-2.0, 0.0, 0.5));
  return options;
}

TEST(DepthCameraTest, NoiseHasTheModelledSpreadDropoutAndSeed) {
  FlatFace face;
  DepthCameraOptions noisy_options = FaceCamera();
  noisy_options.noise = {.sigma_at_1m = 0.002, .dropout = 0.1, .seed = 7};
  auto clean = MakeCamera(face, FaceCamera());
  CAMERA_OR_SKIP(clean);
  auto noisy = MakeCamera(face, noisy_options);
  ASSERT_NE(noisy, nullptr);
  DepthImage clean_image, noisy_image;
  // with the face at `distance`: the std of the noisy minus the clean depth (σ(z) = sigma_at_1m z²) and the
  // fraction of the face's pixels dropped
  struct Stats {
    int pixels = 0;
    double std_dev = 0.0, dropped = 0.0;
  };
  auto face_stats = [&](double distance) {
    face.world.SetObstaclePose(0, Eigen::Isometry3d(Eigen::Translation3d(-1.1 - distance, 0.0, 0.5)));
    face.world.QueryContacts();  // brings the geom poses up to date
    clean->Render(face.world.mj_data(), &clean_image);
    noisy->Render(face.world.mj_data(), &noisy_image);
    double sum = 0.0, sum_sq = 0.0;
    int kept = 0;
    Stats stats;
    for (size_t i = 0; i < clean_image.depth.size(); ++i) {
      const double z = clean_image.depth[i];
      if (z <= 0.0) continue;
      EXPECT_NEAR(z, distance, 1e-3);
      ++stats.pixels;
      if (noisy_image.depth[i] == 0.0f) continue;  // dropped
      const double r = noisy_image.depth[i] - z;
      sum += r, sum_sq += r * r, ++kept;
    }
    const double mean = sum / kept;
    EXPECT_LT(std::abs(mean), 0.05 * 0.002 * distance * distance) << "unbiased";
    stats.std_dev = std::sqrt(sum_sq / kept - mean * mean);
    stats.dropped = 1.0 - static_cast<double>(kept) / stats.pixels;
    return stats;
  };
  const Stats at_2m = face_stats(2.0), at_1m = face_stats(1.0);
  ASSERT_GT(at_2m.pixels, 4000);
  ASSERT_GT(at_1m.pixels, 15000);
  EXPECT_NEAR(at_2m.std_dev, 0.008, 0.2 * 0.008);
  EXPECT_NEAR(at_1m.std_dev, 0.002, 0.2 * 0.002);
  EXPECT_NEAR(at_1m.dropped, 0.1, 0.01);

  // the same seed gives the same frame k; another frame or another seed differs
  auto same_seed = MakeCamera(face, noisy_options);
  DepthImage again;
  same_seed->Render(face.world.mj_data(), &again);  // frame 0 of the same state: other noise
  EXPECT_NE(again.depth, noisy_image.depth);
  same_seed->Render(face.world.mj_data(), &again);  // frame 1, as noisy_image
  EXPECT_EQ(again.depth, noisy_image.depth);
  noisy_options.noise.seed = 8;
  auto other_seed = MakeCamera(face, noisy_options);
  other_seed->Render(face.world.mj_data(), &again);
  other_seed->Render(face.world.mj_data(), &again);
  EXPECT_NE(again.depth, noisy_image.depth);
}

TEST(DepthCameraTest, FaceOnTheOpticalAxisReadsItsDistanceAndRangesCut) {
  FlatFace face;
  face.world.SetObstaclePose(0, Eigen::Isometry3d(Eigen::Translation3d(-2.47, 0.0, 0.5)));  // front face at 1.37 m
  face.world.QueryContacts();
  auto render = [&](double min_range, double max_range, DepthImage* image) {
    DepthCameraOptions options = FaceCamera();
    options.min_range = min_range;
    options.max_range = max_range;
    auto camera = MakeCamera(face, options);
    if (camera != nullptr) camera->Render(face.world.mj_data(), image);
    return camera != nullptr;
  };
  DepthImage image;
  if (!render(1.3, 1.4, &image)) GTEST_SKIP() << "offscreen rendering unavailable";
  const int width = image.intrinsics.width, u0 = width / 2 - 1, v0 = image.intrinsics.height / 2 - 1;
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(image.depth[(v0 + i / 2) * width + u0 + i % 2], 1.37, 1e-3);  // the rays
  auto valid = [&] { return std::count_if(image.depth.begin(), image.depth.end(), [](float z) { return z > 0; }); };
  EXPECT_GT(valid(), 8000);
  render(0.1, 1.36, &image);
  EXPECT_EQ(valid(), 0) << "the face at 1.37 m is beyond max_range";
  render(1.38, 3.0, &image);
  EXPECT_EQ(valid(), 0) << "the face at 1.37 m is nearer than min_range";
}

TEST(DepthCameraTest, BadOptionsAreRefusedNamingTheField) {
  const DepthCameraOptions good;
  EXPECT_NO_THROW(ValidateDepthCameraOptions(good));
  const double nan = std::nan("");
  const std::vector<std::pair<std::string, std::function<void(DepthCameraOptions*)>>> spoilers = {
      {"width", [](auto* o) { o->width = 0; }},
      {"height", [](auto* o) { o->height = -3; }},
      {"vertical_fov_deg", [](auto* o) { o->vertical_fov_deg = 0.0; }},
      {"vertical_fov_deg", [](auto* o) { o->vertical_fov_deg = 180.0; }},
      {"vertical_fov_deg", [nan](auto* o) { o->vertical_fov_deg = nan; }},
      {"min_range", [](auto* o) { o->min_range = 0.0; }},
      {"max_range", [](auto* o) { o->min_range = 2.0, o->max_range = 2.0; }},
      {"X_WC", [nan](auto* o) { o->X_WC.translation().x() = nan; }},
      {"X_WC", [](auto* o) { o->X_WC.linear() *= 2.0; }},
      {"noise.dropout", [](auto* o) { o->noise.dropout = 1.0; }},
      {"noise.sigma_at_1m", [](auto* o) { o->noise.sigma_at_1m = -0.001; }},
      {"rate", [](auto* o) { o->rate = 0.0; }},
      {"rate", [](auto* o) { o->rate = -30.0; }},
  };
  for (const auto& [field, spoil] : spoilers) {
    DepthCameraOptions o = good;
    spoil(&o);
    try {
      ValidateDepthCameraOptions(o);
      ADD_FAILURE() << "accepted a bad " << field;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("DepthCameraOptions." + field + ": expected"), std::string::npos)
          << e.what();
    }
  }
  DepthCameraOptions o = good;
  // Create validates before touching EGL; the other entry points check their inputs too
  TestWorld w(sim::SceneSpec{});
  o.width = 0;
  std::string why_not;
  EXPECT_THROW(DepthCamera::Create(*w.model, o, &why_not), InputError);
  EXPECT_THROW(LookAt(Vector3d(0, 0, 1), Vector3d(0, 0, 0)), InputError);  // vertical: image up undefined
  EXPECT_THROW(LookAt(Vector3d(1, 2, 3), Vector3d(1, 2, 3)), InputError);
  DepthImage image;
  image.intrinsics = IntrinsicsFor(good);
  image.depth.assign(good.width * good.height, 1.0f);
  Eigen::Matrix3Xd p_W;
  EXPECT_THROW(DepthToWorldPoints(image, 0, &p_W), InputError);
  image.depth.pop_back();
  EXPECT_THROW(DepthToWorldPoints(image, 1, &p_W), InputError);
}

TEST(DepthCameraTest, LookAtAndIntrinsicsFollowTheOpenCvConvention) {
  const Eigen::Isometry3d X_WC = LookAt(Vector3d(1, 0, 0), Vector3d(0, 0, 0));
  EXPECT_TRUE(X_WC.linear().col(2).isApprox(Vector3d(-1, 0, 0)));  // optical axis at the target
  EXPECT_TRUE(X_WC.linear().col(1).isApprox(Vector3d(0, 0, -1)));  // image down is world down
  EXPECT_TRUE(X_WC.linear().col(0).isApprox(Vector3d(0, 1, 0)));   // right-handed
  DepthCameraOptions options;
  options.width = 640, options.height = 480, options.vertical_fov_deg = 90.0;
  const CameraIntrinsics k = IntrinsicsFor(options);
  EXPECT_TRUE(Eigen::Vector4d(k.fx, k.fy, k.cx, k.cy).isApprox(Eigen::Vector4d(240.0, 240.0, 319.5, 239.5), 1e-14));
  // stride: every other pixel in u and v of a constant 1 m image, centre column straight ahead
  DepthImage image;
  image.intrinsics = k;
  image.X_WC = X_WC;
  image.depth.assign(640 * 480, 1.0f);
  Eigen::Matrix3Xd p_W;
  EXPECT_EQ(DepthToWorldPoints(image, 2, &p_W), 320 * 240);
  EXPECT_TRUE(p_W.col(0).isApprox(X_WC * Vector3d(-319.5 / 240.0, -239.5 / 240.0, 1.0)));
}

TEST(DepthCameraTest, SetPoseMovesTheViewConsistently) {
  const Vector3d h(0.2, 0.15, 0.1);
  const Eigen::Isometry3d X_WB(Eigen::Translation3d(-2.0, 0.0, 0.3));
  sim::SceneSpec scene;
  scene.obstacles.push_back(sim::ObstacleSpec::Box(h, X_WB));
  TestWorld w(scene);
  DepthCameraOptions options;
  options.X_WC = LookAt(Vector3d(-1.2, 0.3, 1.2), X_WB.translation());
  options.max_range = 2.0;  // the robot, 2.7 m from the second pose, out of range
  auto camera = MakeCamera(w, options);
  CAMERA_OR_SKIP(camera);
  const Eigen::Isometry3d poses[2] = {options.X_WC, LookAt(Vector3d(-2.5, -0.9, 1.0), X_WB.translation())};
  DepthImage images[2];
  Eigen::Matrix3Xd p_W;
  Eigen::AlignedBox3d top_face[2];  // both views see the whole top face z = 0.4
  for (int view = 0; view < 2; ++view) {
    camera->set_pose(poses[view]);
    camera->Render(w.world.mj_data(), &images[view]);
    EXPECT_TRUE(images[view].X_WC.isApprox(poses[view]));
    const int n = DepthToWorldPoints(images[view], 1, &p_W);
    ASSERT_GT(n, 2000);
    for (int i = 0; i < n; ++i) {
      ASSERT_LT(std::abs(BoxSignedDistance(p_W.col(i), X_WB, h)), 2e-3) << "view " << view;
      if (std::abs(p_W(2, i) - 0.4) < 1e-3) top_face[view].extend(p_W.col(i));
    }
    EXPECT_LT((top_face[view].min().head<2>() - Eigen::Vector2d(-2.2, -0.15)).cwiseAbs().maxCoeff(), 0.01);
    EXPECT_LT((top_face[view].max().head<2>() - Eigen::Vector2d(-1.8, 0.15)).cwiseAbs().maxCoeff(), 0.01);
  }
  EXPECT_NE(images[0].depth, images[1].depth);
  EXPECT_THROW(camera->set_pose(Eigen::Isometry3d(Eigen::Scaling(2.0))), InputError);
}

TEST(DepthCameraTest, RenderingAndBackProjectionAllocateNothingAfterTheFirstFrame) {
  FlatFace face;
  DepthCameraOptions options = FaceCamera();
  options.noise = {.sigma_at_1m = 0.002, .dropout = 0.05};
  auto camera = MakeCamera(face, options);
  CAMERA_OR_SKIP(camera);
  DepthImage image;
  Eigen::Matrix3Xd p_W;
  camera->Render(face.world.mj_data(), &image);
  DepthToWorldPoints(image, 1, &p_W);
  const long before = rmpmarl::testing::AllocationCount();
  for (int frame = 0; frame < 3; ++frame) {
    camera->Render(face.world.mj_data(), &image);
    DepthToWorldPoints(image, 1, &p_W);
  }
  EXPECT_EQ(rmpmarl::testing::AllocationCount(), before);
  EXPECT_EQ(camera->frame_count(), 4u);
}

// sim::OffscreenRenderer terminates the process-wide EGL display when destroyed, which destroys every context on it:
// the camera makes its context again.
TEST(DepthCameraTest, KeepsWorkingBesideAnOffscreenRenderer) {
  FlatFace face;
  auto camera = MakeCamera(face, FaceCamera());
  CAMERA_OR_SKIP(camera);
  DepthImage before, image;
  camera->Render(face.world.mj_data(), &before);
  {
    std::string why_not;
    auto renderer = sim::OffscreenRenderer::Create(face.model->mj_model(), {.width = 64, .height = 48}, &why_not);
    ASSERT_NE(renderer, nullptr) << why_not;
    std::vector<std::uint8_t> rgb;
    renderer->Render(face.world.mj_data(), &rgb);
    camera->Render(face.world.mj_data(), &image);
    EXPECT_EQ(image.depth, before.depth);
    renderer->Render(face.world.mj_data(), &rgb);
  }
  camera->Render(face.world.mj_data(), &image);
  EXPECT_EQ(image.depth, before.depth);
}

}  // namespace
}  // namespace rmpmarl::perception
