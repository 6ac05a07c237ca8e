// The generated MJCF against independent references: rmpmarl's forward
// kinematics vs MuJoCo's own (mj_kinematics), capsule end points vs MuJoCo's
// geoms, and the model settings the conventions promise (docs/sim.md).
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <memory>

#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/sim/world.h"
#include "sim_test_util.h"

namespace rmpmarl::sim {
namespace {

using DataPtr = std::unique_ptr<mjData, void (*)(mjData *)>;

DataPtr MakeData(const mjModel *m) {
  return DataPtr(mj_makeData(m), mj_deleteData);
}

TEST(MjcfTest, ForwardKinematicsMatchesMujocoForEveryRobot) {
  constexpr int kConfigurations = 200;
  constexpr double kTolerance = 1e-9;
  double worst_body = 0.0, worst_capsule = 0.0;
  for (const kinematics::Robot &robot : testing::AllSimTestRobots()) {
    SCOPED_TRACE(robot.name);
    const WorldModel world_model(robot);
    const mjModel *m = world_model.mj_model();
    DataPtr d = MakeData(m);
    kinematics::Data kin(robot.model);
    std::mt19937_64 rng(20240611);
    double robot_body = 0.0, robot_capsule = 0.0;
    for (int s = 0; s < kConfigurations; ++s) {
      const Eigen::VectorXd q = testing::RandomConfiguration(robot.model, rng);
      for (int i = 0; i < robot.model.nq(); ++i)
        d->qpos[world_model.dof_qpos_adr(i)] = q[i];
      mj_kinematics(m, d.get());
      kinematics::CalcForwardKinematics(robot.model, q, &kin);
      for (int k = 0; k < robot.model.num_links(); ++k) {
        const int b = world_model.link_body(k);
        const Eigen::Map<const Eigen::Vector3d> p_WL(d->xpos + 3 * b);
        const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>
            R_WL(d->xmat + 9 * b);
        const double err =
            std::max((p_WL - kin.X_WL[k].translation()).cwiseAbs().maxCoeff(),
                     (R_WL - kin.X_WL[k].linear()).cwiseAbs().maxCoeff());
        robot_body = std::max(robot_body, err);
        ASSERT_LT(err, kTolerance)
            << "link " << robot.model.link(k).name << " at sample " << s;
      }
      for (size_t c = 0; c < robot.capsules.size(); ++c) {
        const kinematics::LinkCapsule &cap = robot.capsules[c];
        const int g = world_model.capsule_geom(static_cast<int>(c));
        const Eigen::Map<const Eigen::Vector3d> p_WG(d->geom_xpos + 3 * g);
        const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>
            R_WG(d->geom_xmat + 9 * g);
        // a MuJoCo capsule is centred on its frame, along its z axis, with half
        // length size[1]; MuJoCo 2.2.2 points the z axis of a fromto capsule
        // from `to` (B) towards `from` (A).
        const double half =
            m->geom_type[g] == mjGEOM_CAPSULE ? m->geom_size[3 * g + 1] : 0.0;
        const Eigen::Vector3d p_WA = p_WG + half * R_WG.col(2);
        const Eigen::Vector3d p_WB = p_WG - half * R_WG.col(2);
        const double err = std::max(
            (p_WA - kin.X_WL[cap.link] * cap.p_LA).cwiseAbs().maxCoeff(),
            (p_WB - kin.X_WL[cap.link] * cap.p_LB).cwiseAbs().maxCoeff());
        robot_capsule = std::max(robot_capsule, err);
        ASSERT_LT(err, kTolerance) << "capsule " << c << " at sample " << s;
        EXPECT_EQ(m->geom_size[3 * g], cap.radius);
      }
    }
    fmt::print("  {:>10}: {} links, {} capsules, max |FK − MuJoCo| bodies "
               "{:.2e}, capsule ends {:.2e}\n",
               robot.name, robot.model.num_links(), robot.capsules.size(),
               robot_body, robot_capsule);
    worst_body = std::max(worst_body, robot_body);
    worst_capsule = std::max(worst_capsule, robot_capsule);
  }
  RecordProperty("max_body_error", fmt::format("{:.3e}", worst_body));
  RecordProperty("max_capsule_error", fmt::format("{:.3e}", worst_capsule));
}

TEST(MjcfTest, ModelFollowsTheConventions) {
  SceneSpec scene;
  scene.obstacles = {ObstacleSpec::Cube(0.1), ObstacleSpec::Sphere(0.05)};
  scene.has_floor = true;
  WorldOptions options;
  options.warning_margin = 0.12;
  const WorldModel wm(testing::LoadTreeRobot(), scene, options);
  const mjModel *m = wm.mj_model();
  EXPECT_EQ(m->opt.gravity[0], 0.0);
  EXPECT_EQ(m->opt.gravity[1], 0.0);
  EXPECT_EQ(m->opt.gravity[2], 0.0);
  EXPECT_EQ(m->opt.timestep, 0.002);
  EXPECT_EQ(m->opt.integrator, mjINT_IMPLICIT);
  EXPECT_EQ(m->nu, wm.nq());
  EXPECT_EQ(m->nmocap, 3);
  for (size_t c = 0; c < wm.robot().capsules.size(); ++c) {
    const int g = wm.capsule_geom(static_cast<int>(c));
    EXPECT_EQ(m->geom_margin[g], 0.12);
    EXPECT_EQ(m->geom_gap[g], 0.12);
  }
  EXPECT_EQ(m->geom_contype[wm.target_geom()], 0);
  EXPECT_EQ(m->geom_conaffinity[wm.target_geom()], 0);
  EXPECT_EQ(m->geom_type[wm.obstacle_geom(0)], mjGEOM_BOX);
  EXPECT_EQ(m->geom_size[3 * wm.obstacle_geom(0)], 0.05);
  EXPECT_EQ(m->geom_type[wm.obstacle_geom(1)], mjGEOM_SPHERE);
  EXPECT_EQ(m->geom_type[wm.floor_geom()], mjGEOM_PLANE);
  for (int i = 0; i < wm.nq(); ++i) {
    const int a = wm.dof_actuator(i);
    EXPECT_EQ(m->actuator_gainprm[a * mjNGAIN], wm.servo_gains().kp[i]);
    EXPECT_EQ(m->actuator_biasprm[a * mjNBIAS + 1], -wm.servo_gains().kp[i]);
    EXPECT_EQ(m->dof_damping[wm.dof_vel_adr(i)], wm.servo_gains().damping[i]);
    EXPECT_GT(wm.servo_gains().kp[i], 0.0);
    const kinematics::Link &link =
        wm.robot().model.link(wm.robot().model.dof_link(i));
    if (link.joint_type == kinematics::JointType::kContinuous) {
      EXPECT_EQ(m->actuator_ctrllimited[a], 0);
      EXPECT_EQ(m->jnt_limited[m->dof_jntid[wm.dof_vel_adr(i)]], 0);
    } else {
      EXPECT_EQ(m->actuator_ctrllimited[a], 1);
      EXPECT_EQ(m->actuator_ctrlrange[2 * a],
                wm.robot().model.limits()[i].lower);
      EXPECT_EQ(m->actuator_ctrlrange[2 * a + 1],
                wm.robot().model.limits()[i].upper);
    }
  }
  // the generated text is deterministic: the same inputs give the same MJCF.
  EXPECT_EQ(wm.mjcf(),
            WorldModel(testing::LoadTreeRobot(), scene, options).mjcf());
}

TEST(MjcfTest, ServoGainsAreCriticallyDampedForTheReferenceInertia) {
  const kinematics::Robot robot = kinematics::MakePlanar2();
  WorldOptions options;
  const WorldModel wm(robot, {}, options);
  // independent reference: M_ii at q_ref = 0 from mj_fullM of the compiled
  // model.
  const mjModel *m = wm.mj_model();
  DataPtr d = MakeData(m);
  mj_forward(m, d.get());
  std::vector<double> M(m->nv * m->nv);
  mj_fullM(m, M.data(), d->qM);
  const double w = options.servo.natural_frequency;
  for (int i = 0; i < wm.nq(); ++i) {
    const int v = wm.dof_vel_adr(i);
    const double Mii = M[v * m->nv + v];
    EXPECT_NEAR(wm.servo_gains().kp[i], w * w * Mii, 1e-9 * w * w * Mii);
    EXPECT_NEAR(wm.servo_gains().damping[i], 2.0 * w * Mii, 1e-9 * w * Mii);
    EXPECT_GT(Mii, options.servo.armature); // armature is part of M_ii
  }
}

TEST(MjcfTest, ACapsuleTooShortForMujocoIsTheSphereAroundIt) {
  // MuJoCo refuses a capsule whose end points are closer than 1e-7 m; a fitted
  // cover can give one
  kinematics::Robot robot = testing::AllSimTestRobots().front();
  kinematics::LinkCapsule &cap = robot.capsules.front();
  const Eigen::Vector3d mid = 0.5 * (cap.p_LA + cap.p_LB);
  cap.p_LA = mid - Eigen::Vector3d(2.5e-8, 0, 0);
  cap.p_LB = mid + Eigen::Vector3d(2.5e-8, 0, 0);
  const WorldModel world_model(robot);
  const mjModel *m = world_model.mj_model();
  const int g = world_model.capsule_geom(0);
  EXPECT_EQ(m->geom_type[g], mjGEOM_SPHERE);
  EXPECT_DOUBLE_EQ(m->geom_size[3 * g],
                   cap.radius + 2.5e-8); // it holds the whole capsule
}

TEST(MjcfTest, SolverRowsStayBoundedWithManyCapsulesAndObstacles) {
  // MuJoCo 2.2.2 preallocates njmax² doubles per mjData: a row for every
  // candidate contact of 40 capsules and 1000 obstacles (80 000) would be 51
  // GB. The contact list still holds two contacts per candidate pair.
  kinematics::Robot robot = kinematics::MakePlanar2();
  const kinematics::LinkCapsule link1 = robot.capsules.front();
  for (int k = 0; k < 39; ++k)
    robot.capsules.push_back(link1);
  SceneSpec scene;
  scene.obstacles.assign(1000, ObstacleSpec::Cube(0.02));
  const WorldModel many(robot, scene);
  EXPECT_LE(many.mj_model()->njmax, 512 + 2 * robot.model.nq() + 16);
  EXPECT_GE(many.mj_model()->nconmax,
            2 * 1000 * static_cast<int>(robot.capsules.size()));
  World(std::make_shared<const WorldModel>(many)); // its mjData allocates

  // one capsule per link: 100 cubes inside link1 are 100 collisions, every row
  // kept; 1000 are 1000 collisions (the contact list holds them all) with rows
  // past the cap dropped, which the report says
  const kinematics::Robot planar = kinematics::MakePlanar2();
  World world(std::make_shared<const WorldModel>(planar, scene));
  world.Reset(Eigen::Vector2d(0.0, 0.0));
  for (int j = 0; j < 100; ++j)
    world.SetObstaclePose(j, Eigen::Vector3d(0.05 + 0.004 * j, 0.0, 0.0),
                          Eigen::Matrix3d::Identity());
  world.Step();
  EXPECT_EQ(world.QueryContacts().num_collisions, 100);
  EXPECT_FALSE(world.QueryContacts().contact_buffer_full);
  for (int j = 100; j < 1000; ++j) {
    world.SetObstaclePose(j, Eigen::Vector3d(0.05 + 0.0004 * j, 0.0, 0.0),
                          Eigen::Matrix3d::Identity());
  }
  world.Step();
  EXPECT_EQ(world.QueryContacts().num_collisions, 1000);
  EXPECT_TRUE(world.QueryContacts().contact_buffer_full);
}

TEST(MjcfTest, CompileErrorsReportMujocosMessage) {
  try {
    CompileMjcf("<mujoco><worldbody><geom type=\"capsule\" "
                "size=\"-1\"/></worldbody></mujoco>",
                "bad model");
    FAIL() << "expected InputError";
  } catch (const InputError &e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("bad model"), std::string::npos) << what;
    EXPECT_NE(what.find("MuJoCo could not compile"), std::string::npos) << what;
    EXPECT_GT(
        what.size(),
        std::string("bad model: MuJoCo could not compile the generated MJCF: ")
            .size())
        << what;
  }
}

TEST(MjcfTest, BadOptionsAndScenesThrowInputError) {
  const kinematics::Robot robot = kinematics::MakePlanar2();
  auto expect_error = [&](const SceneSpec &scene, const WorldOptions &options,
                          const std::string &needle) {
    try {
      WorldModel wm(robot, scene, options);
      ADD_FAILURE() << "expected InputError mentioning " << needle;
    } catch (const InputError &e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos)
          << e.what();
    }
  };
  WorldOptions options;
  options.timestep = 0.0;
  expect_error({}, options, "timestep");
  options = {};
  options.servo.kp = Eigen::VectorXd::Ones(3);
  expect_error({}, options, "2 entries");
  options = {};
  options.warning_margin = std::nan("");
  expect_error({}, options, "warning_margin");
  SceneSpec scene;
  scene.obstacles = {ObstacleSpec::Box(Eigen::Vector3d(0.1, -0.1, 0.1))};
  expect_error(scene, {}, "half_size[1]");
  scene.obstacles = {ObstacleSpec::Cube(0.1)};
  scene.obstacles[0].X_WO.linear() *= 2.0;
  expect_error(scene, {}, "rotation");
}

} // namespace
} // namespace rmpmarl::sim
