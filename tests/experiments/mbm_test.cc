// The MotionBenchMaker benchmark (experiments/mbm.h): problems found on disk by family, a hand-made problem (a wall
// across the Panda's way to a joint goal) run by every method, an invalid problem reported with its reason, the
// results files and their columns for both referees; and, where the set is present, problems of MotionBenchMaker's
// own Panda set with its robot model and collision meshes: the validity rule of the mesh referee (a box touching the
// start's meshes: not valid; a box only the capsules touch: rejected by the model, counted) and a problem judged on
// the meshes at every control step.
#include "rmpmarl/experiments/mbm.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <tuple>

#include "rmpmarl/common/error.h"
#include "rmpmarl/experiments/mesh_collision.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/kinematics/urdf_geometry.h"
#include "rmpmarl/setup/mesh.h"
#include "rmpmarl/sim/scenario.h"
#include "../support/temp_files.h"

namespace rmpmarl::experiments {
namespace {
namespace fs = std::filesystem;

fs::path TempDir(const std::string& name) { return test::FreshTempDir("mbm", name); }

void Write(const fs::path& path, const std::string& text) { test::WriteTextFile(path, text); }

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
  // the set's archive not unpacked: the error says so and how
  const fs::path packed = TempDir("packed");
  Write(packed / "problems.tar.bz2", "BZh9");
  try {
    FindMbmProblems(packed);
    ADD_FAILURE() << "found problems in a folder holding only an archive";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("problems.tar.bz2' there is an archive: unpack it first (tar xf"), std::string::npos) << what;
  }
  fs::remove_all(packed);
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
    // no mesh referee: judged on the capsules alone, as the results say
    EXPECT_EQ(r.mesh_collisions, -1);
    EXPECT_FALSE(r.rejected);
    if (r.index == 2) {
      EXPECT_FALSE(r.valid);
      EXPECT_NE(r.reason.find("start in collision in the capsule model: "), std::string::npos) << r.reason;
      EXPECT_NE(r.reason.find(" with wall ("), std::string::npos) << r.reason;
      continue;
    }
    ASSERT_TRUE(r.valid) << r.reason;
    std::printf("[ wall     ] %-13s success %d, %d collisions, final error %.1f mm, joint error %.3f rad, path %.2f "
                "rad, first plan %.1f ms, %d plans\n", r.method.c_str(), r.success, r.collisions, 1e3 * r.final_error,
                r.joint_error, r.path_length, 1e3 * r.planning_time, r.plans);
    // the reactive methods never touch the wall; the plan executed open loop may (its PD tracking cuts corners)
    if (r.method != "rrt-connect") {
      EXPECT_EQ(r.collisions, 0);
    }
    if (r.method == "rrt-connect" || r.method == "plan+rmpflow") {
      EXPECT_TRUE(r.reached) << "final error " << r.final_error << " m";
      EXPECT_GT(r.planning_time, 0.0);
      EXPECT_GE(r.plans, 1);
      EXPECT_GT(r.path_length, 0.0);
    }
    if (r.method == "plan+rmpflow") {
      EXPECT_TRUE(r.success);
    }
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
  // why a run failed (results.csv's reason), none for a success
  for (const MbmResult& r : results) {
    if (r.success) {
      EXPECT_EQ(r.reason, "") << r.method;
    }
    if (r.valid && !r.success) {
      EXPECT_FALSE(r.reason.empty()) << r.method;
    }
  }
  MbmOptions hurried = options;
  hurried.duration = 0.3;
  const MbmResult late = RunMbmBenchmark(panda, {problems[0]}, {MbmMethod::kPlanRmpflow}, hurried)[0];
  EXPECT_FALSE(late.success);
  EXPECT_EQ(late.reason.rfind("timed out: the plan takes ", 0), 0u) << late.reason;
  EXPECT_NE(late.reason.find("the run lasts 0.3 s (--duration)"), std::string::npos) << late.reason;
  MbmOptions starved = options;
  starved.plan.planner.planning_iterations = 1;
  const MbmResult none = RunMbmBenchmark(panda, {problems[0]}, {MbmMethod::kPlanRmpflow}, starved)[0];
  EXPECT_EQ(none.reason.rfind("no plan: no path within the budget (", 0), 0u) << none.reason;

  // the dynamic variant: spheres timed to meet the open-loop plan's end effector — the plan executed open loop hits
  // one; the draw is the problem's, the same for every method and run
  MbmOptions dynamic = options;
  dynamic.moving = 2;
  const std::vector<MbmProblem> first = {problems[0]};
  const std::vector<MbmResult> crossed = RunMbmBenchmark(panda, first, {MbmMethod::kRrtConnect}, dynamic);
  EXPECT_GE(crossed[0].collisions, 1);
  EXPECT_FALSE(crossed[0].success);
  EXPECT_EQ(crossed[0].reason.rfind("collided: ", 0), 0u) << crossed[0].reason;
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
  EXPECT_EQ(header.rfind("family,problem,method,valid,rejected,success,", 0), 0u);
  int lines = 0;
  for (std::string line; std::getline(csv, line);) ++lines;
  EXPECT_EQ(lines, static_cast<int>(results.size()));
  std::stringstream report;
  report << std::ifstream(out / "report.md").rdbuf();
  EXPECT_NE(report.str().find("| wall | plan+rmpflow | 1 of 2 | 0 | 100.0 %"), std::string::npos) << report.str();
  EXPECT_NE(report.str().find("wall 2: start in collision"), std::string::npos);
  EXPECT_NE(report.str().find("Referee: the capsule model alone"), std::string::npos);

  // a mesh referee without meshes (the shipped Panda's URDF has none) is refused with its reason
  MbmOptions unavailable = options;
  unavailable.meshes = std::make_shared<const MeshCollisionModel>(panda);
  try {
    RunMbmBenchmark(panda, first, {MbmMethod::kRrtConnect}, unavailable);
    ADD_FAILURE() << "ran with a mesh model that has no meshes";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no <collision> element"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

// results.csv and report.md of hand-made results: a problem not valid on the meshes, one rejected by the model, and
// one run with collisions on the capsules and the meshes
TEST(MbmBenchmarkTest, EndsBeyondTheLimitsAndUnreadableFilesAreNotValidTheRestRuns) {
  // a goal and a start beyond panda_joint4's limits [-3.0718, -0.0698] and a scene that is not YAML are not valid,
  // each with why; the problem beside them still runs (one bad problem never loses the others)
  const kinematics::Robot panda = kinematics::LoadShippedRobot("panda");
  const fs::path dir = TempDir("limits");
  const fs::path family = dir / "wall_panda";
  Eigen::VectorXd beyond = WallGoal(panda);
  beyond[3] = 0.5;
  WriteWallProblem(family, 1, beyond);
  WriteWallProblem(family, 2, WallGoal(panda));
  {
    std::ifstream in(family / "request0002.yaml");
    std::stringstream text;
    text << in.rdbuf();
    std::string request = text.str();
    request.replace(request.find("-2.356194"), 9, "0.5");
    Write(family / "request0002.yaml", request);
  }
  WriteWallProblem(family, 3, WallGoal(panda));
  Write(family / "scene0003.yaml", "world: [collision_objects\n");
  WriteWallProblem(family, 4, WallGoal(panda));
  MbmOptions options = IterationBudget();
  options.duration = 0.5;
  const std::vector<MbmResult> results =
      RunMbmBenchmark(panda, FindMbmProblems(dir), {MbmMethod::kRrtConnect}, options);
  ASSERT_EQ(results.size(), 4u);
  EXPECT_FALSE(results[0].valid);
  EXPECT_NE(results[0].reason.find("goal outside the joint limits: panda_joint4 = 0.5, limits [-3.0718, -0.0698]"),
            std::string::npos) << results[0].reason;
  EXPECT_FALSE(results[1].valid);
  EXPECT_NE(results[1].reason.find("start outside the joint limits: panda_joint4 = 0.5"), std::string::npos)
      << results[1].reason;
  EXPECT_FALSE(results[2].valid);
  EXPECT_NE(results[2].reason.find("could not be read: "), std::string::npos) << results[2].reason;
  EXPECT_NE(results[2].reason.find("scene0003.yaml"), std::string::npos) << results[2].reason;
  EXPECT_TRUE(results[3].valid) << results[3].reason;
  EXPECT_GE(results[3].plans, 1);
}

TEST(MbmBenchmarkTest, ResultsFilesCountBothReferees) {
  std::vector<MbmResult> results(3);
  for (int i = 0; i < 3; ++i) {
    results[i].family = "shelf";
    results[i].index = i + 1;
    results[i].method = "rmpflow";
  }
  results[0].valid = false;
  results[0].reason = "start in collision (meshes): panda_hand with board (1.5 mm deep)";
  results[1].rejected = true;
  results[1].reason = "rejected by the model: goal in collision in the capsule model: panda_link7 with board (2.0 mm "
                      "deep)";
  results[2].collisions = 2;
  results[2].mesh_collisions = 7;
  results[2].min_mesh_clearance = -0.0031;
  results[2].min_mesh_pair = "panda_leftfinger with board";
  results[2].mesh_check_us = 12.5;
  const fs::path out = TempDir("columns");
  WriteMbmResults(results, out, "rmpmarl benchmark mbm", "setup");
  std::ifstream csv(out / "results.csv");
  std::string header, line;
  std::getline(csv, header);
  EXPECT_EQ(header, "family,problem,method,valid,rejected,success,reached,collisions,mesh_collisions,time_to_goal_s,"
                    "final_error_mm,joint_error_rad,path_length_rad,min_clearance_mm,min_mesh_clearance_mm,"
                    "min_mesh_pair,planning_time_ms,plans,control_us,mesh_check_us,reason");
  std::vector<std::string> rows;
  while (std::getline(csv, line)) rows.push_back(line);
  ASSERT_EQ(rows.size(), 3u);
  // "none" is nan: no mesh referee, a goal never reached, no plan attempted
  EXPECT_EQ(rows[0].rfind("shelf,1,rmpflow,0,0,0,0,0,nan,nan,", 0), 0u) << rows[0];
  EXPECT_EQ(rows[1].rfind("shelf,2,rmpflow,1,1,0,0,0,nan,nan,", 0), 0u) << rows[1];
  EXPECT_EQ(rows[2].rfind("shelf,3,rmpflow,1,0,0,0,2,7,nan,", 0), 0u) << rows[2];
  EXPECT_NE(rows[2].find("panda_leftfinger with board,nan,0,"), std::string::npos) << rows[2];
  EXPECT_NE(rows[2].find(",nan,-3.10,panda_leftfinger with board,"), std::string::npos) << rows[2];
  EXPECT_NE(rows[2].find(",12.50,"), std::string::npos) << rows[2];
  std::stringstream report;
  report << std::ifstream(out / "report.md").rdbuf();
  // 2 valid of 3 (the rejected one counts), no success, 1 rejected, 1 with collisions on each referee
  EXPECT_NE(report.str().find("with collisions (capsules) | with collisions (meshes)"), std::string::npos);
  EXPECT_NE(report.str().find("| shelf | rmpflow | 2 of 3 | 1 | 0.0 % [0.0, 65.8] | 1 | 1 |"), std::string::npos)
      << report.str();
  EXPECT_NE(report.str().find("Referees: validity on the collision meshes"), std::string::npos);
  EXPECT_NE(report.str().find("Problems not valid, not run (1):\n\n- shelf 1: start in collision (meshes)"),
            std::string::npos) << report.str();
  EXPECT_NE(report.str().find("counted as failures (1):\n\n- shelf 2: rejected by the model: goal"),
            std::string::npos) << report.str();
  fs::remove_all(out);
  // why runs failed: a count per kind and method, and the runs that failed while they ran
  results[2].reason = "collided: 2 collision events on the capsules, 7 control steps in collision on the meshes";
  WriteMbmResults(results, out, "rmpmarl benchmark mbm", "setup");
  std::stringstream again;
  again << std::ifstream(out / "report.md").rdbuf();
  EXPECT_NE(again.str().find("| method | rejected by the model | collided | no plan | timed out | stopped short | not "
                             "settled |\n|---|---|---|---|---|---|---|\n| rmpflow | 1 | 1 | 0 | 0 | 0 | 0 |"),
            std::string::npos) << again.str();
  EXPECT_NE(again.str().find("Runs that failed (1):\n\n- shelf 3 rmpflow: collided: 2 collision events"),
            std::string::npos) << again.str();
  fs::remove_all(out);
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
    MbmOptions options = IterationBudget();
    options.meshes = std::make_shared<const MeshCollisionModel>(panda, MeshCollisionOptions{.package_paths = {set}});
    ASSERT_TRUE(options.meshes->available()) << options.meshes->unavailable_reason();
    const MbmResult r = RunMbmProblem(panda, problems[0], method, options);
    SCOPED_TRACE(r.method);
    EXPECT_TRUE(r.valid) << r.reason;
    EXPECT_FALSE(r.rejected) << r.reason;
    EXPECT_TRUE(r.success) << "final error " << r.final_error << " m";
    EXPECT_EQ(r.collisions, 0);
    // judged on the meshes at every control step: clear, and close to the shelf at the grasp
    EXPECT_EQ(r.mesh_collisions, 0);
    EXPECT_GT(r.min_mesh_clearance, 0.0);
    EXPECT_LT(r.min_mesh_clearance, 0.05);
    EXPECT_FALSE(r.min_mesh_pair.empty());
    EXPECT_GT(r.mesh_check_us, 0.0);
    std::printf("[ meshes   ] %-13s closest %.1f mm (%s), mesh check %.1f µs per control step, capsules' closest "
                "%.1f mm\n", r.method.c_str(), 1e3 * r.min_mesh_clearance, r.min_mesh_pair.c_str(), r.mesh_check_us,
                1e3 * r.min_clearance);
  }
}

// a MoveIt scene of boxes (id, pose, half sizes) and a request from q_start to q_goal, for MotionBenchMaker's Panda
void WriteProblem(const fs::path& folder, int index,
                  const std::vector<std::tuple<std::string, Eigen::Isometry3d, Eigen::Vector3d>>& boxes,
                  const Eigen::VectorXd& q_start, const Eigen::VectorXd& q_goal) {
  std::string objects;
  for (const auto& [id, X_WB, half] : boxes) {
    const Eigen::Quaterniond quaternion(X_WB.linear());
    objects += fmt::format("    - id: {}\n      primitive_poses:\n        - position: [{:.17g}, {:.17g}, {:.17g}]\n"
                           "          orientation: [{:.17g}, {:.17g}, {:.17g}, {:.17g}]\n      primitives:\n"
                           "        - type: box\n          dimensions: [{:.17g}, {:.17g}, {:.17g}]\n",
                           id, X_WB.translation().x(), X_WB.translation().y(), X_WB.translation().z(), quaternion.x(),
                           quaternion.y(), quaternion.z(), quaternion.w(), 2 * half.x(), 2 * half.y(), 2 * half.z());
  }
  Write(folder / fmt::format("scene{:04d}.yaml", index), "world:\n  collision_objects:\n" + objects);
  std::string names, start, goal;
  for (int i = 0; i < q_start.size(); ++i) {
    names += fmt::format("{}panda_joint{}", i == 0 ? "" : ", ", i + 1);
    start += fmt::format("{}{:.17g}", i == 0 ? "" : ", ", q_start[i]);
    goal += fmt::format("      - {{joint_name: panda_joint{}, position: {:.17g}}}\n", i + 1, q_goal[i]);
  }
  Write(folder / fmt::format("request{:04d}.yaml", index),
        fmt::format("start_state:\n  joint_state:\n    name: [{}]\n    position: [{}]\ngoal_constraints:\n"
                    "  - joint_constraints:\n{}", names, start, goal));
}

// The validity rule on MotionBenchMaker's Panda at its ready posture. Its meshes' vertices are posed here; for a
// direction u the vertex farthest along u bounds every mesh point's u-coordinate, so a box with a face normal to u
// set g beyond that plane is at least g from the meshes, and one set 5 mm inside it touches them. Problem 1: a box
// touching the start's meshes — not valid, the pair and depth named, out of the denominator. Problem 2: a box the
// meshes clear by 3 mm and the capsules (fatter) enter — valid, rejected by the model, a failure of every method, in
// the denominator; without the mesh referee the capsules decide and it is not valid.
TEST(MbmBenchmarkTest, MeshValidityAndProblemsRejectedByTheCapsuleModel) {
  const fs::path set = RMPMARL_MBM_PANDA;
  if (!fs::is_regular_file(set / "panda.urdf")) GTEST_SKIP() << "MotionBenchMaker's Panda set is absent: " << set;
  if (!setup::MeshReadingAvailable()) GTEST_SKIP() << "built without assimp: meshes cannot be read";
  const kinematics::Robot panda = kinematics::LoadRobot(
      set / "panda.urdf", fs::path(RMPMARL_TEST_DATA_DIR).parent_path().parent_path() / "configs" / "benchmarks" /
                              "mbm-panda.collision.yaml");
  auto meshes = std::make_shared<const MeshCollisionModel>(panda, MeshCollisionOptions{.package_paths = {set}});
  ASSERT_TRUE(meshes->available()) << meshes->unavailable_reason();
  const Eigen::VectorXd q = sim::ReadyConfiguration(panda);
  kinematics::Data kin(panda.model);
  kinematics::CalcForwardKinematics(panda.model, q, &kin);
  std::stringstream xml;
  xml << std::ifstream(set / "panda.urdf").rdbuf();
  std::vector<Eigen::Vector3d> vertices;
  for (const kinematics::LinkShape& s : kinematics::ParseUrdfShapes(xml.str(), panda.model, "panda.urdf")) {
    if (s.visual) continue;
    const setup::TriangleMesh mesh =
        setup::ReadMesh(setup::ResolveMeshUri(s.mesh_uri, set / "panda.urdf", {set}), s.mesh_scale);
    for (Eigen::Index i = 0; i < mesh.p_M.cols(); ++i) {
      vertices.push_back(kin.X_WL[s.link] * s.X_LG * Eigen::Vector3d(mesh.p_M.col(i)));
    }
  }
  // a box of half sizes (2, 2, 1) cm with its z face normal to u, its near face `gap` beyond the meshes' extreme
  // plane along u
  const Eigen::Vector3d half(0.02, 0.02, 0.01);
  auto box_beyond = [&](const Eigen::Vector3d& u, double gap) {
    const Eigen::Vector3d* extreme = &vertices.front();
    for (const Eigen::Vector3d& v : vertices) {
      if (u.dot(v) > u.dot(*extreme)) extreme = &v;
    }
    Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();
    X_WB.linear() = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), u).toRotationMatrix();
    X_WB.translation() = *extreme + (gap + half.z()) * u;
    return X_WB;
  };
  // the first of some directions in which a box 3 mm clear of the meshes enters the capsules
  planning::RrtPolicy capsules(panda, {.check_floor = false, .safety_margin = 0.0});
  MeshCollisionData data(*meshes);
  std::optional<Eigen::Isometry3d> capsule_only;
  for (const Eigen::Vector3d& direction :
       {Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(0, -1, 0), Eigen::Vector3d(0, 0, 1),
        Eigen::Vector3d(1, 0, 1), Eigen::Vector3d(1, 1, 0), Eigen::Vector3d(1, -1, 0), Eigen::Vector3d(-1, 0, 1)}) {
    const Eigen::Isometry3d X_WB = box_beyond(direction.normalized(), 0.003);
    rmp::Scene scene;
    scene.obstacles.push_back(rmp::Obstacle::MakeBox(X_WB, half));
    const MeshClearance mesh = CalcMeshClearance(*meshes, kin, scene.obstacles, &data);
    EXPECT_GE(mesh.distance, 0.003 - 1e-6);
    if (capsules.Clearance(q, scene) < -0.001) {
      capsule_only = X_WB;
      break;
    }
  }
  ASSERT_TRUE(capsule_only) << "no direction in which the capsules reach 3 mm beyond the meshes";
  const fs::path dir = TempDir("referee");
  WriteProblem(dir / "rule_panda", 1, {{"touching_box", box_beyond(Eigen::Vector3d::UnitZ(), -0.005), half}}, q, q);
  WriteProblem(dir / "rule_panda", 2, {{"capsule_only_box", *capsule_only, half}}, q, q);
  const std::vector<MbmProblem> problems = FindMbmProblems(dir);
  MbmOptions options = IterationBudget();
  options.meshes = meshes;
  const std::vector<MbmMethod> methods = {MbmMethod::kRrtConnect, MbmMethod::kRmpflow};
  const std::vector<MbmResult> results = RunMbmBenchmark(panda, problems, methods, options);
  ASSERT_EQ(results.size(), 4u);
  for (const MbmResult& r : results) {
    SCOPED_TRACE(fmt::format("problem {} {}", r.index, r.method));
    EXPECT_FALSE(r.success);
    if (r.index == 1) {
      EXPECT_FALSE(r.valid);
      EXPECT_EQ(r.reason.rfind("start in collision (meshes): ", 0), 0u) << r.reason;
      EXPECT_NE(r.reason.find(" with touching_box ("), std::string::npos) << r.reason;
      EXPECT_NE(r.reason.find(" mm deep)"), std::string::npos) << r.reason;
    } else {
      EXPECT_TRUE(r.valid);
      EXPECT_TRUE(r.rejected);
      EXPECT_EQ(r.reason.rfind("rejected by the model: start in collision in the capsule model: panda_", 0), 0u)
          << r.reason;
      EXPECT_NE(r.reason.find(" with capsule_only_box ("), std::string::npos) << r.reason;
    }
  }
  // in the denominator: 1 valid of 2, rejected, no success
  const std::string table = MbmSummaryTable(results);
  EXPECT_NE(table.find("| rule | rmpflow | 1 of 2 | 1 | 0.0 % [0.0, 79.3] |"), std::string::npos) << table;
  // the capsules alone: the second problem not valid
  options.meshes = nullptr;
  const std::vector<MbmResult> capsule_judged = RunMbmBenchmark(panda, {problems[1]}, {MbmMethod::kRmpflow}, options);
  EXPECT_FALSE(capsule_judged[0].valid);
  EXPECT_EQ(capsule_judged[0].reason.rfind("start in collision in the capsule model: ", 0), 0u)
      << capsule_judged[0].reason;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace rmpmarl::experiments
