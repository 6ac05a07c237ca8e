// The basic layer at one joint against the scalar formula (Σ j_iᵀ(f − M J̇q̇))/(Σ j_iᵀ M j_i + λ), with j_i the dof's
// column of the task Jacobians computed independently by an rmp::Tree.
#include "rmpmarl/rmp/joint_layer.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <random>

#include "rmp_test_util.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/rmp/tree.h"

namespace rmpmarl::rmp {
namespace {

using testing::RandomConfiguration;
using testing::RandomVector3;
using testing::RandomVelocity;
using testing::Uniform;

// q̈_i by the scalar formula from a tree holding the end-effector point and every capsule × obstacle distance
JointLayerResult ScalarFormula(const kinematics::Robot& robot, const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                               int dof, const Scene& scene, const BasicRmpParams& params,
                               const JointLayerWeights& w) {
  std::vector<NodeSpec> specs = {{"ee", "", LinkPointMap{robot.end_effector.link,
                                                          robot.end_effector.X_LE.translation()}}};
  for (int c = 0; c < static_cast<int>(robot.capsules.size()); ++c) {
    for (int s = 0; s < static_cast<int>(scene.obstacles.size()); ++s) {
      specs.push_back({fmt::format("d{}_{}", c, s), "", CapsuleObstacleDistanceMap{c, s}});
    }
  }
  const Tree tree(robot, specs);
  TreeData data(tree);
  PushForward(tree, q, qd, scene, &data);
  JointLayerResult r;
  if (w.use_target && scene.has_target) {
    const Rmp3 rmp = EvalTargetRmp(params.target, data.x(0), Eigen::Vector3d(data.xd(0)) - scene.v_WT, scene.p_WT);
    const Eigen::Matrix3d M = w.target_metric_scale * rmp.M;
    const Eigen::Vector3d f = M * (w.target_accel_scale * rmp.a);
    const Eigen::Vector3d j = data.J(0).col(dof);
    r.force += j.dot(f - M * Eigen::Vector3d(data.Jdot_qd(0)));
    r.metric += j.dot(M * j);
  }
  if (w.use_collision) {
    for (int i = 1; i < tree.num_nodes(); ++i) {
      const int capsule = std::get<CapsuleObstacleDistanceMap>(tree.map(i)).capsule;
      if (!robot.model.DofMovesLink(dof, robot.capsules[capsule].link)) continue;
      const double x = data.x(i)[0];
      if (x > params.collision.metric_modulation_radius) continue;
      const Rmp1 rmp = EvalCollisionRmp(params.collision, x, data.xd(i)[0]);
      const double m = w.collision_metric_scale * rmp.m;
      const double f = m * w.collision_accel_scale * rmp.a;
      const double j = data.J(i)(0, dof);
      r.force += j * (f - m * data.Jdot_qd(i)[0]);
      r.metric += j * m * j;
      ++r.collision_terms;
    }
  }
  r.lambda = 1e-6 * (1.0 + r.metric);
  r.qdd = r.force / (r.metric + r.lambda);
  return r;
}

TEST(JointLayerTest, MatchesTheScalarPullbackFormula) {
  std::mt19937_64 rng(41);
  const std::vector<kinematics::Robot> robots = {testing::LoadArm(), testing::LoadTreeRobot(),
                                                 kinematics::MakePlanar2()};
  int collision_terms = 0, checked = 0;
  for (const kinematics::Robot& robot : robots) {
    kinematics::Data kin(robot.model);
    for (int trial = 0; trial < 60; ++trial) {
      Scene scene;
      for (int k = 0; k < 4; ++k) {
        const Eigen::Vector3d p = RandomVector3(rng, -0.6, 0.6) + Eigen::Vector3d(0.0, 0.0, 0.4);
        const Eigen::Vector3d v = RandomVector3(rng, -0.3, 0.3);
        if (k % 2) {
          scene.obstacles.push_back(Obstacle::MakeSphere(p, Uniform(rng, 0.03, 0.1), v));
        } else {
          Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
          X.linear() = Eigen::Quaterniond::UnitRandom().toRotationMatrix();
          X.translation() = p;
          scene.obstacles.push_back(Obstacle::MakeBox(X, RandomVector3(rng, 0.02, 0.1), v));
        }
      }
      scene.p_WT = RandomVector3(rng, -0.5, 0.5);
      scene.v_WT = RandomVector3(rng, -0.2, 0.2);
      BasicRmpParams params;
      params.target.damping = trial % 2 ? TargetDamping::kLinear : TargetDamping::kQuadratic;
      JointLayerWeights w;
      w.use_target = trial % 5 != 1;
      w.use_collision = trial % 5 != 2;
      w.target_accel_scale = Uniform(rng, 0.0, 2.0);
      w.target_metric_scale = Uniform(rng, 0.0, 2.0);
      w.collision_accel_scale = Uniform(rng, 0.0, 2.0);
      w.collision_metric_scale = Uniform(rng, 0.0, 2.0);
      const Eigen::VectorXd q = RandomConfiguration(robot.model, rng);
      const Eigen::VectorXd qd = RandomVelocity(robot.model, rng);
      kinematics::CalcVelocityKinematics(robot.model, q, qd, &kin);
      for (int dof = 0; dof < robot.model.nq(); ++dof) {
        const JointLayerResult got = EvaluateJointLayer(robot, kin, dof, scene, params, w);
        const JointLayerResult expected = ScalarFormula(robot, q, qd, dof, scene, params, w);
        const double tol = 1e-9 * (1.0 + std::abs(expected.force) + std::abs(expected.metric));
        EXPECT_NEAR(got.force, expected.force, tol);
        EXPECT_NEAR(got.metric, expected.metric, tol);
        EXPECT_NEAR(got.qdd, expected.qdd, 1e-8 * (1.0 + std::abs(expected.qdd)));
        EXPECT_EQ(got.collision_terms, expected.collision_terms);
        EXPECT_TRUE(std::isfinite(got.qdd));
        collision_terms += got.collision_terms;
        ++checked;
      }
    }
  }
  EXPECT_GT(collision_terms, 100);
  EXPECT_GT(checked, 500);
}

TEST(JointLayerTest, AllJointsAtOnceEqualsOneJointAtATime) {
  std::mt19937_64 rng(42);
  for (const kinematics::Robot& robot : {testing::LoadArm(), testing::LoadTreeRobot()}) {
    kinematics::Data kin(robot.model);
    const int nq = robot.model.nq();
    for (int trial = 0; trial < 30; ++trial) {
      Scene scene;
      for (int k = 0; k < 6; ++k) {
        scene.obstacles.push_back(Obstacle::MakeSphere(RandomVector3(rng, -0.6, 0.6) + Eigen::Vector3d(0, 0, 0.4),
                                                       Uniform(rng, 0.03, 0.15), RandomVector3(rng, -0.3, 0.3)));
      }
      scene.p_WT = RandomVector3(rng, -0.5, 0.5);
      std::vector<JointLayerWeights> weights(nq);
      for (JointLayerWeights& w : weights) {
        w.use_target = rng() % 4 != 0;
        w.use_collision = rng() % 4 != 0;
        w.target_accel_scale = Uniform(rng, 0.0, 2.0);
        w.collision_metric_scale = Uniform(rng, 0.0, 2.0);
      }
      kinematics::CalcVelocityKinematics(robot.model, RandomConfiguration(robot.model, rng),
                                         RandomVelocity(robot.model, rng), &kin);
      std::vector<JointLayerResult> all(nq);
      EvaluateJointLayers(robot, kin, scene, BasicRmpParams{}, weights, all);
      for (int dof = 0; dof < nq; ++dof) {
        const JointLayerResult one = EvaluateJointLayer(robot, kin, dof, scene, BasicRmpParams{}, weights[dof]);
        EXPECT_NEAR(all[dof].qdd, one.qdd, 1e-9 * (1.0 + std::abs(one.qdd)));
        EXPECT_NEAR(all[dof].metric, one.metric, 1e-9 * (1.0 + one.metric));
        EXPECT_EQ(all[dof].collision_terms, one.collision_terms);
        EXPECT_EQ(all[dof].min_distance, one.min_distance);
      }
    }
    std::vector<JointLayerResult> wrong(nq + 1);
    EXPECT_THROW(EvaluateJointLayers(robot, kin, Scene{}, BasicRmpParams{}, std::vector<JointLayerWeights>(nq), wrong),
                 InputError);
  }
}

TEST(JointLayerTest, CollisionLengthScaleEqualsScaledRmpLengthScales) {
  // s_l multiplies l_p and l_d of eq (8): the layer with weights s_l must equal the scalar formula on parameters
  // whose repulsion_std_dev and damping_std_dev are multiplied by s_l (and s_l = 1), one joint and all at once
  std::mt19937_64 rng(43);
  const kinematics::Robot robot = testing::LoadArm();
  kinematics::Data kin(robot.model);
  const int nq = robot.model.nq();
  int compared = 0, changed = 0;
  for (int trial = 0; trial < 40; ++trial) {
    Scene scene;
    for (int k = 0; k < 4; ++k) {
      scene.obstacles.push_back(Obstacle::MakeSphere(RandomVector3(rng, -0.5, 0.5) + Eigen::Vector3d(0, 0, 0.4),
                                                     Uniform(rng, 0.05, 0.2), RandomVector3(rng, -2.0, 2.0)));
    }
    scene.p_WT = RandomVector3(rng, -0.5, 0.5);
    BasicRmpParams params;
    params.collision.metric_modulation_radius = 0.35;
    const Eigen::VectorXd q = RandomConfiguration(robot.model, rng);
    const Eigen::VectorXd qd = RandomVelocity(robot.model, rng);
    kinematics::CalcVelocityKinematics(robot.model, q, qd, &kin);
    std::vector<JointLayerWeights> weights(nq);
    for (JointLayerWeights& w : weights) {
      w.use_target = rng() % 3 == 0;
      w.collision_accel_scale = Uniform(rng, 0.25, 4.0);
      w.collision_length_scale = rng() % 4 == 0 ? 1.0 : Uniform(rng, 0.3, 3.0);
    }
    std::vector<JointLayerResult> all(nq);
    EvaluateJointLayers(robot, kin, scene, params, weights, all);
    for (int dof = 0; dof < nq; ++dof) {
      BasicRmpParams scaled = params;
      scaled.collision.repulsion_std_dev *= weights[dof].collision_length_scale;
      scaled.collision.damping_std_dev *= weights[dof].collision_length_scale;
      JointLayerWeights unit = weights[dof];
      unit.collision_length_scale = 1.0;
      const JointLayerResult expected = ScalarFormula(robot, q, qd, dof, scene, scaled, unit);
      const JointLayerResult one = EvaluateJointLayer(robot, kin, dof, scene, params, weights[dof]);
      const double tol = 1e-8 * (1.0 + std::abs(expected.qdd));
      EXPECT_NEAR(one.qdd, expected.qdd, tol);
      EXPECT_NEAR(all[dof].qdd, expected.qdd, tol);
      EXPECT_EQ(one.collision_terms, expected.collision_terms);
      ++compared;
      const JointLayerResult plain = ScalarFormula(robot, q, qd, dof, scene, params, unit);
      if (expected.collision_terms > 0 && std::abs(plain.qdd - expected.qdd) > 1e-6 * (1.0 + std::abs(plain.qdd))) {
        ++changed;
      }
    }
  }
  EXPECT_EQ(compared, 40 * nq);
  EXPECT_GT(changed, 20);  // the scale acts (it is not silently ignored)
}

TEST(JointLayerTest, PlanarArmTargetOnlyByHand) {
  // planar2 at q = (0, π/2), q̇ = 0: end effector at (0.5, 0.5, 0); joint 2's column is ẑ × (0, 0.5, 0) = (−0.5, 0, 0)
  const kinematics::Robot robot = kinematics::MakePlanar2();
  kinematics::Data kin(robot.model);
  kinematics::CalcVelocityKinematics(robot.model, Eigen::Vector2d(0.0, M_PI / 2), Eigen::Vector2d::Zero(), &kin);
  Scene scene;
  scene.p_WT = Eigen::Vector3d(0.2, 0.5, 0.0);  // 0.3 in −x from the end effector
  const BasicRmpParams params;
  const JointLayerResult r = EvaluateJointLayer(robot, kin, 1, scene, params, JointLayerWeights{});
  const Rmp3 rmp = EvalTargetRmp(params.target, Eigen::Vector3d(0.5, 0.5, 0.0), Eigen::Vector3d::Zero(), scene.p_WT);
  const Eigen::Vector3d j(-0.5, 0.0, 0.0);
  const double metric = j.dot(rmp.M * j);
  EXPECT_NEAR(r.force, j.dot(rmp.M * rmp.a), 1e-9);
  EXPECT_NEAR(r.metric, metric, 1e-9);
  // target straight along −x = +j direction: q̈ = a_x/(−0.5) up to the regulariser, and positive
  EXPECT_NEAR(r.qdd, rmp.a.x() / -0.5 * metric / (metric + 1e-6 * (1.0 + metric)), 1e-9);
  EXPECT_GT(r.qdd, 0.0);
  // nothing selected: zero, not NaN
  const JointLayerResult none =
      EvaluateJointLayer(robot, kin, 1, scene, params, JointLayerWeights{.use_target = false, .use_collision = false});
  EXPECT_EQ(none.qdd, 0.0);
}

}  // namespace
}  // namespace rmpmarl::rmp
