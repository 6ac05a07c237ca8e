// RMPflow tree: build-time structure errors, pullback/resolve against the dense least-squares form with Jacobians
// and curvature terms from finite differences, and distance task maps against finite differences.
#include "rmpmarl/rmp/tree.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "rmp_test_util.h"
#include "rmpmarl/common/error.h"

namespace rmpmarl::rmp {
namespace {

using testing::LoadTreeRobot;
using testing::RandomConfiguration;
using testing::RandomSpd;
using testing::RandomVector;
using testing::RandomVector3;
using testing::RandomVelocity;
using testing::Uniform;

// expects InputError whose message contains `fragment`
template <typename F>
void ExpectInputError(F&& f, const std::string& fragment) {
  try {
    f();
    FAIL() << "expected InputError containing '" << fragment << "'";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(TreeBuildTest, RejectsStructureErrors) {
  const kinematics::Robot robot = kinematics::MakePlanar2();
  const JointAffineMap q_map{{0, 1}, {}, {}};
  ExpectInputError([&] { Tree(robot, {{"", "", q_map}}); }, "empty name");
  ExpectInputError([&] { Tree(robot, {{"a", "", q_map}, {"a", "", q_map}}); }, "duplicate node name 'a'");
  ExpectInputError([&] { Tree(robot, {{"a", "nowhere", AffineMap{Eigen::MatrixXd::Identity(2, 2),
                                                                     Eigen::VectorXd::Zero(2)}}}); },
                   "parent 'nowhere' not found");
  const AffineMap square{Eigen::MatrixXd::Identity(2, 2), Eigen::VectorXd::Zero(2)};
  ExpectInputError([&] { Tree(robot, {{"a", "a", square}}); }, "own parent");
  ExpectInputError([&] { Tree(robot, {{"a", "b", square}, {"b", "c", square}, {"c", "a", square}}); }, "cycle");
  ExpectInputError([&] { Tree(robot, {{"q", "", q_map}, {"a", "q", AffineMap{Eigen::MatrixXd::Identity(2, 3),
                                                                             Eigen::VectorXd::Zero(2)}}}); },
                   "wrong dimensions");
  ExpectInputError([&] { Tree(robot, {{"q", "", q_map}, {"a", "q", AffineMap{Eigen::MatrixXd::Identity(2, 2),
                                                                             Eigen::VectorXd::Zero(3)}}}); },
                   "wrong dimensions");
  ExpectInputError([&] { Tree(robot, {{"a", "", AffineMap{Eigen::MatrixXd::Identity(3, 3),
                                                          Eigen::VectorXd::Zero(3)}}}); },
                   "wrong dimensions");
  ExpectInputError([&] { Tree(robot, {{"q", "", q_map}, {"p", "q", LinkPointMap{1, Eigen::Vector3d::Zero()}}}); },
                   "parent must be the root");
  ExpectInputError([&] { Tree(robot, {{"q", "", JointAffineMap{{0, 2}, {}, {}}}}); }, "dof 2 out of range");
  ExpectInputError([&] { Tree(robot, {{"q", "", JointAffineMap{{0, 1}, {1.0}, {}}}}); }, "wrong dimensions");
  ExpectInputError([&] { Tree(robot, {{"p", "", LinkPointMap{7, Eigen::Vector3d::Zero()}}}); }, "link 7");
  ExpectInputError([&] { Tree(robot, {{"d", "", CapsuleObstacleDistanceMap{5, 0, 1.0}}}); }, "capsule 5");
  ExpectInputError([&] { Tree(robot, {{"d", "", CapsuleObstacleDistanceMap{0, -1, 1.0}}}); }, "slot");
  ExpectInputError([&] { Tree(robot, {{"d", "", CapsuleObstacleDistanceMap{0, 0, 0.0}}}); }, "cutoff");
  ExpectInputError([&] { Tree(robot, {{"d", "", CapsuleCapsuleDistanceMap{1, 1, 1.0}}}); }, "same link");
}

TEST(SceneTest, ValidateSceneRejectsBadObstacles) {
  Scene scene;
  scene.obstacles.push_back(Obstacle::MakeSphere(Eigen::Vector3d(0.1, 0.2, 0.3), 0.1));
  scene.obstacles.push_back(Obstacle::MakeBox(Eigen::Isometry3d::Identity(), Eigen::Vector3d(0.1, 0.2, 0.3)));
  EXPECT_NO_THROW(ValidateScene(scene, "scene"));
  Scene bad = scene;
  bad.obstacles[0].sphere.radius = 0.0;
  ExpectInputError([&] { ValidateScene(bad, "scene"); }, "obstacles[0]");
  bad = scene;
  bad.obstacles[1].box.X_WB.linear() *= 2.0;  // not a rotation
  ExpectInputError([&] { ValidateScene(bad, "scene"); }, "obstacles[1]");
  bad = scene;
  bad.obstacles[1].v_WO.x() = NAN;
  ExpectInputError([&] { ValidateScene(bad, "scene"); }, "v_WO");
  bad = scene;
  bad.p_WT.z() = INFINITY;
  ExpectInputError([&] { ValidateScene(bad, "scene"); }, "target");
  // finite but absurd: a unit or sign error, refused with the values
  bad = scene;
  bad.p_WT.x() = 1e301;
  ExpectInputError([&] { ValidateScene(bad, "scene"); }, "target: expected a position and velocity within ±1000 m");
  bad = scene;
  bad.obstacles[0].sphere.p_WC.y() = -2e3;
  ExpectInputError([&] { ValidateScene(bad, "scene"); }, "obstacles[0]: expected a position");
  bad = scene;
  bad.obstacles[1].box.half_size.z() = 5e3;
  ExpectInputError([&] { ValidateScene(bad, "scene"); }, "size [0.1, 0.2, 5000]");
}

TEST(SceneTest, CylindersAreValidatedAndMeasuredExactly) {
  Eigen::Isometry3d X_WC = Eigen::Isometry3d::Identity();
  X_WC.linear() = Eigen::AngleAxisd(0.5 * M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();  // axis along −y
  X_WC.translation() = Eigen::Vector3d(0.5, 0.0, 0.2);
  Scene scene;
  scene.obstacles.push_back(Obstacle::MakeCylinder(X_WC, 0.05, 0.2));
  EXPECT_NO_THROW(ValidateScene(scene, "scene"));
  Scene bad = scene;
  bad.obstacles[0].cylinder.half_length = 0.0;
  ExpectInputError([&] { ValidateScene(bad, "scene"); }, "obstacles[0] (cylinder)");
  bad = scene;
  bad.obstacles[0].cylinder.X_WC.linear() *= -1.0;  // a reflection
  ExpectInputError([&] { ValidateScene(bad, "scene"); }, "rotation matrix");
  bad = scene;
  bad.obstacles[0].cylinder.radius = 2e3;
  ExpectInputError([&] { ValidateScene(bad, "scene"); }, "size [2000, 2000, 0.2]");

  // a vertical capsule above the lying cylinder: the gap is hand-derived (0.2 − 0.05 above the axis − 0.05 − 0.02)
  const math::Capsule capsule{Eigen::Vector3d(0.5, 0.1, 0.3), Eigen::Vector3d(0.5, 0.1, 0.6), 0.02};
  const math::DistanceResult d = CapsuleObstacleDistance(capsule, scene.obstacles[0]);
  EXPECT_NEAR(d.distance, 0.3 - 0.2 - 0.05 - 0.02, 1e-9);
  EXPECT_TRUE(d.n_W.isApprox(Eigen::Vector3d::UnitZ(), 1e-6));
  EXPECT_TRUE(Centre(scene.obstacles[0]).isApprox(X_WC.translation()));
  EXPECT_NEAR(BoundingRadius(scene.obstacles[0]), std::hypot(0.05, 0.2), 1e-15);
}

TEST(TreeBuildTest, OrdersParentsBeforeChildren) {
  const kinematics::Robot robot = kinematics::MakePlanar2();
  const AffineMap square{Eigen::MatrixXd::Identity(2, 2), Eigen::VectorXd::Zero(2)};
  const Tree tree(robot, {{"c", "b", square}, {"b", "a", square}, {"a", "", JointAffineMap{{0, 1}, {}, {}}}});
  EXPECT_EQ(tree.topological_order(), (std::vector<int>{2, 1, 0}));
  EXPECT_EQ(tree.FindNode("b"), 1);
  EXPECT_EQ(tree.FindNode("zz"), -1);
  EXPECT_EQ(tree.parent(0), 1);
  EXPECT_EQ(tree.parent(2), -1);
  EXPECT_EQ(tree.dim(0), 2);
}

// random tree of joint, point and affine maps (exact J̇q̇), on `robot`
std::vector<NodeSpec> RandomTree(const kinematics::Robot& robot, std::mt19937_64& rng) {
  const int nq = robot.model.nq();
  std::vector<NodeSpec> nodes;
  std::vector<int> dims;
  JointAffineMap all;
  for (int i = 0; i < nq; ++i) all.dofs.push_back(i);
  nodes.push_back({"cspace", "", all});
  dims.push_back(nq);
  const int num_points = 1 + static_cast<int>(rng() % 3);
  for (int k = 0; k < num_points; ++k) {
    const int link = 1 + static_cast<int>(rng() % (robot.model.num_links() - 1));
    nodes.push_back({fmt::format("point{}", k), "", LinkPointMap{link, RandomVector3(rng, -0.2, 0.2)}});
    dims.push_back(3);
  }
  JointAffineMap sub;
  for (int i = 0; i < nq; ++i) {
    if (rng() % 2) {
      sub.dofs.push_back(i);
      sub.scale.push_back(Uniform(rng, -2.0, 2.0));
      sub.offset.push_back(Uniform(rng, -1.0, 1.0));
    }
  }
  if (!sub.dofs.empty()) {
    nodes.push_back({"joints", "", sub});
    dims.push_back(static_cast<int>(sub.dofs.size()));
  }
  const int num_affine = 2 + static_cast<int>(rng() % 4);
  for (int k = 0; k < num_affine; ++k) {
    const int parent = static_cast<int>(rng() % nodes.size());
    const int dim = 1 + static_cast<int>(rng() % 4);
    nodes.push_back({fmt::format("affine{}", k), nodes[parent].name,
                     AffineMap{Eigen::MatrixXd::Random(dim, dims[parent]), RandomVector(dim, rng)}});
    dims.push_back(dim);
  }
  std::shuffle(nodes.begin(), nodes.end(), rng);  // the description need not be in order
  return nodes;
}

// x of every node at configuration q (velocity zero)
std::vector<Eigen::VectorXd> NodeValues(const Tree& tree, TreeData* data, const Eigen::VectorXd& q) {
  PushForward(tree, q, Eigen::VectorXd::Zero(tree.nq()), Scene{}, data);
  std::vector<Eigen::VectorXd> x;
  for (int i = 0; i < tree.num_nodes(); ++i) x.push_back(data->x(i));
  return x;
}

TEST(TreeEvaluationTest, PullbackAndResolveMatchDenseLeastSquaresOnRandomTrees) {
  std::mt19937_64 rng(21);
  const std::vector<kinematics::Robot> robots = {LoadTreeRobot(), kinematics::MakePlanar2()};
  int checked = 0;
  for (const kinematics::Robot& robot : robots) {
    const int nq = robot.model.nq();
    for (int trial = 0; trial < 40; ++trial) {
      const Tree tree(robot, RandomTree(robot, rng));
      TreeData data(tree);
      const Eigen::VectorXd q = RandomConfiguration(robot.model, rng);
      const Eigen::VectorXd qd = RandomVelocity(robot.model, rng);
      // full Jacobian of every node by central differences, J̇q̇ by a second difference along q̇
      const double h = 1e-6, h2 = 1e-4;
      std::vector<Eigen::MatrixXd> J_full(tree.num_nodes());
      for (int i = 0; i < tree.num_nodes(); ++i) J_full[i].resize(tree.dim(i), nq);
      for (int j = 0; j < nq; ++j) {
        Eigen::VectorXd dq = Eigen::VectorXd::Zero(nq);
        dq[j] = h;
        const auto plus = NodeValues(tree, &data, q + dq);
        const auto minus = NodeValues(tree, &data, q - dq);
        for (int i = 0; i < tree.num_nodes(); ++i) J_full[i].col(j) = (plus[i] - minus[i]) / (2.0 * h);
      }
      const auto x0 = NodeValues(tree, &data, q);
      const auto xp = NodeValues(tree, &data, q + h2 * qd);
      const auto xm = NodeValues(tree, &data, q - h2 * qd);
      // random RMPs on every node (leaves and inner nodes alike)
      PushForward(tree, q, qd, Scene{}, &data);
      Eigen::VectorXd f_dense = Eigen::VectorXd::Zero(nq);
      Eigen::MatrixXd M_dense = Eigen::MatrixXd::Zero(nq, nq);
      for (int i = 0; i < tree.num_nodes(); ++i) {
        const Eigen::VectorXd f = RandomVector(tree.dim(i), rng);
        const Eigen::MatrixXd M = RandomSpd(tree.dim(i), rng);
        data.f(i) = f;
        data.M(i) = M;
        const Eigen::VectorXd jdqd = (xp[i] - 2.0 * x0[i] + xm[i]) / (h2 * h2);
        // the pushforward itself: ẋ = J q̇ and the curvature term composed through the chain
        EXPECT_LT((data.xd(i) - J_full[i] * qd).cwiseAbs().maxCoeff(), 1e-6) << tree.name(i);
        f_dense += J_full[i].transpose() * (f - M * jdqd);
        M_dense += J_full[i].transpose() * M * J_full[i];
      }
      Eigen::VectorXd qdd(nq);
      PullbackAndResolve(tree, &data, qdd);
      EXPECT_LT((data.M_root - M_dense).cwiseAbs().maxCoeff(), 1e-6 * (1.0 + M_dense.cwiseAbs().maxCoeff()));
      EXPECT_LT((data.f_root - f_dense).cwiseAbs().maxCoeff(), 1e-4 * (1.0 + f_dense.cwiseAbs().maxCoeff()));
      const double lambda = 1e-6 * (1.0 + M_dense.trace() / nq);
      const Eigen::VectorXd expected =
          (M_dense + lambda * Eigen::MatrixXd::Identity(nq, nq)).ldlt().solve(f_dense);
      EXPECT_LT((qdd - expected).norm(), 1e-4 * (1.0 + expected.norm()));
      ++checked;
    }
  }
  EXPECT_EQ(checked, 80);
}

// a scene around the tree robot: spheres and boxes at random places within ~0.6 m of its base
Scene RandomScene(std::mt19937_64& rng, int count, bool moving) {
  Scene scene;
  for (int k = 0; k < count; ++k) {
    const Eigen::Vector3d p = RandomVector3(rng, -0.5, 0.5) + Eigen::Vector3d(0.0, 0.0, 0.5);
    const Eigen::Vector3d v = moving ? RandomVector3(rng, -0.5, 0.5) : Eigen::Vector3d::Zero();
    if (k % 2 == 0) {
      scene.obstacles.push_back(Obstacle::MakeSphere(p, Uniform(rng, 0.03, 0.15), v));
    } else {
      Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
      X.linear() = Eigen::Quaterniond::UnitRandom().toRotationMatrix();
      X.translation() = p;
      scene.obstacles.push_back(Obstacle::MakeBox(X, RandomVector3(rng, 0.03, 0.12), v));
    }
  }
  return scene;
}

// the scene moved by time t along its obstacles' velocities
Scene Advance(const Scene& scene, double t) {
  Scene moved = scene;
  for (Obstacle& o : moved.obstacles) {
    o.sphere.p_WC += t * o.v_WO;
    o.box.X_WB.translation() += t * o.v_WO;
  }
  return moved;
}

TEST(TreeEvaluationTest, DistanceMapsMatchFiniteDifferences) {
  const kinematics::Robot robot = LoadTreeRobot();
  const int nq = robot.model.nq();
  std::vector<NodeSpec> specs;
  const int num_obstacles = 4;
  for (int c = 0; c < static_cast<int>(robot.capsules.size()); ++c) {
    for (int s = 0; s < num_obstacles; ++s) {
      specs.push_back({fmt::format("o{}_{}", c, s), "", CapsuleObstacleDistanceMap{c, s}});
    }
    for (int c2 = c + 1; c2 < static_cast<int>(robot.capsules.size()); ++c2) {
      if (robot.capsules[c].link == robot.capsules[c2].link) continue;
      specs.push_back({fmt::format("s{}_{}", c, c2), "", CapsuleCapsuleDistanceMap{c, c2}});
    }
  }
  const Tree tree(robot, specs);
  TreeData data(tree), probe(tree);
  std::mt19937_64 rng(22);
  int checked = 0, penetrating = 0;
  for (int trial = 0; trial < 150; ++trial) {
    const Scene scene = RandomScene(rng, num_obstacles, /*moving=*/true);
    const Eigen::VectorXd q = RandomConfiguration(robot.model, rng);
    const Eigen::VectorXd qd = RandomVelocity(robot.model, rng);
    PushForward(tree, q, qd, scene, &data);
    const double h = 1e-6;
    Eigen::MatrixXd J_fd(tree.num_nodes(), nq);
    for (int j = 0; j < nq; ++j) {
      Eigen::VectorXd dq = Eigen::VectorXd::Zero(nq);
      dq[j] = h;
      PushForward(tree, q + dq, qd, scene, &probe);
      for (int i = 0; i < tree.num_nodes(); ++i) J_fd(i, j) = probe.x(i)[0];
      PushForward(tree, q - dq, qd, scene, &probe);
      for (int i = 0; i < tree.num_nodes(); ++i) J_fd(i, j) = (J_fd(i, j) - probe.x(i)[0]) / (2.0 * h);
    }
    // total time derivative of the distance with the robot moving along q̇ and the obstacles along their velocity
    PushForward(tree, q + h * qd, qd, Advance(scene, h), &probe);
    Eigen::VectorXd xd_fd(tree.num_nodes());
    for (int i = 0; i < tree.num_nodes(); ++i) xd_fd[i] = probe.x(i)[0];
    PushForward(tree, q - h * qd, qd, Advance(scene, -h), &probe);
    for (int i = 0; i < tree.num_nodes(); ++i) xd_fd[i] = (xd_fd[i] - probe.x(i)[0]) / (2.0 * h);
    for (int i = 0; i < tree.num_nodes(); ++i) {
      ASSERT_TRUE(data.active(i));
      const math::DistanceResult& res = data.distance(i);
      // J = g nᵀ J_WP1 agrees with the finite-difference gradient (where the distance is differentiable:
      // skip the rare configurations whose one-sided differences disagree, i.e. kinks of the witness choice)
      const Eigen::RowVectorXd J = data.J(i);
      const double scale = 1.0 + J_fd.row(i).cwiseAbs().maxCoeff();
      if ((J - J_fd.row(i)).cwiseAbs().maxCoeff() > 1e-5 * scale) {
        ADD_FAILURE() << tree.name(i) << " trial " << trial << " d=" << res.distance << " g=" << res.gradient_norm
                      << "\nJ    " << J << "\nJ_fd " << J_fd.row(i);
        continue;
      }
      if (res.distance < 0.0) ++penetrating;
      // ẋ = J q̇ − g nᵀ v_obstacle, and the finite-difference total derivative
      double expected_xd = J.dot(qd);
      if (tree.type(i) == TaskMapType::kCapsuleObstacleDistance) {
        const int slot = std::get<CapsuleObstacleDistanceMap>(tree.map(i)).obstacle;
        expected_xd -= res.gradient_norm * res.n_W.dot(scene.obstacles[slot].v_WO);
      }
      EXPECT_NEAR(data.xd(i)[0], expected_xd, 1e-12 * (1.0 + std::abs(expected_xd)));
      EXPECT_NEAR(data.xd(i)[0], xd_fd[i], 1e-5 * (1.0 + std::abs(expected_xd))) << tree.name(i);
      ++checked;
    }
  }
  EXPECT_GT(checked, 1000);
  EXPECT_GT(penetrating, 10);  // the random scenes exercise the penetrating branch as well
}

TEST(TreeEvaluationTest, DistanceNodesWithinTheCutoffAreActiveAtTheirExactDistance) {
  // every capsule against boards and walls (long, flat boxes, whose bounding spheres reach far beyond them), cubes
  // and spheres: a node is active exactly when the exact distance is within the cutoff, and then holds that distance
  // bit for bit; an inactive node holds a lower bound beyond the cutoff
  const kinematics::Robot robot = LoadTreeRobot();
  constexpr double kCutoff = 0.3;
  std::mt19937_64 rng(31);
  std::vector<NodeSpec> specs;
  constexpr int kObstacles = 6;
  for (int c = 0; c < static_cast<int>(robot.capsules.size()); ++c) {
    for (int j = 0; j < kObstacles; ++j) {
      specs.push_back({fmt::format("c{}o{}", c, j), "", CapsuleObstacleDistanceMap{c, j, kCutoff}});
    }
  }
  const Tree tree(robot, specs);
  TreeData data(tree);
  int active = 0, skipped_near_box = 0, skipped_by_sphere = 0;
  for (int trial = 0; trial < 100; ++trial) {
    Scene scene;
    for (int j = 0; j < kObstacles; ++j) {
      Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
      X.linear() = Eigen::Quaterniond::UnitRandom().toRotationMatrix();
      X.translation() = RandomVector3(rng, -0.6, 0.6) + Eigen::Vector3d(0.0, 0.0, 0.5);
      if (j % 3 == 0) {
        scene.obstacles.push_back(Obstacle::MakeBox(
            X, Eigen::Vector3d(Uniform(rng, 0.2, 0.6), Uniform(rng, 0.2, 0.6), Uniform(rng, 0.005, 0.02))));
      } else if (j % 3 == 1) {
        scene.obstacles.push_back(Obstacle::MakeBox(X, RandomVector3(rng, 0.03, 0.12)));
      } else {
        scene.obstacles.push_back(Obstacle::MakeSphere(X.translation(), Uniform(rng, 0.03, 0.15)));
      }
    }
    const Eigen::VectorXd q = RandomConfiguration(robot.model, rng);
    PushForward(tree, q, RandomVelocity(robot.model, rng), scene, &data);
    for (int i = 0; i < tree.num_nodes(); ++i) {
      const auto& map = std::get<CapsuleObstacleDistanceMap>(tree.map(i));
      const double d = CapsuleObstacleDistance(kinematics::WorldCapsule(robot.capsules[map.capsule], data.kinematics),
                                               scene.obstacles[map.obstacle]).distance;
      if (d <= kCutoff) {
        ASSERT_TRUE(data.active(i)) << "trial " << trial << ", node " << i << ", distance " << d;
        ASSERT_EQ(data.x(i)[0], d);
        ++active;
      } else {
        ASSERT_FALSE(data.active(i));
        ASSERT_GT(data.x(i)[0], kCutoff);
        ASSERT_LE(data.x(i)[0], d + 1e-12);
        // a board's bounding sphere let the pair through to the exact distance, or skipped it with a lower bound
        skipped_near_box += scene.obstacles[map.obstacle].shape == ObstacleShape::kBox && d < 2.0 * kCutoff ? 1 : 0;
        skipped_by_sphere += data.x(i)[0] < d ? 1 : 0;
      }
    }
  }
  EXPECT_GT(active, 200);
  EXPECT_GT(skipped_near_box, 200);
  EXPECT_GT(skipped_by_sphere, 200);  // the broad phase skipped pairs (their x a bound below the distance)
}

TEST(TreeEvaluationTest, DistanceNodesAreInactiveForEmptySlotsAndBeyondTheCutoff) {
  const kinematics::Robot robot = kinematics::MakePlanar2();  // links along x in the z = 0 plane
  const Tree tree(robot, {{"near", "", CapsuleObstacleDistanceMap{1, 0, 0.5}},
                          {"far", "", CapsuleObstacleDistanceMap{1, 1, 0.5}},
                          {"empty", "", CapsuleObstacleDistanceMap{1, 2, 0.5}}});
  TreeData data(tree);
  Scene scene;
  scene.obstacles.push_back(Obstacle::MakeSphere({0.75, 0.3, 0.0}, 0.1));  // 0.3 − 0.04 − 0.1 = 0.16 from link 2
  scene.obstacles.push_back(Obstacle::MakeSphere({0.75, 3.0, 0.0}, 0.1));  // 2.86 away
  PushForward(tree, Eigen::Vector2d::Zero(), Eigen::Vector2d(0.0, 1.0), scene, &data);
  EXPECT_TRUE(data.active(0));
  EXPECT_NEAR(data.x(0)[0], 0.16, 1e-12);
  // link 2 turns about (0.5, 0, 0) at 1 rad/s: its point (0.75, 0.04, 0) moves at (0, 0.25, 0) toward the sphere
  EXPECT_NEAR(data.xd(0)[0], -0.25, 1e-12);
  EXPECT_FALSE(data.active(1));
  EXPECT_GT(data.x(1)[0], 0.5);
  EXPECT_LE(data.x(1)[0], 2.86 + 1e-12);  // a lower bound of the distance
  EXPECT_FALSE(data.active(2));
  Eigen::VectorXd qdd(2);
  data.f(0)[0] = 1.0;
  data.M(0)(0, 0) = 1.0;
  data.f(1)[0] = 1e9;  // inactive nodes are not pulled back, whatever they hold
  PullbackAndResolve(tree, &data, qdd);
  EXPECT_TRUE(qdd.allFinite());
  // J = nᵀ J_WP1 with n = (0, −1, 0): joint 1 moves the witness (0.75, 0.04, 0) at (−0.04, 0.75, 0) per rad/s
  EXPECT_NEAR(data.J(0)(0, 0), -0.75, 1e-12);
  EXPECT_NEAR(data.J(0)(0, 1), -0.25, 1e-12);
  // J̇q̇ = nᵀ(centripetal acceleration −ω² (0.25, 0.04, 0)) = 0.04
  EXPECT_NEAR(data.Jdot_qd(0)[0], 0.04, 1e-12);
  EXPECT_NEAR(data.f_root[1], -0.25 * (1.0 - 0.04), 1e-12);
  EXPECT_NEAR(data.M_root(1, 1), 0.0625, 1e-12);
}

}  // namespace
}  // namespace rmpmarl::rmp
