// The viewer's live scene: what the page's commands do to the simulation, checked on the shipped Panda with the
// shipped learned controller and RMPflow.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <thread>

#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/sim/world.h"

#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/planning/planning_scene.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/sim/scenario.h"
#include "rmpmarl/viewer/live_sim.h"

namespace rmpmarl::viewer {
namespace {

std::string PolicyPath() {
  return (kinematics::ModelsDirectory() / "policies" / "marl-rmp-residual.rmpp").string();
}

std::shared_ptr<const control::PolicyFile> Policy() {
  static const auto file = std::make_shared<const control::PolicyFile>(control::LoadPolicyFile(PolicyPath()));
  return file;
}

Command Make(CommandKind kind) {
  Command c;
  c.kind = kind;
  return c;
}

// removes every obstacle, holds the target at p and runs `seconds`; returns the first time the end effector of
// `arm` was within 2 cm of it (−1: never)
double TimeToReach(LiveSim& sim, const Eigen::Vector3d& p, double seconds, int arm = 0) {
  Command t = Make(CommandKind::kSetTarget);
  t.p = p;
  EXPECT_EQ(sim.Apply(t), "");
  const double start = sim.time();
  while (sim.time() - start < seconds) {
    sim.ControlStep();
    if ((sim.end_effector(arm) - p).norm() < 0.02) return sim.time() - start;
  }
  return -1.0;
}

void RemoveAll(LiveSim& sim) {
  for (int id : sim.obstacle_ids()) {
    Command r = Make(CommandKind::kRemoveObstacle);
    r.id = id;
    ASSERT_EQ(sim.Apply(r), "");
  }
  EXPECT_TRUE(sim.obstacle_ids().empty());
}

TEST(LiveSimTest, HeldTargetIsReachedByEveryController) {
  LiveSim sim(kinematics::LoadShippedRobot("panda"), Policy(), PolicyPath());
  RemoveAll(sim);
  for (int k = 0; k < 50; ++k) sim.ControlStep();
  const Eigen::Vector3d start = sim.end_effector(0);
  // a point 15 cm from the end effector inside the workspace box
  const Eigen::AlignedBox3d& box = sim.scenario().workspace().box;
  Eigen::Vector3d p = start + Eigen::Vector3d(0.0, 0.15, 0.0);
  p = p.cwiseMax(box.min()).cwiseMin(box.max());
  const double learned = TimeToReach(sim, p, 3.0);
  EXPECT_GE(learned, 0.0) << "learned: end effector " << sim.end_effector(0).transpose() << ", target " << p.transpose();
  Command c = Make(CommandKind::kController);
  c.name = "rmpflow";
  ASSERT_EQ(sim.Apply(c), "");
  EXPECT_EQ(sim.controller(0), "rmpflow");
  const double rmpflow = TimeToReach(sim, start, 3.0);
  EXPECT_GE(rmpflow, 0.0) << "rmpflow: end effector " << sim.end_effector(0).transpose();
  std::printf("time to within 2 cm of a target 15 cm away: learned %.2f s, rmpflow %.2f s\n", learned, rmpflow);
}


TEST(LiveSimTest, ObstaclesFollowTheScenarioUntilHeldAndDragVelocityIsEstimated) {
  LiveSim sim(kinematics::LoadShippedRobot("panda"), nullptr, "", LiveSimOptions{.controller = "rmpflow"});
  ASSERT_EQ(sim.obstacle_ids(), (std::vector<int>{0, 1, 2, 3}));  // the crossing scenario's four cubes
  for (int k = 0; k < 20; ++k) sim.ControlStep();
  for (int id : sim.obstacle_ids()) {
    EXPECT_LT((sim.obstacle_position(id) - sim.scenario().obstacles()[id].p_WO()).norm(), 1e-12);
    // the arms' MuJoCo world has it where the scene says
    EXPECT_LT((sim.world(0).ObstaclePose(id).translation() - sim.obstacle_position(id)).norm(), 1e-12);
  }
  Command drag = Make(CommandKind::kSetObstacle);
  drag.id = 1;
  drag.p = Eigen::Vector3d(0.4, 0.3, 0.5);
  ASSERT_EQ(sim.Apply(drag), "");
  for (int k = 0; k < 3; ++k) sim.ControlStep();  // 30 ms later the drag moves on by 3 cm in y
  drag.p.y() += 0.03;
  ASSERT_EQ(sim.Apply(drag), "");
  std::string frame;
  sim.Frame({}, &frame);
  const auto f = nlohmann::json::parse(frame);
  const auto& o = f["obstacles"][1];
  ASSERT_EQ(o["id"], 1);
  EXPECT_TRUE(o["held"].get<bool>());
  EXPECT_NEAR(o["p"][1].get<double>(), 0.33, 1e-9);
  // half of 1 m/s: the estimate is smoothed over updates, starting from rest
  EXPECT_NEAR(o["v"][1].get<double>(), 0.5, 1e-6);
  for (int k = 0; k < 50; ++k) sim.ControlStep();
  EXPECT_LT((sim.obstacle_position(1) - drag.p).norm(), 1e-12) << "a held obstacle stays where it was left";
  sim.Frame({}, &frame);
  EXPECT_EQ(nlohmann::json::parse(frame)["obstacles"][1]["v"][1].get<double>(), 0.0) << "no drag: at rest";
  EXPECT_LT((sim.obstacle_position(0) - sim.scenario().obstacles()[0].p_WO()).norm(), 1e-12);
}

TEST(LiveSimTest, AddRemoveAndTheirRefusals) {
  LiveSimOptions options;
  options.controller = "rmpflow";
  options.extra_boxes = 1;
  options.extra_spheres = 2;
  options.max_obstacles = 6;
  LiveSim sim(kinematics::LoadShippedRobot("panda"), nullptr, "", options);
  Command add = Make(CommandKind::kAddObstacle);
  add.shape = rmp::ObstacleShape::kBox;
  add.p = Eigen::Vector3d(0.5, 0.0, 0.3);
  EXPECT_EQ(sim.Apply(add), "");
  EXPECT_EQ(sim.obstacle_ids().size(), 5u);
  EXPECT_NE(sim.Apply(add).find("no room for another cube"), std::string::npos);
  add.shape = rmp::ObstacleShape::kSphere;
  EXPECT_EQ(sim.Apply(add), "");
  EXPECT_NE(sim.Apply(add).find("holds 6 obstacles"), std::string::npos);
  Command remove = Make(CommandKind::kRemoveObstacle);
  remove.id = 0;
  EXPECT_EQ(sim.Apply(remove), "");
  const std::string again = sim.Apply(remove);
  EXPECT_NE(again.find("obstacle 0 is not in the scene"), std::string::npos) << again;
  EXPECT_EQ(sim.world(0).ObstaclePose(0).translation().z(), sim::ParkedPose().translation().z());
  Command other = Make(CommandKind::kSideBySide);
  other.on = true;
  EXPECT_NE(sim.Apply(other).find("needs a learned controller"), std::string::npos);
  EXPECT_NE(sim.Apply(Make(CommandKind::kSeek)).find("only a replay"), std::string::npos);
  // a reset restores the scenario's obstacles
  EXPECT_EQ(sim.Apply(Make(CommandKind::kReset)), "");
  EXPECT_EQ(sim.obstacle_ids(), (std::vector<int>{0, 1, 2, 3}));
}

TEST(LiveSimTest, SideBySideFeedsBothArmsTheSameSceneAndResetIsDeterministic) {
  LiveSimOptions options;
  options.side_by_side = true;
  LiveSim sim(kinematics::LoadShippedRobot("panda"), Policy(), PolicyPath(), options);
  ASSERT_EQ(sim.num_arms(), 2);
  EXPECT_EQ(sim.controller(0), "learned");
  EXPECT_EQ(sim.controller(1), "rmpflow");
  std::vector<Eigen::Vector3d> first;
  for (int k = 0; k < 100; ++k) {
    sim.ControlStep();
    first.push_back(sim.end_effector(0));
    for (int id : sim.obstacle_ids()) {
      EXPECT_EQ(sim.world(0).ObstaclePose(id).translation(), sim.world(1).ObstaclePose(id).translation());
    }
  }
  // the two controllers move differently
  EXPECT_GT((sim.end_effector(0) - sim.end_effector(1)).norm(), 1e-4);
  std::string frame;
  sim.Frame({}, &frame);
  const auto f = nlohmann::json::parse(frame);
  ASSERT_EQ(f["arms"].size(), 2u);
  EXPECT_EQ(f["arms"][0]["joints"].size(), 7u);
  EXPECT_TRUE(f["arms"][1]["joints"].is_null());
  const auto hello = nlohmann::json::parse(sim.hello());
  EXPECT_EQ(hello["arms"].size(), 2u);
  EXPECT_TRUE(hello["side_by_side"].get<bool>());
  // the same seed again: the same motion, bit for bit
  ASSERT_EQ(sim.Apply(Make(CommandKind::kReset)), "");
  for (int k = 0; k < 100; ++k) {
    sim.ControlStep();
    ASSERT_EQ(sim.end_effector(0), first[k]) << "step " << k;
  }
  Command off = Make(CommandKind::kSideBySide);
  off.on = false;
  ASSERT_EQ(sim.Apply(off), "");
  EXPECT_EQ(sim.num_arms(), 1);
  EXPECT_EQ(nlohmann::json::parse(sim.hello())["arms"].size(), 1u);
}

TEST(LiveSimTest, FrameLinkPosesMatchForwardKinematics) {
  const kinematics::Robot robot = kinematics::LoadShippedRobot("ur5e");
  LiveSim sim(robot, Policy(), PolicyPath());
  for (int k = 0; k < 30; ++k) sim.ControlStep();
  std::string frame;
  sim.Frame({}, &frame);
  const auto f = nlohmann::json::parse(frame);
  kinematics::Data data(robot.model);
  kinematics::CalcForwardKinematics(robot.model, sim.world(0).q(), &data);
  const auto& links = f["arms"][0]["links"];
  ASSERT_EQ(static_cast<int>(links.size()), robot.model.num_links());
  for (int k = 0; k < robot.model.num_links(); ++k) {
    const Eigen::Vector3d p(links[k][0].get<double>(), links[k][1].get<double>(), links[k][2].get<double>());
    const Eigen::Quaterniond q(links[k][3].get<double>(), links[k][4].get<double>(), links[k][5].get<double>(),
                               links[k][6].get<double>());
    EXPECT_LT((p - data.X_WL[k].translation()).norm(), 1e-4) << robot.model.link(k).name;
    EXPECT_LT(q.angularDistance(Eigen::Quaterniond(data.X_WL[k].linear())), 1e-4) << robot.model.link(k).name;
  }
  const Eigen::Vector3d ee(f["arms"][0]["ee"][0].get<double>(), f["arms"][0]["ee"][1].get<double>(),
                           f["arms"][0]["ee"][2].get<double>());
  EXPECT_LT((ee - data.X_WL[robot.end_effector.link] * robot.end_effector.X_LE.translation()).norm(), 1e-4);
}

TEST(LiveSimTest, AnObstacleDraggedOntoTheArmShowsTheAgentsWitnessPoints) {
  LiveSim sim(kinematics::LoadShippedRobot("panda"), Policy(), PolicyPath());
  RemoveAll(sim);
  Command add = Make(CommandKind::kAddObstacle);
  add.shape = rmp::ObstacleShape::kSphere;
  // 12 cm beside the elbow (link 4)
  const int elbow = sim.world(0).model().link_body(4);
  add.p = Eigen::Map<const Eigen::Vector3d>(sim.world(0).mj_data()->xpos + 3 * elbow) + Eigen::Vector3d(0, 0.12, 0);
  ASSERT_EQ(sim.Apply(add), "");
  sim.ControlStep();
  std::string frame;
  sim.Frame({}, &frame);
  const auto f = nlohmann::json::parse(frame);
  const auto& witness = f["arms"][0]["witness"];
  ASSERT_FALSE(witness.empty()) << frame;
  for (const auto& w : witness) {
    EXPECT_GE(w["joint"].get<int>(), 0);
    const Eigen::Vector3d a(w["a"][0].get<double>(), w["a"][1].get<double>(), w["a"][2].get<double>());
    const Eigen::Vector3d b(w["b"][0].get<double>(), w["b"][1].get<double>(), w["b"][2].get<double>());
    // b lies on the sphere's surface, d is the gap a–b
    EXPECT_NEAR((b - add.p).norm(), 0.05, 2e-4);
    EXPECT_NEAR((a - b).norm(), std::abs(w["d"].get<double>()), 2e-4);
  }
  EXPECT_TRUE(std::isfinite(f["arms"][0]["clearance"].get<double>()));
}

TEST(LiveSimTest, AScenesRequestIsPlannedToItsJointGoalAsTheBenchmarkPlans) {
  // rmpmarl view --scene --request --plan on MotionBenchMaker's box problem 1, whose cell's base board lies 49 cm
  // below the robot's base: the arm goes to the request's joint goal (a floor at z = 0 would make it unplannable, and
  // an IK solution of its end effector is another posture)
  const std::filesystem::path problems = RMPMARL_MBM_PROBLEMS;
  if (problems.empty()) GTEST_SKIP() << "MotionBenchMaker's Panda set is not here";
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  const planning::PlanningScene scene = planning::ReadPlanningScene(problems / "box_panda" / "scene0001.yaml");
  const planning::MotionPlanRequest request =
      planning::ReadMotionPlanRequest(problems / "box_panda" / "request0001.yaml");
  // the same with the plans made beside the loop (view --plan-beside-loop): RMPflow goes for the goal alone until the
  // plan is ready, then follows it there
  for (const bool beside : {false, true}) {
    LiveSimOptions options;
    options.controller = "rmpflow";
    options.plan = true;
    options.plan_beside_loop = beside;
    options.scene = sim::StaticSceneOf(robot, scene, &request, "request0001.yaml");
    options.max_obstacles = static_cast<int>(options.scene->obstacles.size()) + 8;
    const Eigen::VectorXd q_goal = options.scene->q_goal;
    LiveSim sim(robot, nullptr, "", options);
    double error = 1e9;
    while (sim.time() < 8.0 && error > 0.02) {
      sim.ControlStep();
      // beside the loop, the first 0.3 s run in real time as the live view runs them, so that the plan arrives after
      // as many steps as it would there (as fast as it can, the loop would run far ahead of the plan)
      if (beside && sim.time() < 0.3) std::this_thread::sleep_for(std::chrono::milliseconds(10));
      error = (sim.world(0).q() - q_goal).cwiseAbs().maxCoeff();
    }
    EXPECT_LT(error, 0.02) << "beside the loop " << beside << ": at " << sim.world(0).q().transpose() << ", goal "
                           << q_goal.transpose();
    EXPECT_EQ(sim.collisions(0), 0) << beside;
    std::printf("view --scene --request --plan%s on box 1: at the joint goal (within 0.02 rad) after %.2f s\n",
                beside ? "-beside-loop" : "", sim.time());
  }
}

TEST(LiveSimTest, BadOptionsAreRefused) {
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  EXPECT_THROW(LiveSim(robot, nullptr, "", LiveSimOptions{}), InputError);  // learned without a file
  EXPECT_THROW(LiveSim(robot, Policy(), PolicyPath(), LiveSimOptions{.scenario = "nowhere"}), InputError);
  EXPECT_THROW(LiveSim(robot, Policy(), PolicyPath(), LiveSimOptions{.controller = "magic"}), InputError);
}

}  // namespace
}  // namespace rmpmarl::viewer
