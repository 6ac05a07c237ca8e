// The MotionBenchMaker benchmark (experiments/mbm.h): problems found on disk by family, a hand-made problem (a wall
// across the Panda's way to a joint goal) run by every method, an invalid problem reported with its reason, the
// results files; and, where the set is present, problems of MotionBenchMaker's own Panda set with its robot model.
#include "rmpmarl/experiments/mbm.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/sim/scenario.h"

namespace rmpmarl::experiments {
namespace {
namespace fs = std::filesystem;

fs::path TempDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / fmt::format("rmpmarl-mbm-{}-{}", name, getpid());
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

void Write(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

// a 24 × 4 × 36 cm wall between the Panda's ready posture and a goal 45 cm to its left (the RRT tests' wall), as a
// MoveIt scene and request; `goal` the joint goal
void WriteWallProblem(const fs::path& folder, int index, const Eigen::VectorXd& goal, double wall_y = 0.225) {
  Write(folder / fmt::format("scene{:04d}.yaml", index), fmt::format(R"(world:
  collision_objects:
    - id: wall
      primitive_poses:
        - position: [0.357, {}, 0.515]
          orientation: [0, 0, 0, 1]
      primitives:
        - type: box
          dimensions: [0.24, 0.04, 0.36]
)", wall_y));
  std::string joints;
  for (int i = 0; i < goal.size(); ++i) {
    joints += fmt::format("      - {{joint_name: panda_joint{}, position: {:.17g}}}\n", i + 1, goal[i]);
  }
  Write(folder / fmt::format("request{:04d}.yaml", index),
        "start_state:\n  joint_state:\n    name: [panda_joint1, panda_joint2, panda_joint3, panda_joint4, "
        "panda_joint5, panda_joint6, panda_joint7, panda_finger_joint1]\n"
        "    position: [0, -0.785398, 0, -2.356194, 0, 1.570796, 0.785398, 0.04]\n"
        "goal_constraints:\n  - joint_constraints:\n" + joints);
}

// a collision-free configuration with the end effector 45 cm left of and 15 cm below the ready posture's
Eigen::VectorXd WallGoal(const kinematics::Robot& panda) {
  const Eigen::VectorXd q0 = sim::ReadyConfiguration(panda);
  kinematics::Data data(panda.model);
  kinematics::CalcForwardKinematics(panda.model, q0, &data);
  const Eigen::Vector3d p0 = kinematics::CalcPointPosition(data, panda.end_effector.link,
                                                           panda.end_effector.X_LE.translation());
  rmp::Scene scene;
  scene.p_WT = p0 + Eigen::Vector3d(0.0, 0.45, -0.15);
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.translation() = Eigen::Vector3d(0.357, 0.225, 0.515);
  scene.obstacles.push_back(rmp::Obstacle::MakeBox(X, Eigen::Vector3d(0.12, 0.02, 0.18)));
  planning::RrtPolicy ik(panda, {.seed = 2});
  const planning::IkResult r = ik.SolveIk(q0, scene);
  EXPECT_TRUE(r.reached);
  return r.q;
}

MbmOptions IterationBudget() {
  MbmOptions o;
  o.duration = 8.0;
  o.policy = kinematics::ModelsDirectory() / "policies" / "marl-rmp-residual.rmpp";
  o.plan.planner.planning_time_budget = 3600.0;
  o.plan.planner.planning_iterations = 20000;
  return o;
}

TEST(MbmProblemsTest, FoundByFamilyInOrderWithLimitsAndClearErrors) {
  const fs::path dir = TempDir("find");
  const Eigen::VectorXd goal = Eigen::VectorXd::Zero(7);
  for (int i : {3, 1, 2}) WriteWallProblem(dir / "shelf_panda", i, goal);
  WriteWallProblem(dir / "box_panda", 7, goal);
  Write(dir / "box_panda" / "scene0008.yaml", "world: {}\n");  // no request beside it: not a problem
  const std::vector<MbmProblem> all = FindMbmProblems(dir);
  ASSERT_EQ(all.size(), 4u);
  EXPECT_EQ(all[0].family, "box");
  EXPECT_EQ(all[0].index, 7);
  EXPECT_EQ(all[1].family, "shelf");
  EXPECT_EQ(all[1].index, 1);
  EXPECT_EQ(all[3].index, 3);
  const std::vector<MbmProblem> limited = FindMbmProblems(dir, {"shelf"}, 2);
  ASSERT_EQ(limited.size(), 2u);
  EXPECT_EQ(limited[1].index, 2);
  EXPECT_THROW(FindMbmProblems(dir, {"cage"}), InputError);
  EXPECT_THROW(FindMbmProblems(dir / "nowhere"), InputError);
  EXPECT_THROW(FindMbmProblems(TempDir("empty")), InputError);
  try {
    ParseMbmMethod("plan+rrt");
    ADD_FAILURE() << "accepted an unknown method";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("plan+learned"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

TEST(MbmBenchmarkTest, AWallAcrossTheWayToAJointGoal) {
  const kinematics::Robot panda = kinematics::LoadShippedRobot("panda");
  const fs::path dir = TempDir("wall");
  WriteWallProblem(dir / "wall_panda", 1, WallGoal(panda));
  WriteWallProblem(dir / "wall_panda", 2, WallGoal(panda), 0.0);  // the wall through the arm at its start
  const std::vector<MbmProblem> problems = FindMbmProblems(dir);
  MbmOptions options = IterationBudget();
  options.jobs = 2;
  const std::vector<MbmResult> results = RunMbmBenchmark(panda, problems, AllMbmMethods(), options);
  ASSERT_EQ(results.size(), 2u * AllMbmMethods().size());
  for (const MbmResult& r : results) {
    SCOPED_TRACE(fmt::format("{} {} {}", r.family, r.index, r.method));
    if (r.index == 2) {
      EXPECT_FALSE(r.valid);
      EXPECT_NE(r.invalid_reason.find("start in collision"), std::string::npos) << r.invalid_reason;
      continue;
    }
    ASSERT_TRUE(r.valid) << r.invalid_reason;
    std::printf("[ wall     ] %-13s success %d, %d collisions, final error %.1f mm, joint error %.3f rad, path %.2f "
                "rad, first plan %.1f ms, %d plans\n", r.method.c_str(), r.success, r.collisions, 1e3 * r.final_error,
                r.joint_error, r.path_length, 1e3 * r.planning_time, r.plans);
    // the reactive methods never touch the wall; the plan executed open loop may (its PD tracking cuts corners)
    if (r.method != "rrt-connect") EXPECT_EQ(r.collisions, 0);
    if (r.method == "rrt-connect" || r.method == "plan+rmpflow") {
      EXPECT_TRUE(r.reached) << "final error " << r.final_error << " m";
      EXPECT_GT(r.planning_time, 0.0);
      EXPECT_GE(r.plans, 1);
      EXPECT_GT(r.path_length, 0.0);
    }
    if (r.method == "plan+rmpflow") EXPECT_TRUE(r.success);
    if (r.method == "rrt-connect") {
      EXPECT_LT(r.joint_error, 0.01);
    }
    if (r.method == "rmpflow" || r.method == "learned") {
      EXPECT_EQ(r.plans, 0);
    }
  }
  // the same results on one thread
  options.jobs = 1;
  const std::vector<MbmResult> again = RunMbmBenchmark(panda, problems, {MbmMethod::kPlanRmpflow}, options);
  EXPECT_DOUBLE_EQ(again[0].final_error, results[3].final_error);

  // the dynamic variant: spheres timed to meet the open-loop plan's end effector — the plan executed open loop hits
  // one; the draw is the problem's, the same for every method and run
  MbmOptions dynamic = options;
  dynamic.moving = 2;
  const std::vector<MbmProblem> first = {problems[0]};
  const std::vector<MbmResult> crossed = RunMbmBenchmark(panda, first, {MbmMethod::kRrtConnect}, dynamic);
  EXPECT_GE(crossed[0].collisions, 1);
  EXPECT_FALSE(crossed[0].success);
  EXPECT_EQ(RunMbmBenchmark(panda, first, {MbmMethod::kRrtConnect}, dynamic)[0].final_error, crossed[0].final_error);
  dynamic.speed_min = 0.0;
  EXPECT_THROW(RunMbmBenchmark(panda, first, {MbmMethod::kRrtConnect}, dynamic), InputError);

  // every crossing is avoidable: its sphere, sampled every millisecond of the episode, keeps crossing_clearance from
  // the arm's capsules at the start and at the goal (point-to-segment distances, not the drawing's capsule distance)
  dynamic.speed_min = 0.5;
  dynamic.moving = 8;
  const sim::StaticSceneOptions set_up = MbmProblemScene(panda, first[0], dynamic);
  ASSERT_EQ(set_up.moving.size(), 8u);
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> segments;
  std::vector<double> radii;
  kinematics::Data data(panda.model);
  for (const Eigen::VectorXd* q : {&set_up.q_start, &set_up.q_goal}) {
    kinematics::CalcForwardKinematics(panda.model, *q, &data);
    for (const kinematics::LinkCapsule& c : panda.capsules) {
      segments.emplace_back(data.X_WL[c.link] * c.p_LA, data.X_WL[c.link] * c.p_LB);
      radii.push_back(c.radius);
    }
  }
  for (const sim::LinearMotion& m : set_up.moving) {
    EXPECT_EQ(m.v_W.z(), 0.0);
    EXPECT_GE(m.v_W.norm(), dynamic.speed_min - 1e-12);
    EXPECT_LE(m.v_W.norm(), dynamic.speed_max + 1e-12);
    double clearance = std::numeric_limits<double>::infinity();
    for (int step = 0; step <= 1000 * dynamic.duration; ++step) {
      const Eigen::Vector3d p = m.p_W0 + 1e-3 * step * m.v_W;
      for (size_t c = 0; c < segments.size(); ++c) {
        const auto& [a, b] = segments[c];
        const double f = std::clamp((p - a).dot(b - a) / std::max((b - a).squaredNorm(), 1e-30), 0.0, 1.0);
        clearance = std::min(clearance, (p - (a + f * (b - a))).norm() - radii[c] - dynamic.moving_radius);
      }
    }
    EXPECT_GE(clearance, dynamic.crossing_clearance - 1e-6);
  }
  MbmOptions thin = dynamic;
  thin.moving_radius = 0.0;
  EXPECT_THROW(MbmProblemScene(panda, first[0], thin), InputError);
  try {
    MbmProblemScene(panda, problems[1], dynamic);
    ADD_FAILURE() << "gave the set-up of a problem whose start is in collision";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("start in collision"), std::string::npos) << e.what();
  }

  const fs::path out = dir / "out";
  WriteMbmResults(results, out, "rmpmarl benchmark mbm --problems X", "setup");
  std::ifstream csv(out / "results.csv");
  std::string header;
  std::getline(csv, header);
  EXPECT_EQ(header.rfind("family,problem,method,valid,success,", 0), 0u);
  int lines = 0;
  for (std::string line; std::getline(csv, line);) ++lines;
  EXPECT_EQ(lines, static_cast<int>(results.size()));
  std::stringstream report;
  report << std::ifstream(out / "report.md").rdbuf();
  EXPECT_NE(report.str().find("| wall | plan+rmpflow | 1 of 2 | 100.0 %"), std::string::npos) << report.str();
  EXPECT_NE(report.str().find("wall 2: start in collision"), std::string::npos);
  fs::remove_all(dir);
}

// MotionBenchMaker's own problems with the robot model they were made with (hand and fingers): RRT-Connect and the
// plan followed by RMPflow reach the first bookshelf problem's goal without a collision
TEST(MbmBenchmarkTest, MotionBenchMakerPandaBookshelf) {
  const fs::path problems_dir = RMPMARL_MBM_PROBLEMS, set = RMPMARL_MBM_PANDA;
  if (problems_dir.empty() || !fs::is_directory(problems_dir)) GTEST_SKIP() << "MotionBenchMaker's set is absent";
  const kinematics::Robot panda = kinematics::LoadRobot(
      set / "panda.urdf", fs::path(RMPMARL_TEST_DATA_DIR).parent_path().parent_path() / "configs" / "benchmarks" /
                              "mbm-panda.collision.yaml");
  const std::vector<MbmProblem> problems = FindMbmProblems(problems_dir, {"bookshelf_small"}, 1);
  for (MbmMethod method : {MbmMethod::kRrtConnect, MbmMethod::kPlanRmpflow}) {
    const MbmResult r = RunMbmProblem(panda, problems[0], method, IterationBudget());
    SCOPED_TRACE(r.method);
    EXPECT_TRUE(r.valid) << r.invalid_reason;
    EXPECT_TRUE(r.success) << "final error " << r.final_error << " m";
    EXPECT_EQ(r.collisions, 0);
  }
}

}  // namespace
}  // namespace rmpmarl::experiments
