// World behaviour: servo tracking, the servos' inverse-dynamics feed-forward against MuJoCo's forward dynamics, model
// sharing, split stepping vs mj_step, input checks and NaN reporting.
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <gtest/gtest.h>
#include <mujoco/mjxmacro.h>
#include <mujoco/mujoco.h>

#include <cmath>
#include <cstddef>
#include <cstring>
#include <random>
#include <string>
#include <type_traits>

#include "rmpmarl/common/error.h"
#include "rmpmarl/sim/world.h"
#include "sim_test_util.h"

namespace rmpmarl::sim {
namespace {

// the robot of the dynamic tests: the paper's Panda.
kinematics::Robot ArmForDynamics() { return kinematics::LoadShippedRobot("panda"); }

// a configuration inside the limits, `fraction` of the way from the lower to the upper limit (continuous: ±pi).
Eigen::VectorXd Within(const WorldModel& wm, double fraction) {
  Eigen::VectorXd q(wm.nq());
  for (int i = 0; i < wm.nq(); ++i) {
    const double lo = std::isfinite(wm.lower_limits()[i]) ? wm.lower_limits()[i] : -M_PI;
    const double hi = std::isfinite(wm.upper_limits()[i]) ? wm.upper_limits()[i] : M_PI;
    q[i] = lo + fraction * (hi - lo);
  }
  return q;
}

TEST(WorldTest, ServoTracksAStepCommand) {
  // documented: with the default servo (ω_n = 40 rad/s, ζ = 1) a 0.3 rad step on every joint settles to 1e-3 rad
  // within 0.4 s of simulated time (critically damped: (1 + ω t) e^{−ω t} · 0.3 < 1e-3 at t ≈ 0.2 s for the
  // reference inertia; the configuration-dependent inertia and coupling leave some slack).
  constexpr double kSettleTime = 0.4;
  constexpr double kStep = 0.3;
  for (const kinematics::Robot& robot : {ArmForDynamics(), kinematics::MakePlanar2()}) {
    SCOPED_TRACE(robot.name);
    auto wm = std::make_shared<const WorldModel>(robot);
    World world(wm);
    const Eigen::VectorXd q0 = Within(*wm, 0.4);
    world.Reset(q0);
    Eigen::VectorXd q_cmd = q0;
    for (int i = 0; i < wm->nq(); ++i) {
      const double span = std::min(wm->upper_limits()[i] - wm->lower_limits()[i], 2 * M_PI);
      q_cmd[i] += std::min(kStep, 0.3 * span);
    }
    world.SetJointTargets(q_cmd);
    double settled_at = -1.0;
    const int steps = static_cast<int>(std::lround(1.0 / wm->options().timestep));
    for (int s = 0; s < steps; ++s) {
      ASSERT_TRUE(world.Step().ok);
      const double err = (world.q() - q_cmd).cwiseAbs().maxCoeff();
      if (err < 1e-3 && settled_at < 0.0) settled_at = world.time();
      if (err >= 1e-3) settled_at = -1.0;  // must stay settled
    }
    fmt::print("  {}: |q − q_cmd| < 1e-3 rad from t = {:.3f} s on (max final error {:.1e})\n", robot.name, settled_at,
               (world.q() - q_cmd).cwiseAbs().maxCoeff());
    EXPECT_GE(settled_at, 0.0);
    EXPECT_LE(settled_at, kSettleTime);
    EXPECT_LT((world.q() - q_cmd).cwiseAbs().maxCoeff(), 1e-5);
  }
}

// the acceleration one physics step gives the world's state under its current targets, (q̇' − q̇) / h, from
// MuJoCo's own mj_step2 on a copy of its data (the integrator's, implicit or not)
Eigen::VectorXd StepAcceleration(const World& world) {
  const mjModel* m = world.mj_model();
  mjData* d = mj_makeData(m);
  mj_copyData(d, m, world.mj_data());
  mj_step2(m, d);
  Eigen::VectorXd qdd(world.nq());
  for (int i = 0; i < world.nq(); ++i) {
    const int v = world.model().dof_vel_adr(i);
    qdd[i] = (d->qvel[v] - world.mj_data()->qvel[v]) / m->opt.timestep;
  }
  mj_deleteData(d);
  return qdd;
}

TEST(WorldTest, InverseDynamicsFeedForwardGivesTheCommandedAcceleration) {
  // on the commanded state (q = q_cmd, q̇ = q̇_cmd), targets q_cmd + (d/kp) q̇_cmd with the feed-forward make the servo
  // torque M(q) q̈_cmd + c(q, q̇) + h D q̈_cmd: MuJoCo's own step (joint damping D implicit) then accelerates the arm at
  // q̈_cmd, whatever the posture, velocity and commanded acceleration (random draws) — exactly with the Euler
  // integrator, to the Coriolis forces' velocity derivative (which the implicit one also integrates; measured ≤ 0.7 %
  // at |q̇| ≤ 1.5 rad/s) with the default; without it, the PD alone is off by more than 5 rad/s² (measured: ~20)
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (const kinematics::Robot& robot : {ArmForDynamics(), kinematics::MakePlanar2()}) {
    for (const Integrator integrator : {Integrator::kImplicit, Integrator::kEuler}) {
      const std::string name = fmt::format("{}, {}", robot.name, integrator == Integrator::kImplicit ? "implicit" : "Euler");
      SCOPED_TRACE(name);
      WorldOptions with, without;
      with.warning_margin = without.warning_margin = 0.0;
      with.integrator = without.integrator = integrator;
      with.servo.inverse_dynamics_feedforward = true;
      auto wm = std::make_shared<const WorldModel>(robot, SceneSpec{}, with);
      auto wm_off = std::make_shared<const WorldModel>(robot, SceneSpec{}, without);
      ASSERT_EQ(wm->servo_gains().kp, wm_off->servo_gains().kp);
      World world(wm), world_off(wm_off);
      const Eigen::VectorXd ff = wm->servos().feedforward;  // d / kp
      double worst = 0.0, off_error = 0.0;
      for (int draw = 0; draw < 20; ++draw) {
        const Eigen::VectorXd q = Within(*wm, 0.5 + 0.3 * unit(rng));
        Eigen::VectorXd qd(wm->nq()), qdd(wm->nq());
        for (int i = 0; i < wm->nq(); ++i) {
          qd[i] = 1.5 * unit(rng);
          qdd[i] = 20.0 * unit(rng);
        }
        const Eigen::VectorXd target = q + ff.cwiseProduct(qd);
        world.Reset(q, qd);
        world.SetJointTargets(target, qdd);
        EXPECT_EQ(world.joint_targets(), target);  // the command, without the offset
        worst = std::max(worst, (StepAcceleration(world) - qdd).cwiseAbs().maxCoeff() / qdd.cwiseAbs().maxCoeff());
        world_off.Reset(q, qd);
        world_off.SetJointTargets(target, qdd);  // the acceleration is ignored: the same as without it
        EXPECT_EQ(world_off.joint_targets(), target);
        off_error = std::max(off_error, (StepAcceleration(world_off) - qdd).cwiseAbs().maxCoeff());
      }
      fmt::print("  {}: |q̈ − q̈_cmd| / |q̈_cmd| ≤ {:.1e} with the feed-forward; without it |q̈ − q̈_cmd| up to {:.1f} "
                 "rad/s²\n", name, worst, off_error);
      EXPECT_LT(worst, integrator == Integrator::kEuler ? 1e-8 : 0.01);
      EXPECT_GT(off_error, 5.0);
    }
  }
}

TEST(WorldTest, InverseDynamicsFeedForwardTracksAnAcceleratingCommand) {
  // a smooth command with accelerations of ~10 rad/s² (q_d = q0 + A (1 − cos ω t)) given as targets q_d + (d/kp)
  // q̇_d at every physics step: the PD alone trails it by about M q̈ / kp, the feed-forward leaves a fraction of that
  const kinematics::Robot robot = ArmForDynamics();
  double max_error[2] = {0.0, 0.0};
  for (int on = 0; on < 2; ++on) {
    WorldOptions options;
    options.warning_margin = 0.0;
    options.servo.inverse_dynamics_feedforward = on == 1;
    auto wm = std::make_shared<const WorldModel>(robot, SceneSpec{}, options);
    World world(wm);
    const Eigen::VectorXd q0 = Within(*wm, 0.4), ff = wm->servos().feedforward;
    const double A = 0.25, w = 2.0 * M_PI;  // 1 Hz: |q̈| up to A ω² ≈ 9.9 rad/s²
    world.Reset(q0);
    const int steps = static_cast<int>(std::lround(1.0 / wm->options().timestep));
    for (int s = 0; s < steps; ++s) {
      const double t = world.time();
      const Eigen::VectorXd q_d = q0 + Eigen::VectorXd::Constant(wm->nq(), A * (1.0 - std::cos(w * t)));
      const Eigen::VectorXd qd_d = Eigen::VectorXd::Constant(wm->nq(), A * w * std::sin(w * t));
      const Eigen::VectorXd qdd_d = Eigen::VectorXd::Constant(wm->nq(), A * w * w * std::cos(w * t));
      world.SetJointTargets(q_d + ff.cwiseProduct(qd_d), qdd_d);
      ASSERT_TRUE(world.Step().ok);
      const double t1 = world.time();
      const Eigen::VectorXd q_next = q0 + Eigen::VectorXd::Constant(wm->nq(), A * (1.0 - std::cos(w * t1)));
      max_error[on] = std::max(max_error[on], (world.q() - q_next).cwiseAbs().maxCoeff());
    }
  }
  fmt::print("  panda, 1 Hz sway of 0.25 rad on every joint: max |q − q_d| {:.4f} rad with the PD alone, {:.4f} rad "
             "with the feed-forward\n", max_error[0], max_error[1]);
  EXPECT_GT(max_error[0], 2e-3);
  EXPECT_LT(max_error[1], 0.2 * max_error[0]);
}

TEST(WorldTest, FeedForwardTargetsAreClampedAndADivergenceRestoresTheCommand) {
  // near a limit the offset target is clamped to it (the feed-forward cut); joint_targets() keeps the command; after a
  // divergence the servos get the command back, without the offset
  WorldOptions options;
  options.warning_margin = 0.0;
  options.servo.inverse_dynamics_feedforward = true;
  auto wm = std::make_shared<const WorldModel>(kinematics::MakePlanar2(), SceneSpec{}, options);
  World world(wm);
  const Eigen::Vector2d q_cmd(wm->upper_limits()[0] - 0.01, 0.2), qdd(1000.0, 0.0);
  world.Reset(q_cmd);
  world.SetJointTargets(q_cmd, qdd);
  EXPECT_EQ(world.joint_targets(), q_cmd);
  EXPECT_EQ(world.mj_data()->ctrl[wm->dof_actuator(0)], wm->upper_limits()[0]);  // 1000 rad/s² ≫ 0.01 rad × kp / M
  const Eigen::Vector2d q_low(0.3, wm->lower_limits()[1] + 0.01), qdd_low(0.0, -1000.0);
  world.SetJointTargets(q_low, qdd_low);
  EXPECT_EQ(world.mj_data()->ctrl[wm->dof_actuator(1)], wm->lower_limits()[1]);
  // at rest with no acceleration asked, the targets are the commands
  world.SetJointTargets(q_low, Eigen::Vector2d::Zero());
  for (int i = 0; i < 2; ++i) EXPECT_EQ(world.mj_data()->ctrl[wm->dof_actuator(i)], q_low[i]);
}

TEST(WorldTest, TargetsAreClampedToTheJointLimits) {
  auto wm = std::make_shared<const WorldModel>(kinematics::MakePlanar2());
  World world(wm);
  world.SetJointTargets(Eigen::Vector2d(10.0, -10.0));
  EXPECT_EQ(world.joint_targets()[0], 3.0);
  EXPECT_EQ(world.joint_targets()[1], -3.0);
  EXPECT_EQ(world.mj_data()->ctrl[wm->dof_actuator(0)], 3.0);
}

TEST(WorldTest, WorldsSharingAModelAreIdenticalAndIndependent) {
  const kinematics::Robot robot = ArmForDynamics();
  SceneSpec scene;
  scene.obstacles = {ObstacleSpec::Cube(0.1), ObstacleSpec::Cube(0.1)};
  auto wm = std::make_shared<const WorldModel>(robot, scene);
  World a(wm), b(wm), c(wm);
  EXPECT_EQ(a.mj_model(), b.mj_model());  // one mjModel
  std::mt19937_64 rng(3);
  const Eigen::VectorXd q0 = testing::RandomConfiguration(robot.model, rng);
  for (World* w : {&a, &b, &c}) w->Reset(q0);
  c.SetObstaclePose(0, Eigen::Vector3d(0.4, 0.1, 0.3), testing::RandomRotation(rng));  // only c
  std::vector<Eigen::VectorXd> targets;
  for (int k = 0; k < 20; ++k) targets.push_back(testing::RandomConfiguration(robot.model, rng));
  for (int k = 0; k < 20; ++k) {
    a.SetJointTargets(targets[k]);
    ASSERT_TRUE(a.Step(10).ok);
    // c runs different commands in between; b steps after it.
    c.SetJointTargets(targets[(k + 7) % 20]);
    c.Step(5);
    c.QueryContacts();
    b.SetJointTargets(targets[k]);
    ASSERT_TRUE(b.Step(10).ok);
    ASSERT_EQ(a.q(), b.q()) << "step " << k;  // bitwise identical
    ASSERT_EQ(a.qd(), b.qd());
    EXPECT_EQ(a.time(), b.time());
  }
  EXPECT_NE(a.q(), c.q());
  EXPECT_TRUE(a.ObstaclePose(0).isApprox(ParkedPose()));
}

TEST(WorldTest, SplitStepEqualsMujocosStep) {
  // independent reference: a bare mjData stepped with mj_step under the same controls.
  for (Integrator integrator : {Integrator::kImplicit, Integrator::kEuler}) {
    WorldOptions options;
    options.integrator = integrator;
    const kinematics::Robot robot = testing::LoadTreeRobot();
    auto wm = std::make_shared<const WorldModel>(robot, SceneSpec{}, options);
    World world(wm);
    std::unique_ptr<mjData, void (*)(mjData*)> ref(mj_makeData(wm->mj_model()), mj_deleteData);
    std::mt19937_64 rng(5);
    const Eigen::VectorXd q0 = testing::RandomConfiguration(robot.model, rng);
    world.Reset(q0);
    for (int i = 0; i < wm->nq(); ++i) {
      ref->qpos[wm->dof_qpos_adr(i)] = q0[i];
      ref->ctrl[wm->dof_actuator(i)] = q0[i];
    }
    for (int k = 0; k < 10; ++k) {
      const Eigen::VectorXd q_cmd = testing::RandomConfiguration(robot.model, rng);
      world.SetJointTargets(q_cmd);
      for (int i = 0; i < wm->nq(); ++i) ref->ctrl[wm->dof_actuator(i)] = q_cmd[i];
      for (int s = 0; s < 20; ++s) {
        world.Step();
        mj_step(wm->mj_model(), ref.get());
      }
      for (int i = 0; i < wm->nq(); ++i) {
        ASSERT_EQ(world.q()[i], ref->qpos[wm->dof_qpos_adr(i)]) << "integrator " << int(integrator);  // bitwise
        ASSERT_EQ(world.qd()[i], ref->qvel[wm->dof_vel_adr(i)]);
      }
    }
  }
}

// the names of the mjData arrays whose bytes differ between a and b (MuJoCo's own list of them)
std::vector<std::string> DifferingArrays(const mjModel* m, const mjData* a, const mjData* b) {
  std::vector<std::string> differ;
  MJDATA_POINTERS_PREAMBLE(m)
#define X(type, name, nr, nc)                                                                              \
  if (!std::is_same_v<type, mjContact> && std::memcmp(a->name, b->name, sizeof(type) * (m->nr) * (nc)) != 0) { \
    differ.push_back(#name);                                                                                 \
  }
  MJDATA_POINTERS
#undef X
  if (a->ncon != b->ncon) differ.push_back("ncon");
  // a contact's fields, not the struct's trailing padding (which MuJoCo leaves as it finds it)
  constexpr size_t kContactBytes = offsetof(mjContact, efc_address) + sizeof(int);
  for (int c = 0; c < m->nconmax; ++c) {
    if (std::memcmp(a->contact + c, b->contact + c, kContactBytes) != 0) {
      differ.push_back(fmt::format("contact {}", c));
      break;
    }
  }
  return differ;
}

// the arm with three obstacles (mocap bodies), contacts for touching pairs only (as in the tasks' worlds)
std::shared_ptr<const WorldModel> ArmWithObstacles(Integrator integrator) {
  SceneSpec scene;
  scene.obstacles = {ObstacleSpec::Cube(0.12), ObstacleSpec::Sphere(0.06), ObstacleSpec::Cube(0.05)};
  WorldOptions options;
  options.integrator = integrator;
  options.warning_margin = 0.0;
  return std::make_shared<const WorldModel>(ArmForDynamics(), scene, options);
}

// every obstacle to within 8 cm per axis of a random link's origin, at a random rotation
void MoveOntoRandomLinks(World& world, std::mt19937_64& rng) {
  const WorldModel& wm = world.model();
  std::uniform_int_distribution<int> link(1, wm.robot().model.num_links() - 1);
  std::uniform_real_distribution<double> offset(-0.08, 0.08);
  for (int j = 0; j < wm.num_obstacles(); ++j) {
    const double* x = world.mj_data()->xpos + 3 * wm.link_body(link(rng));
    world.SetObstaclePose(j, Eigen::Vector3d(x[0] + offset(rng), x[1] + offset(rng), x[2] + offset(rng)),
                          testing::RandomRotation(rng));
  }
}

TEST(WorldTest, AMovedObstacleGivesTheStateOfAWholeMjStep1) {
  // World recomputes after a mocap move only what reads mocap poses; independent reference: a copy of its mjData
  // through the whole mj_step1. Obstacles are moved onto the arm's links (contacts and constraints change) and away.
  for (Integrator integrator : {Integrator::kImplicit, Integrator::kEuler}) {
    const auto wm = ArmWithObstacles(integrator);
    const kinematics::Robot& robot = wm->robot();
    World world(wm);
    const mjModel* m = wm->mj_model();
    std::unique_ptr<mjData, void (*)(mjData*)> ref(mj_makeData(m), mj_deleteData);
    std::mt19937_64 rng(11);
    world.Reset(testing::RandomConfiguration(robot.model, rng));
    std::uniform_real_distribution<double> offset(-0.08, 0.08);
    int with_contacts = 0, clear_moves = 0;
    for (int k = 0; k < 60; ++k) {
      world.SetJointTargets(testing::RandomConfiguration(robot.model, rng));
      ASSERT_TRUE(world.Step(3).ok);
      MoveOntoRandomLinks(world, rng);
      auto expect_whole_step1 = [&](const char* what) {
        mj_copyData(ref.get(), m, world.mj_data());
        mj_step1(m, ref.get());
        world.QueryContacts();  // brings the world's mjData up to date
        const std::vector<std::string> differ = DifferingArrays(m, world.mj_data(), ref.get());
        EXPECT_TRUE(differ.empty()) << what << ", move " << k << ": " << fmt::format("{}", fmt::join(differ, ", "));
      };
      expect_whole_step1("onto the arm");
      const int ncon_onto = world.mj_data()->ncon;
      // and away again, so that the arm steps on freely
      for (int j = 0; j < wm->num_obstacles(); ++j) world.SetObstaclePose(j, ParkedPose());
      expect_whole_step1("parked");
      with_contacts += ncon_onto > world.mj_data()->ncon ? 1 : 0;
      // moved in the open, from a state without contacts (the contacts need not be computed again)
      world.SetJointTargets(world.q());
      ASSERT_TRUE(world.Step(1).ok);
      if (world.QueryContacts().colliding_pairs.empty() && world.mj_data()->ncon == 0) {
        ++clear_moves;
        for (int j = 0; j < wm->num_obstacles(); ++j) {
          world.SetObstaclePose(j, Eigen::Vector3d(1.5 + 0.4 * j, offset(rng), 0.5 + offset(rng)),
                                testing::RandomRotation(rng));
        }
        expect_whole_step1("in the open");
      }
      if (HasFailure()) return;
    }
    EXPECT_GE(with_contacts, 20);  // the moves did put obstacles on the arm (contacts with them)
    EXPECT_GE(clear_moves, 20);
  }
}

TEST(WorldTest, AStepAfterAnObstacleMoveIsMjStep1ThenMjStep) {
  // World::Step skips the pass over the moved mocap poses where mj_step2 does not read them (no contact before,
  // none possible after the move). Independent reference: a copy of the mjData before the move through the whole
  // pipeline, mj_step1 (the pass) then mj_step2 and mj_step1. Moves in the open (the pass skipped) and onto the
  // arm's links (the pass needed: contacts appear), both integrators.
  for (Integrator integrator : {Integrator::kImplicit, Integrator::kEuler}) {
    const auto wm = ArmWithObstacles(integrator);
    const kinematics::Robot& robot = wm->robot();
    World world(wm);
    const mjModel* m = wm->mj_model();
    std::unique_ptr<mjData, void (*)(mjData*)> ref(mj_makeData(m), mj_deleteData);
    std::mt19937_64 rng(17);
    world.Reset(testing::RandomConfiguration(robot.model, rng));
    std::uniform_real_distribution<double> offset(-0.08, 0.08);
    int open_moves = 0, contact_moves = 0;
    long skipped = 0;
    for (int k = 0; k < 80; ++k) {
      world.SetJointTargets(testing::RandomConfiguration(robot.model, rng));
      ASSERT_TRUE(world.Step(2).ok);
      const bool onto = k % 2 == 0;
      if (onto) {
        MoveOntoRandomLinks(world, rng);
      } else {
        for (int j = 0; j < wm->num_obstacles(); ++j) {
          world.SetObstaclePose(j, Eigen::Vector3d(1.5 + 0.4 * j, offset(rng), 0.5 + offset(rng)),
                                testing::RandomRotation(rng));
        }
      }
      mj_copyData(ref.get(), m, world.mj_data());  // before the move's pass: mocap poses set, the rest not
      mj_step1(m, ref.get());
      const int ncon_after_move = ref->ncon;
      mj_step2(m, ref.get());
      mj_step1(m, ref.get());
      const bool open = world.mj_data()->ncon == 0 && ncon_after_move == 0;
      const long skipped_before = world.skipped_mocap_passes();
      ASSERT_TRUE(world.Step(1).ok);
      const long skipped_now = world.skipped_mocap_passes() - skipped_before;
      EXPECT_TRUE(open || skipped_now == 0) << "the pass was skipped where contacts came with the move, move " << k;
      skipped += skipped_now;
      const std::vector<std::string> differ = DifferingArrays(m, world.mj_data(), ref.get());
      EXPECT_TRUE(differ.empty()) << (onto ? "onto the arm" : "in the open") << ", move " << k << ": "
                                  << fmt::format("{}", fmt::join(differ, ", "));
      open_moves += open ? 1 : 0;
      contact_moves += ncon_after_move > 0 ? 1 : 0;
      if (HasFailure()) return;
      // park them again so that the arm moves on freely
      for (int j = 0; j < wm->num_obstacles(); ++j) world.SetObstaclePose(j, ParkedPose());
    }
    EXPECT_GE(open_moves, 20);     // moves that need no pass
    EXPECT_GE(skipped, 20);        // and the World did without it
    EXPECT_GE(contact_moves, 15);  // the pass was needed
  }
}

TEST(WorldTest, ResetKeepsTheSceneAndSetsTheState) {
  SceneSpec scene;
  scene.obstacles = {ObstacleSpec::Sphere(0.05)};
  auto wm = std::make_shared<const WorldModel>(kinematics::MakePlanar2(), scene);
  World world(wm);
  world.SetObstaclePose(0, Eigen::Vector3d(1.0, 2.0, 3.0), Eigen::Matrix3d::Identity());
  world.SetTargetPosition(Eigen::Vector3d(0.3, 0.4, 0.0));
  world.SetJointTargets(Eigen::Vector2d(1.0, 1.0));
  world.Step(50);
  world.Reset(Eigen::Vector2d(0.5, -0.5), Eigen::Vector2d(0.1, 0.2));
  EXPECT_EQ(world.time(), 0.0);
  EXPECT_EQ(world.q(), Eigen::Vector2d(0.5, -0.5));
  EXPECT_EQ(world.qd(), Eigen::Vector2d(0.1, 0.2));
  EXPECT_EQ(world.joint_targets(), Eigen::Vector2d(0.5, -0.5));
  EXPECT_EQ(world.ObstaclePose(0).translation(), Eigen::Vector3d(1.0, 2.0, 3.0));
  EXPECT_EQ(world.TargetPosition(), Eigen::Vector3d(0.3, 0.4, 0.0));
  const int body = wm->obstacle_body(0);
  EXPECT_EQ(world.mj_data()->xpos[3 * body + 2], 3.0);  // mjData's kinematics are current after Reset
}

template <typename F>
void ExpectInputError(F&& f, std::initializer_list<std::string> needles) {
  try {
    f();
    ADD_FAILURE() << "expected InputError";
  } catch (const InputError& e) {
    for (const std::string& needle : needles) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << "'" << needle << "' not in: " << e.what();
    }
  }
}

TEST(WorldTest, BadInputThrowsInputErrorWithClearMessages) {
  SceneSpec scene;
  scene.obstacles = {ObstacleSpec::Cube(0.1)};
  auto wm = std::make_shared<const WorldModel>(kinematics::MakePlanar2(), scene);
  World world(wm);
  ExpectInputError([&] { world.SetJointTargets(Eigen::Vector3d(0, 0, 0)); }, {"q_cmd", "expected 2", "got 3"});
  ExpectInputError([&] { world.SetJointTargets(Eigen::Vector2d(0, std::nan(""))); }, {"q_cmd", "joint2", "finite"});
  ExpectInputError([&] { world.SetJointTargets(Eigen::Vector2d(INFINITY, 0)); }, {"q_cmd", "finite"});
  ExpectInputError([&] { world.SetJointTargets(Eigen::Vector2d(0, 0), Eigen::Vector3d(0, 0, 0)); },
                   {"qdd_cmd", "expected 2", "got 3"});
  ExpectInputError([&] { world.SetJointTargets(Eigen::Vector2d(0, 0), Eigen::Vector2d(NAN, 0)); },
                   {"qdd_cmd", "finite"});
  ExpectInputError([&] { world.Reset(Eigen::VectorXd::Zero(1)); }, {"q0", "expected 2"});
  ExpectInputError([&] { world.Reset(Eigen::Vector2d(0.0, 3.5)); }, {"q0[1]", "[-3, 3]", "3.5"});
  ExpectInputError([&] { world.Reset(Eigen::Vector2d(0, 0), Eigen::Vector2d(0, NAN)); }, {"qd0", "finite"});
  ExpectInputError([&] { world.SetObstaclePose(1, Eigen::Isometry3d::Identity()); }, {"[0, 1)", "got 1"});
  ExpectInputError([&] { world.SetObstaclePose(0, Eigen::Vector3d(NAN, 0, 0), Eigen::Matrix3d::Identity()); },
                   {"finite"});
  ExpectInputError([&] { world.SetObstaclePose(0, Eigen::Vector3d::Zero(), 2.0 * Eigen::Matrix3d::Identity()); },
                   {"rotation"});
  ExpectInputError([&] { world.SetTargetPosition(Eigen::Vector3d(0, NAN, 0)); }, {"finite"});
  ExpectInputError([&] { world.Step(0); }, {"num_steps", "got 0"});
  ExpectInputError([&] { World w(nullptr); }, {"null"});
  // a failed call leaves the world as it was.
  EXPECT_EQ(world.joint_targets(), Eigen::Vector2d(0, 0));
  EXPECT_TRUE(world.Step().ok);
}

int g_mujoco_warnings = 0;

TEST(WorldTest, DivergenceIsReportedNotPropagated) {
  // capture MuJoCo's warning text (its default handler prints it and appends to MUJOCO_LOG.TXT in the working
  // directory); restored on exit.
  struct WarningCapture {
    void (*previous)(const char*) = mju_user_warning;
    WarningCapture() {
      g_mujoco_warnings = 0;
      mju_user_warning = [](const char*) { ++g_mujoco_warnings; };
    }
    ~WarningCapture() { mju_user_warning = previous; }
  } capture;
  // an absurd explicit servo with the explicit integrator blows up within a few steps.
  WorldOptions options;
  options.integrator = Integrator::kEuler;
  options.servo.kp = Eigen::Vector2d(1e12, 1e12);
  options.servo.damping = Eigen::Vector2d(0.0, 0.0);
  options.servo.armature = 0.0;
  options.servo.inverse_dynamics_feedforward = true;  // the reset restores the command, not the offset target
  SceneSpec scene;
  scene.obstacles = {ObstacleSpec::Cube(0.1, Eigen::Isometry3d(Eigen::Translation3d(2.0, 0.0, 0.0)))};
  auto wm = std::make_shared<const WorldModel>(kinematics::MakePlanar2(), scene, options);
  World world(wm);
  world.SetJointTargets(Eigen::Vector2d(1.0, -1.0), Eigen::Vector2d(50.0, -50.0));
  ASSERT_NE(world.mj_data()->ctrl[wm->dof_actuator(0)], 1.0);  // offset by the feed-forward
  StepResult result;
  int steps = 0;
  for (; steps < 1000 && result.ok; ++steps) result = world.Step();
  ASSERT_FALSE(result.ok) << "no divergence detected in 1000 steps";
  EXPECT_NE(result.issue, StepIssue::kNone);
  EXPECT_TRUE(result.state_was_reset);
  EXPECT_TRUE(world.q().allFinite());
  EXPECT_TRUE(world.qd().allFinite());
  EXPECT_EQ(world.ObstaclePose(0).translation(), Eigen::Vector3d(2.0, 0.0, 0.0));  // scene kept
  EXPECT_EQ(world.mj_data()->mocap_pos[3 * wm->obstacle_mocap(0)], 2.0);
  EXPECT_EQ(world.mj_data()->ctrl[wm->dof_actuator(0)], 1.0);  // the command back, without the offset
  EXPECT_EQ(world.mj_data()->ctrl[wm->dof_actuator(1)], -1.0);
  EXPECT_GE(g_mujoco_warnings, 1);
  fmt::print("  diverged after {} steps, issue {}\n", steps, static_cast<int>(result.issue));
  // the world is usable again after a Reset.
  world.Reset(Eigen::Vector2d(0.0, 0.0));
  world.SetJointTargets(Eigen::Vector2d(0.0, 0.0));
  EXPECT_TRUE(world.Step().ok);
}

}  // namespace
}  // namespace rmpmarl::sim
