// The coupled basic layer (EvaluateCoupledLayer) against independent references: RMPflow's own tree pullback and
// resolve (every weight 1 on RMPflow's structure), the per-joint layer (one joint selecting), and hand-derived
// scale invariances.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>

#include "rmp_test_util.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/rmp/joint_layer.h"
#include "rmpmarl/rmp/rmpflow.h"

namespace rmpmarl::rmp {
namespace {

using testing::RandomConfiguration;
using testing::RandomVector3;
using testing::RandomVelocity;
using testing::Uniform;

Scene RandomScene(std::mt19937_64& rng, int obstacles) {
  Scene scene;
  for (int k = 0; k < obstacles; ++k) {
    scene.obstacles.push_back(Obstacle::MakeSphere(RandomVector3(rng, -0.5, 0.5) + Eigen::Vector3d(0, 0, 0.4),
                                                   Uniform(rng, 0.03, 0.12), RandomVector3(rng, -1.0, 1.0)));
  }
  scene.p_WT = RandomVector3(rng, -0.5, 0.5) + Eigen::Vector3d(0, 0, 0.4);
  scene.v_WT = RandomVector3(rng, -0.3, 0.3);
  return scene;
}

// With every joint selecting both RMPs at unit scales, the coupled layer on RMPflow's structure is RMPflow: the
// tree's pullback of the same target and collision RMPs resolved with the same regulariser.
TEST(CoupledLayerTest, UnitWeightsOnRmpflowStructureEqualRmpflow) {
  std::mt19937_64 rng(7);
  for (const kinematics::Robot& robot : {testing::LoadArm(), testing::LoadTreeRobot()}) {
    const int nq = robot.model.nq();
    RmpflowOptions options;
    options.collision.metric_modulation_radius = 0.4;
    options.collision.repulsion_gain = 3200.0;
    options.max_acceleration_norm = 1e12;  // compare before any cap
    RmpflowPolicy rmpflow(robot, options, 4);
    RmpflowPolicy structure(robot, options, 0);
    BasicRmpParams params;
    params.target = options.target;
    params.collision = options.collision;
    const std::vector<JointLayerWeights> weights(nq);  // both RMPs, unit scales
    kinematics::Data kin(robot.model);
    CoupledLayerWorkspace workspace(nq);
    int with_collisions = 0;
    for (int trial = 0; trial < 40; ++trial) {
      const Scene scene = RandomScene(rng, 4);
      const Eigen::VectorXd q = RandomConfiguration(robot.model, rng, 0.05);
      const Eigen::VectorXd qd = RandomVelocity(robot.model, rng);
      Eigen::VectorXd expected(nq), got(nq);
      rmpflow.Evaluate(q, qd, scene, expected);
      with_collisions += rmpflow.diagnostics().active_obstacle_pairs > 0 ? 1 : 0;
      structure.EvaluateStructure(q, qd);
      kinematics::CalcVelocityKinematics(robot.model, q, qd, &kin);
      EvaluateCoupledLayer(robot, kin, scene, params, weights, structure.data().f_root, structure.data().M_root,
                           options.resolve.relative_regularizer, &workspace, got);
      ASSERT_TRUE(got.allFinite());
      EXPECT_LT((got - expected).norm(), 1e-7 * (1.0 + expected.norm())) << robot.name << " trial " << trial;
    }
    EXPECT_GT(with_collisions, 10) << "the scenes must exercise the collision leaves";
  }
}

// boards and walls (long, flat boxes, whose bounding spheres reach far beyond them) and cubes about the arm
Scene BoardScene(std::mt19937_64& rng, int obstacles) {
  Scene scene;
  for (int k = 0; k < obstacles; ++k) {
    Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
    X.linear() = Eigen::Quaterniond::UnitRandom().toRotationMatrix();
    X.translation() = RandomVector3(rng, -0.6, 0.6) + Eigen::Vector3d(0, 0, 0.4);
    const Eigen::Vector3d half = k % 2 == 0 ? Eigen::Vector3d(Uniform(rng, 0.2, 0.6), Uniform(rng, 0.2, 0.6),
                                                              Uniform(rng, 0.005, 0.02))
                                            : RandomVector3(rng, 0.03, 0.1);
    scene.obstacles.push_back(Obstacle::MakeBox(X, half, RandomVector3(rng, -0.5, 0.5)));
  }
  scene.p_WT = RandomVector3(rng, -0.5, 0.5) + Eigen::Vector3d(0, 0, 0.4);
  scene.v_WT = RandomVector3(rng, -0.3, 0.3);
  return scene;
}

// With no structure and only joint i selecting RMPs, the system decouples: q̈_i is the per-joint layer's and every
// other joint stays at rest (up to the regulariser, which differs: λ(1 + trace/n) vs λ(1 + metric_i)). The per-joint
// layer computes each pair within the bounding spheres' reach on its own (not the coupled layer's squared sphere test
// and vectorised leaves): among spheres, and among boards and walls, where most pairs the spheres let through are
// beyond the modulation radius.
TEST(CoupledLayerTest, OneSelectingJointEqualsThePerJointLayer) {
  std::mt19937_64 rng(11);
  const kinematics::Robot robot = testing::LoadArm();
  const int nq = robot.model.nq();
  kinematics::Data kin(robot.model);
  CoupledLayerWorkspace workspace(nq);
  const Eigen::VectorXd f0 = Eigen::VectorXd::Zero(nq);
  const Eigen::MatrixXd M0 = Eigen::MatrixXd::Zero(nq, nq);
  BasicRmpParams params;
  params.collision.metric_modulation_radius = 0.4;
  int boards_in_range = 0;
  for (const bool boards : {false, true}) {
    for (int trial = 0; trial < 40; ++trial) {
      const Scene scene = boards ? BoardScene(rng, 6) : RandomScene(rng, 5);
      kinematics::CalcVelocityKinematics(robot.model, RandomConfiguration(robot.model, rng),
                                         RandomVelocity(robot.model, rng), &kin);
      for (const kinematics::LinkCapsule& lc : robot.capsules) {
        for (int j = 0; boards && j < static_cast<int>(scene.obstacles.size()); j += 2) {
          const double d = CapsuleObstacleDistance(kinematics::WorldCapsule(lc, kin), scene.obstacles[j]).distance;
          boards_in_range += d > 0.0 && d <= 0.4 ? 1 : 0;
        }
      }
      const int dof = static_cast<int>(rng() % nq);
      std::vector<JointLayerWeights> weights(nq);
      for (JointLayerWeights& w : weights) w.use_target = w.use_collision = false;
      JointLayerWeights& w = weights[dof];
      w.use_target = w.use_collision = true;
      w.target_accel_scale = Uniform(rng, 0.25, 4.0);
      w.target_metric_scale = Uniform(rng, 0.25, 4.0);
      w.collision_accel_scale = Uniform(rng, 0.25, 4.0);
      w.collision_metric_scale = Uniform(rng, 0.25, 4.0);
      w.collision_length_scale = Uniform(rng, 0.5, 2.0);
      Eigen::VectorXd qdd(nq);
      EvaluateCoupledLayer(robot, kin, scene, params, weights, f0, M0, 1e-9, &workspace, qdd);
      const JointLayerResult one = EvaluateJointLayer(robot, kin, dof, scene, params, w, 1e-9);
      EXPECT_NEAR(qdd[dof], one.qdd, 1e-5 * (1.0 + std::abs(one.qdd))) << (boards ? "boards" : "spheres")
                                                                         << ", trial " << trial;
      for (int i = 0; i < nq; ++i) {
        if (i != dof) {
          EXPECT_EQ(qdd[i], 0.0);
        }
      }
    }
  }
  EXPECT_GT(boards_in_range, 60);
}

// Hand-derived: a common metric scale on every joint cancels in the resolve (no structure), and at rest (J̇q̇ = 0)
// a common target accel scale scales q̈ by itself.
TEST(CoupledLayerTest, CommonScalesActAsDerived) {
  std::mt19937_64 rng(5);
  const kinematics::Robot robot = testing::LoadArm();
  const int nq = robot.model.nq();
  kinematics::Data kin(robot.model);
  CoupledLayerWorkspace workspace(nq);
  const Eigen::VectorXd f0 = Eigen::VectorXd::Zero(nq);
  const Eigen::MatrixXd M0 = Eigen::MatrixXd::Zero(nq, nq);
  const BasicRmpParams params;
  auto solve = [&](double accel, double metric) {
    std::vector<JointLayerWeights> weights(nq);
    for (JointLayerWeights& w : weights) {
      w.use_collision = false;
      w.target_accel_scale = accel;
      w.target_metric_scale = metric;
    }
    Eigen::VectorXd qdd(nq);
    EvaluateCoupledLayer(robot, kin, RandomScene(rng, 0), params, weights, f0, M0, 1e-12, &workspace, qdd);
    return qdd;
  };
  for (int trial = 0; trial < 10; ++trial) {
    kinematics::CalcVelocityKinematics(robot.model, RandomConfiguration(robot.model, rng, 0.1),
                                       Eigen::VectorXd::Zero(nq), &kin);
    const std::mt19937_64 saved = rng;
    const Eigen::VectorXd base = solve(1.0, 1.0);
    rng = saved;
    const Eigen::VectorXd heavier = solve(1.0, 3.0);
    rng = saved;
    const Eigen::VectorXd faster = solve(2.5, 1.0);
    // the target task is 3-D on a redundant arm: compare the task-space accelerations J q̈ (the null space of the
    // singular metric is set by the tiny regulariser alone)
    const kinematics::Data& k = kin;
    const Eigen::Vector3d p_WE = k.X_WL[robot.end_effector.link] * robot.end_effector.X_LE.translation();
    Eigen::Matrix3Xd J(3, nq);
    for (int i = 0; i < nq; ++i) {
      J.col(i) = kinematics::CalcPointJacobianColumn(robot.model, k, i, robot.end_effector.link, p_WE);
    }
    const Eigen::Vector3d a = J * base;
    EXPECT_LT((J * heavier - a).norm(), 1e-6 * (1.0 + a.norm()));
    EXPECT_LT((J * faster - 2.5 * a).norm(), 1e-6 * (1.0 + a.norm()));
  }
}

// rmp.target_scale stiffness: s_a multiplies eq (5)'s attraction only, so every joint at s_a = c is the layer with
// k_p → c k_p at unit scales, on the coupled and on the per-joint resolve; at s_a = 1 both modes agree, and at s_a ≠ 1
// they differ (the damping is not scaled)
TEST(CoupledLayerTest, StiffnessScaleActsAsAScaledProportionalGain) {
  std::mt19937_64 rng(19);
  const kinematics::Robot robot = testing::LoadArm();
  const int nq = robot.model.nq();
  kinematics::Data kin(robot.model);
  CoupledLayerWorkspace workspace(nq);
  RmpflowOptions options;
  RmpflowPolicy structure(robot, options, 0);
  BasicRmpParams stiffness;
  stiffness.target = options.target;
  stiffness.target_scale = TargetScale::kStiffness;
  BasicRmpParams acceleration = stiffness;
  acceleration.target_scale = TargetScale::kAcceleration;
  double largest_mode_difference = 0.0;
  for (int trial = 0; trial < 30; ++trial) {
    const double c = Uniform(rng, 0.25, 4.0);
    BasicRmpParams stiffer = acceleration;
    stiffer.target.accel_p_gain *= c;
    std::vector<JointLayerWeights> scaled(nq), unit(nq);
    for (JointLayerWeights& w : scaled) w.target_accel_scale = c;
    const Scene scene = RandomScene(rng, 2);
    const Eigen::VectorXd q = RandomConfiguration(robot.model, rng, 0.05);
    const Eigen::VectorXd qd = RandomVelocity(robot.model, rng);
    structure.EvaluateStructure(q, qd);
    kinematics::CalcVelocityKinematics(robot.model, q, qd, &kin);
    Eigen::VectorXd got(nq), expected(nq), unscaled_damping(nq), unit_stiffness(nq), unit_acceleration(nq);
    const Eigen::VectorXd& f0 = structure.data().f_root;
    const Eigen::MatrixXd& M0 = structure.data().M_root;
    EvaluateCoupledLayer(robot, kin, scene, stiffness, scaled, f0, M0, 1e-6, &workspace, got);
    EvaluateCoupledLayer(robot, kin, scene, stiffer, unit, f0, M0, 1e-6, &workspace, expected);
    EXPECT_LT((got - expected).norm(), 1e-9 * (1.0 + expected.norm())) << "trial " << trial;
    EvaluateCoupledLayer(robot, kin, scene, acceleration, scaled, f0, M0, 1e-6, &workspace, unscaled_damping);
    largest_mode_difference = std::max(largest_mode_difference, (unscaled_damping - got).norm());
    EvaluateCoupledLayer(robot, kin, scene, stiffness, unit, f0, M0, 1e-6, &workspace, unit_stiffness);
    EvaluateCoupledLayer(robot, kin, scene, acceleration, unit, f0, M0, 1e-6, &workspace, unit_acceleration);
    EXPECT_EQ(unit_stiffness, unit_acceleration);
    // the per-joint layer, joint by joint
    for (int dof = 0; dof < nq; ++dof) {
      const JointLayerResult a = EvaluateJointLayer(robot, kin, dof, scene, stiffness, scaled[dof], 1e-6);
      const JointLayerResult b = EvaluateJointLayer(robot, kin, dof, scene, stiffer, unit[dof], 1e-6);
      EXPECT_NEAR(a.force, b.force, 1e-9 * (1.0 + std::abs(b.force))) << "trial " << trial << " joint " << dof;
      EXPECT_EQ(a.metric, b.metric);
    }
    // and the batched per-joint layer (the env's per-joint resolve)
    std::vector<JointLayerResult> batch_scaled(nq), batch_stiffer(nq);
    EvaluateJointLayers(robot, kin, scene, stiffness, scaled, batch_scaled, 1e-6);
    EvaluateJointLayers(robot, kin, scene, stiffer, unit, batch_stiffer, 1e-6);
    for (int dof = 0; dof < nq; ++dof) {
      EXPECT_NEAR(batch_scaled[dof].force, batch_stiffer[dof].force, 1e-9 * (1.0 + std::abs(batch_stiffer[dof].force)))
          << "trial " << trial << " joint " << dof;
    }
  }
  EXPECT_GT(largest_mode_difference, 1e-3);  // the two modes are different layers
}

TEST(CoupledLayerTest, RejectsWrongSizes) {
  const kinematics::Robot robot = testing::LoadArm();
  const int nq = robot.model.nq();
  kinematics::Data kin(robot.model);
  kinematics::CalcVelocityKinematics(robot.model, Eigen::VectorXd::Zero(nq), Eigen::VectorXd::Zero(nq), &kin);
  CoupledLayerWorkspace workspace(nq);
  Eigen::VectorXd qdd(nq + 1);
  EXPECT_THROW(EvaluateCoupledLayer(robot, kin, Scene{}, BasicRmpParams{}, std::vector<JointLayerWeights>(nq),
                                    Eigen::VectorXd::Zero(nq), Eigen::MatrixXd::Zero(nq, nq), 1e-6, &workspace, qdd),
               InputError);
}

// EvaluateStructure leaves the end-effector node out: its pulled-back (f, M) equal, bit for bit, those of a full
// evaluation whose scene gives that node nothing to do (no target, no obstacles); and the same policy evaluated in
// full afterwards (the node back in) gives what a fresh one gives, bit for bit.
TEST(CoupledLayerTest, StructureWithoutTheTargetNodeIsBitIdenticalAndTheFullEvaluationComesBack) {
  std::mt19937_64 rng(17);
  for (const kinematics::Robot& robot : {testing::LoadArm(), testing::LoadTreeRobot()}) {
    const int nq = robot.model.nq();
    const RmpflowOptions options;
    RmpflowPolicy structure(robot, options, 4), reference(robot, options, 0), fresh(robot, options, 4);
    Scene empty;  // no target, no obstacles
    empty.has_target = false;
    for (int trial = 0; trial < 20; ++trial) {
      const Eigen::VectorXd q = RandomConfiguration(robot.model, rng, 0.05);
      const Eigen::VectorXd qd = RandomVelocity(robot.model, rng);
      Eigen::VectorXd qdd(nq), qdd_fresh(nq);
      structure.EvaluateStructure(q, qd);
      reference.Evaluate(q, qd, empty, qdd);
      const Eigen::VectorXd f = structure.data().f_root;
      const Eigen::MatrixXd M = structure.data().M_root;
      ASSERT_TRUE(f.allFinite() && M.allFinite());
      EXPECT_EQ(std::memcmp(f.data(), reference.data().f_root.data(), sizeof(double) * nq), 0) << trial;
      EXPECT_EQ(std::memcmp(M.data(), reference.data().M_root.data(), sizeof(double) * nq * nq), 0) << trial;
      const Scene scene = RandomScene(rng, 4);
      structure.Evaluate(q, qd, scene, qdd);
      fresh.Evaluate(q, qd, scene, qdd_fresh);
      EXPECT_EQ(std::memcmp(qdd.data(), qdd_fresh.data(), sizeof(double) * nq), 0) << robot.name << " " << trial;
      EXPECT_EQ(structure.end_effector_position(), fresh.end_effector_position());
    }
  }
}

// The vectorised collision leaves (AVX2, four joints or leaves at a time) give the scalar loop's q̈, A and b up to
// rounding, on the Panda (a serial chain of revolute joints: the kernel runs where the CPU has it, which
// CollisionLeafSimdTest.KernelRunsOnEveryAvx2Machine checks) and on the tree robot (a prismatic joint: the scalar
// loop throughout), with leaves inside obstacles (d ≤ 0), batches of more than 32 leaves, joints that take no leaf,
// zero metric scales, unit and other length scales.
TEST(CoupledLayerTest, VectorisedLeavesGiveTheScalarLoopsResults) {
  std::mt19937_64 rng(23);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (const kinematics::Robot& robot : {testing::LoadArm(), testing::LoadTreeRobot()}) {
    const int nq = robot.model.nq();
    const bool panda = robot.name == "panda";
    kinematics::Data kin(robot.model);
    CoupledLayerWorkspace vectorised(nq), scalar(nq);
    scalar.vectorised = false;
    EXPECT_EQ(vectorised.robot_vectorisable(robot), panda) << robot.name;
    BasicRmpParams params;
    params.collision.metric_modulation_radius = 0.5;
    params.collision.repulsion_std_dev = 0.0283;
    params.collision.damping_std_dev = 0.1131;
    int most_leaves = 0, penetrating = 0;
    for (int trial = 0; trial < 200; ++trial) {
      Scene scene = RandomScene(rng, 1 + static_cast<int>(rng() % 8));
      for (int k = 0; k < 3; ++k) {  // boxes too, some of them on the arm
        Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
        const Eigen::Quaterniond rotation(normal(rng), normal(rng), normal(rng), normal(rng));
        X.linear() = rotation.normalized().toRotationMatrix();
        X.translation() = RandomVector3(rng, -0.4, 0.4) + Eigen::Vector3d(0, 0, 0.4);
        scene.obstacles.push_back(
            Obstacle::MakeBox(X, RandomVector3(rng, 0.02, 0.15), RandomVector3(rng, -1.0, 1.0)));
      }
      kinematics::CalcVelocityKinematics(robot.model, RandomConfiguration(robot.model, rng),
                                         RandomVelocity(robot.model, rng), &kin);
      std::vector<JointLayerWeights> weights(nq);
      for (JointLayerWeights& w : weights) {
        const int pick = static_cast<int>(rng() % 8);
        w.use_collision = pick != 0;
        w.collision_metric_scale = pick == 1 ? 0.0 : Uniform(rng, 0.25, 4.0);
        w.collision_accel_scale = Uniform(rng, 0.25, 4.0);
        w.collision_length_scale = pick == 2 ? 1.0 : std::pow(w.collision_accel_scale, 0.75);
        w.target_accel_scale = Uniform(rng, 0.25, 4.0);
        w.target_metric_scale = Uniform(rng, 0.25, 4.0);
      }
      Eigen::MatrixXd B(nq, nq);
      Eigen::VectorXd f0(nq);
      for (int i = 0; i < nq; ++i) {
        f0[i] = Uniform(rng, -1.0, 1.0);
        for (int j = 0; j < nq; ++j) B(i, j) = Uniform(rng, -1.0, 1.0);
      }
      const Eigen::MatrixXd M0 = B * B.transpose() + Eigen::MatrixXd::Identity(nq, nq);
      Eigen::VectorXd qdd_vectorised(nq), qdd_scalar(nq);
      EvaluateCoupledLayer(robot, kin, scene, params, weights, f0, M0, 1e-6, &vectorised, qdd_vectorised);
      EvaluateCoupledLayer(robot, kin, scene, params, weights, f0, M0, 1e-6, &scalar, qdd_scalar);
      ASSERT_TRUE(qdd_scalar.allFinite());
      // the same sums up to rounding (another exp, other summation orders): A and b to 1e-13 of their largest
      // entry, q̈ (through the solve) to 1e-9
      const double A_scale = 1.0 + scalar.A.cwiseAbs().maxCoeff(), b_scale = 1.0 + scalar.b.cwiseAbs().maxCoeff();
      EXPECT_LE((vectorised.A - scalar.A).cwiseAbs().maxCoeff(), 1e-13 * A_scale) << trial;
      EXPECT_LE((vectorised.b - scalar.b).cwiseAbs().maxCoeff(), 1e-13 * b_scale) << trial;
      EXPECT_LE((qdd_vectorised - qdd_scalar).norm(), 1e-9 * (1.0 + qdd_scalar.norm())) << trial;
      // the Panda's first joint moves every moving capsule: its per-joint layer counts the leaves
      std::vector<JointLayerResult> per_joint(nq);
      EvaluateJointLayers(robot, kin, scene, params, std::vector<JointLayerWeights>(nq), per_joint);
      most_leaves = std::max(most_leaves, per_joint[0].collision_terms);
      penetrating += per_joint[0].min_distance <= 0.0;
    }
    if (panda) {
      EXPECT_GT(most_leaves, 2 * CoupledLayerWorkspace::kLeafBatch) << "no trial with several batches of leaves";
      EXPECT_GT(penetrating, 5) << "too few trials with a leaf inside an obstacle";
    }
  }
}

}  // namespace
}  // namespace rmpmarl::rmp
