// The MotionBenchMaker benchmark: problems found on disk, each method run in MuJoCo on each (its results table and
// report: mbm_report.cc).
#include "rmpmarl/experiments/mbm.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <random>
#include <regex>
#include <set>
#include <thread>

#include "report.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/collision/checker.h"
#include "rmpmarl/common/random.h"
#include "rmpmarl/control/learned_controller.h"
#include "rmpmarl/planning/planning_scene.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/experiments/statistics.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/sim/episode.h"
#include "rmpmarl/sim/scenario.h"

namespace rmpmarl::experiments {
namespace fs = std::filesystem;

namespace {

// the folder's name without a trailing `_<robot>` (bookshelf_small_panda → bookshelf_small)
std::string FamilyOf(const std::string& folder) {
  const size_t cut = folder.rfind('_');
  return cut == std::string::npos || cut == 0 ? folder : folder.substr(0, cut);
}

constexpr MbmMethod kMethods[] = {MbmMethod::kRrtConnect, MbmMethod::kRmpflow, MbmMethod::kLearned,
                                  MbmMethod::kPlanRmpflow, MbmMethod::kPlanLearned};

}  // namespace

std::string MbmMethodName(MbmMethod method) {
  switch (method) {
    case MbmMethod::kRrtConnect: return "rrt-connect";
    case MbmMethod::kRmpflow: return "rmpflow";
    case MbmMethod::kLearned: return "learned";
    case MbmMethod::kPlanRmpflow: return "plan+rmpflow";
    case MbmMethod::kPlanLearned: return "plan+learned";
  }
  return "?";
}

MbmMethod ParseMbmMethod(const std::string& name) {
  for (MbmMethod m : kMethods) {
    if (MbmMethodName(m) == name) return m;
  }
  std::vector<std::string> names;
  for (MbmMethod m : kMethods) names.push_back(MbmMethodName(m));
  throw InputError(fmt::format("--methods: expected some of {}, got '{}'", fmt::join(names, ", "), name));
}

std::vector<MbmMethod> AllMbmMethods() { return {std::begin(kMethods), std::end(kMethods)}; }

std::vector<MbmProblem> FindMbmProblems(const fs::path& dir, const std::vector<std::string>& families, int limit) {
  if (!fs::is_directory(dir)) {
    throw InputError(fmt::format("--problems: expected a folder of problem folders, got '{}'", dir.string()));
  }
  std::vector<fs::path> folders;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.is_directory()) folders.push_back(entry.path());
  }
  std::sort(folders.begin(), folders.end());
  const std::regex scene_name(R"(scene(\d+)\.yaml)");
  std::vector<MbmProblem> problems;
  std::set<std::string> found;
  for (const fs::path& folder : folders) {
    const std::string family = FamilyOf(folder.filename().string());
    if (!families.empty() && std::find(families.begin(), families.end(), family) == families.end()) continue;
    std::vector<MbmProblem> here;
    for (const auto& entry : fs::directory_iterator(folder)) {
      std::smatch m;
      const std::string name = entry.path().filename().string();
      if (!std::regex_match(name, m, scene_name)) continue;
      const fs::path request = folder / ("request" + m[1].str() + ".yaml");
      if (!fs::exists(request)) continue;
      here.push_back({family, std::stoi(m[1].str()), entry.path(), request});
    }
    std::sort(here.begin(), here.end(), [](const MbmProblem& a, const MbmProblem& b) { return a.index < b.index; });
    if (limit > 0 && static_cast<int>(here.size()) > limit) here.resize(limit);
    if (!here.empty()) found.insert(family);
    problems.insert(problems.end(), here.begin(), here.end());
  }
  for (const std::string& f : families) {
    if (!found.contains(f)) {
      throw InputError(fmt::format("--families: no problems of family '{}' under '{}'", f, dir.string()));
    }
  }
  if (problems.empty()) {
    // an archive of the problems beside nothing unpacked: say how to unpack it
    std::string archive;
    for (const auto& entry : fs::directory_iterator(dir)) {
      const std::string name = entry.path().filename().string();
      for (const char* suffix : {".tar.bz2", ".tar.gz", ".tgz", ".tar.xz", ".tar"}) {
        if (archive.empty() && name.ends_with(suffix)) archive = entry.path().string();
      }
    }
    const std::string hint =
        archive.empty() ? ""
                        : fmt::format("; '{}' there is an archive: unpack it first (tar xf '{}' -C <folder>) and pass "
                                      "the folder of family folders it makes (e.g. <folder>/problems)",
                                      archive, archive);
    throw InputError(fmt::format("--problems: no sceneNNNN.yaml with a requestNNNN.yaml beside it in the folders of "
                                 "'{}'{}", dir.string(), hint));
  }
  return problems;
}

std::uint64_t MbmProblemKey(const MbmProblem& problem) {
  std::uint64_t h = 0xcbf29ce484222325ULL;  // FNV-1a of the family's name
  for (const unsigned char c : problem.family) h = (h ^ c) * 0x100000001b3ULL;
  return SplitMix64(h ^ static_cast<std::uint64_t>(problem.index));
}

namespace {

// the planner options of a problem of key `key` (MbmProblemKey; the open-loop method's and the crossings')
planning::RrtOptions PlannerOf(const MbmOptions& options, std::uint64_t key) {
  planning::RrtOptions planner = options.plan.planner;
  planner.check_floor = false;
  planner.seed = options.seed + key;
  return planner;
}

// each joint's speed when a plan is executed open loop: path_speed_fraction × its velocity limit
Eigen::VectorXd PathSpeeds(const kinematics::Robot& robot, const MbmOptions& options) {
  Eigen::VectorXd speeds(robot.model.nq());
  for (int i = 0; i < robot.model.nq(); ++i) {
    speeds[i] = options.plan.planner.path_speed_fraction * robot.model.limits()[i].velocity;
  }
  return speeds;
}

// the dynamic variant's spheres (MbmOptions::moving): each passes through the end effector of the open-loop plan's
// execution at a drawn time
std::vector<sim::LinearMotion> CrossingObstacles(const kinematics::Robot& robot, const Eigen::VectorXd& q_start,
                                                 const Eigen::VectorXd& q_goal, const rmp::Scene& scene,
                                                 const MbmOptions& options, std::uint64_t key) {
  planning::RrtPolicy planner(robot, PlannerOf(options, key));
  std::vector<Eigen::VectorXd> path = planner.PlanPath(q_start, q_goal, scene);
  if (path.empty()) path = {q_start, q_goal};  // no plan: the straight way, timed the same
  // timed as PlanFollowPolicy executes a plan open loop
  const std::vector<double> times = planning::PathArrivalTimes(path, PathSpeeds(robot, options));
  std::mt19937_64 rng(options.crossing_seed * 0x9E3779B97F4A7C15ULL + key);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  kinematics::Data data(robot.model);
  // the arm's capsules at the start and at the goal: a sphere's way keeps clear of both
  std::vector<math::Capsule> ends;
  for (const Eigen::VectorXd* q_end : {&q_start, &q_goal}) {
    kinematics::CalcForwardKinematics(robot.model, *q_end, &data);
    for (const kinematics::LinkCapsule& lc : robot.capsules) ends.push_back(kinematics::WorldCapsule(lc, data));
  }
  Eigen::VectorXd q, qd;
  std::vector<sim::LinearMotion> moving;
  for (int k = 0; k < options.moving; ++k) {
    double t = (0.25 + 0.5 * unit(rng)) * times.back();
    double heading = 2.0 * M_PI * unit(rng);
    const double speed = options.speed_min + (options.speed_max - options.speed_min) * unit(rng);
    sim::LinearMotion m;
    m.spec = sim::ObstacleSpec::Sphere(options.moving_radius);
    double best = -std::numeric_limits<double>::infinity();
    for (int attempt = 0; attempt < 64; ++attempt) {
      if (attempt > 0) {
        t = (0.25 + 0.5 * unit(rng)) * times.back();
        heading = 2.0 * M_PI * unit(rng);
      }
      planning::SamplePath(path, times, t, &q, &qd);
      kinematics::CalcForwardKinematics(robot.model, q, &data);
      const Eigen::Vector3d p = kinematics::CalcPointPosition(data, robot.end_effector.link,
                                                              robot.end_effector.X_LE.translation());
      const Eigen::Vector3d v_W = speed * Eigen::Vector3d(std::cos(heading), std::sin(heading), 0.0);
      const Eigen::Vector3d p_W0 = p - t * v_W;
      // the sphere's way over the episode: a capsule of its radius
      const math::Capsule way{p_W0, p_W0 + options.duration * v_W, options.moving_radius};
      double clearance = std::numeric_limits<double>::infinity();
      for (const math::Capsule& c : ends) clearance = std::min(clearance, math::CapsuleCapsuleDistance(c, way).distance);
      if (clearance > best) {
        best = clearance;
        m.v_W = v_W;
        m.p_W0 = p_W0;
      }
      if (clearance >= options.crossing_clearance) break;
    }
    moving.push_back(m);
  }
  return moving;
}

bool Learned(MbmMethod m) { return m == MbmMethod::kLearned || m == MbmMethod::kPlanLearned; }

// what every method of a problem runs on: its start, joint goal, obstacles and crossings, or why it is not run
struct PreparedProblem {
  bool valid = true;
  bool rejected = false;  // valid on the meshes, in collision on the capsules at an end
  std::string reason;     // why not valid or rejected
  sim::StaticSceneOptions scene;
  // per obstacle of the episode's scene (the cell's primitives in file order, then the crossing spheres): its name
  // in the messages — the planning scene's object id, with the primitive's number when the object has several
  std::vector<std::string> obstacle_names;
};

// "<link> with <link or obstacle>" of a capsule pair
std::string CapsulePairName(const kinematics::Robot& robot, const planning::ClearancePair& pair,
                            const std::vector<std::string>& obstacle_names) {
  const std::string link = pair.link >= 0 ? robot.model.link(pair.link).name : std::string("?");
  switch (pair.kind) {
    case planning::ClearancePair::Kind::kObstacle:
      return fmt::format("{} with {}", link, obstacle_names[pair.obstacle]);
    case planning::ClearancePair::Kind::kSelf:
      return fmt::format("{} with {}", link, robot.model.link(pair.other_link).name);
    case planning::ClearancePair::Kind::kFloor: return fmt::format("{} with the floor", link);
    case planning::ClearancePair::Kind::kNone: break;
  }
  return "nothing";
}

PreparedProblem Prepare(const kinematics::Robot& robot, const MbmProblem& problem, const MbmOptions& options,
                        std::uint64_t key) {
  PreparedProblem p;
  const planning::PlanningScene scene = planning::ReadPlanningScene(problem.scene, robot.model.link(0).name);
  const planning::MotionPlanRequest request = planning::ReadMotionPlanRequest(problem.request);
  p.scene = sim::StaticSceneOf(robot, scene, &request, problem.request.string());
  rmp::Scene rmp_scene;
  rmp_scene.obstacles = scene.Obstacles();
  rmp::ValidateScene(rmp_scene, problem.scene.string());
  for (size_t i = 0; i < scene.objects.size(); ++i) {
    const planning::SceneObject& object = scene.objects[i];
    const std::string id = object.id.empty() ? fmt::format("object {}", i + 1) : object.id;
    for (size_t j = 0; j < object.primitives.size(); ++j) {
      p.obstacle_names.push_back(object.primitives.size() == 1 ? id : fmt::format("{} (primitive {})", id, j + 1));
    }
  }
  const std::pair<const char*, const Eigen::VectorXd*> ends[] = {{"start", &p.scene.q_start},
                                                                 {"goal", &p.scene.q_goal}};
  // the ends within the joint limits: the simulated arm cannot start beyond one, nor stop at a goal beyond one
  for (const auto& [what, q] : ends) {
    kinematics::CheckJointVector(robot.model, *q, what);
    for (int i = 0; i < robot.model.nq(); ++i) {
      const kinematics::DofLimits& limits = robot.model.limits()[i];
      if (!((*q)[i] >= limits.lower && (*q)[i] <= limits.upper)) {
        p.valid = false;
        p.reason = fmt::format("{} outside the joint limits: {} = {:.6g}, limits [{:.6g}, {:.6g}]", what,
                               robot.model.dof_name(i), (*q)[i], limits.lower, limits.upper);
        return p;
      }
    }
  }

  // valid, with the mesh referee: the collision meshes are clear of the cell at the start and the goal
  double mesh_clearance[2] = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  if (options.meshes) {
    MeshCollisionData data(*options.meshes);
    kinematics::Data kin(robot.model);
    for (int e = 0; e < 2; ++e) {
      const auto& [what, q] = ends[e];
      kinematics::CalcForwardKinematics(robot.model, *q, &kin);
      const MeshClearance c = CalcMeshClearance(*options.meshes, kin, rmp_scene.obstacles, &data);
      mesh_clearance[e] = c.distance;
      if (c.in_collision()) {
        p.valid = false;
        p.reason = fmt::format("{} in collision (meshes): {} with {} ({:.1f} mm deep)", what,
                               robot.model.link(c.link).name, p.obstacle_names[c.obstacle], -1e3 * c.distance);
        return p;
      }
      const MeshSelfContact self = CheckMeshSelfCollision(*options.meshes, kin, &data);
      if (self.in_collision()) {
        p.valid = false;
        p.reason = fmt::format("{} in self-collision (meshes): {} with {}", what, robot.model.link(self.link).name,
                               robot.model.link(self.other_link).name);
        return p;
      }
    }
  }
  // the capsule model collision-free at the start and the goal (no floor: the cell's own surfaces count): without
  // the mesh referee the problem is valid then; with it, a problem the capsules put in collision is the model's
  // failure (rejected by the model, counted)
  const collision::RobotCollisionModel checker(robot, {/*check_floor=*/false, 0.0});
  collision::RobotCollisionData placed(checker);
  for (int e = 0; e < 2; ++e) {
    const auto& [what, q] = ends[e];
    const collision::ClearancePair pair = collision::CalcRobotClearance(checker, *q, rmp_scene.obstacles, &placed);
    if (!(pair.distance > 0.0)) {
      const std::string why = fmt::format("{} in collision in the capsule model: {} ({:.1f} mm deep)", what,
                                          CapsulePairName(robot, pair, p.obstacle_names), -1e3 * pair.distance);
      if (options.meshes) {
        // how far the meshes are from the scene there: what a tighter model has to gain
        const std::string meshes = std::isfinite(mesh_clearance[e])
                                       ? fmt::format("{:.1f} mm", 1e3 * mesh_clearance[e])
                                       : fmt::format("> {:.0f} mm", 1e3 * options.meshes->options().distance_cap);
        p.rejected = true;
        p.reason = fmt::format("rejected by the model: {}; the meshes' clearance {}", why, meshes);
      } else {
        p.valid = false;
        p.reason = why;
      }
      return p;
    }
  }
  if (options.moving > 0) {
    p.scene.moving =
        CrossingObstacles(robot, p.scene.q_start, p.scene.q_goal, rmp_scene, options, key);
    for (size_t k = 0; k < p.scene.moving.size(); ++k) {
      p.obstacle_names.push_back(fmt::format("crossing sphere {}", k + 1));
    }
  }
  return p;
}

// why a run that was not a success failed, most telling first: it collided (capsules, meshes); a plan-based method
// never had a plan (and why); it did not reach the goal in time because the plan's execution at the path speed takes
// longer than the run, or because it stopped short
std::string FailureReason(const kinematics::Robot& robot, const MbmResult& r, const sim::EpisodeMetrics& m,
                          const planning::PlanFollowPolicy* follower, const MbmOptions& options) {
  if (r.collisions > 0 || r.mesh_collisions > 0) {
    return r.mesh_collisions >= 0
               ? fmt::format("collided: {} collision events on the capsules, {} control steps in collision on the "
                             "meshes", r.collisions, r.mesh_collisions)
               : fmt::format("collided: {} collision events on the capsules", r.collisions);
  }
  if (follower != nullptr && follower->stats().plans_succeeded == 0) {
    const planning::PlanFollowStats& s = follower->stats();
    return fmt::format("no plan: {} ({} attempts)", planning::PlanOutcomeName(s.last_outcome), s.plans_attempted);
  }
  if (follower != nullptr && !follower->path().empty()) {
    const double needs = planning::PathArrivalTimes(follower->path(), PathSpeeds(robot, options)).back();
    if (!r.reached && r.planning_time >= 0.0 && r.planning_time + needs > options.duration) {
      return fmt::format("timed out: the plan takes {:.1f} s at {:.0f} % of the velocity limits, the run lasts {:.1f} s "
                         "(--duration)", needs, 100.0 * options.plan.planner.path_speed_fraction, options.duration);
    }
  }
  if (!r.reached) {
    return fmt::format("stopped short: the end effector {:.1f} mm from the goal's at the end (tolerance {:.1f} mm)",
                       1e3 * m.final_tracking_error, 1e3 * options.goal_tolerance);
  }
  return fmt::format("not settled: reached, but {:.1f} mm from the goal's at the end", 1e3 * m.final_tracking_error);
}

// one method on a prepared problem; `policy` is the learned controller's file (learned methods only)
MbmResult RunMethod(const kinematics::Robot& robot, const MbmProblem& problem, const PreparedProblem& prepared,
                    MbmMethod method, const MbmOptions& options, std::uint64_t key,
                    const control::PolicyFile* policy_file) {
  MbmResult r;
  r.family = problem.family;
  r.index = problem.index;
  r.method = MbmMethodName(method);
  r.valid = prepared.valid;
  r.rejected = prepared.rejected;
  r.reason = prepared.reason;
  if (!r.valid || r.rejected) return r;
  const sim::StaticSceneOptions& static_scene = prepared.scene;
  const int num_obstacles = static_cast<int>(static_scene.obstacles.size() + static_scene.moving.size());
  sim::StaticScenario scenario(robot, static_scene);
  sim::WorldOptions world_options;
  world_options.warning_margin = 0.0;
  world_options.servo.inverse_dynamics_feedforward = options.servo_feedforward;
  auto world_model = std::make_shared<const sim::WorldModel>(robot, scenario.scene_spec(), world_options);
  sim::World world(world_model);

  // the controller: its acceleration policy and options
  control::ControllerOptions controller_options;
  std::unique_ptr<control::AccelerationPolicy> reactive;
  if (Learned(method)) {
    RMPMARL_ASSERT(policy_file != nullptr, "RunMethod: a learned method without its controller file");
    auto policy = control::MakeLearnedController(robot, *policy_file, options.policy.string(), num_obstacles);
    controller_options = policy->controller_options();
    reactive = std::move(policy);
  } else if (method != MbmMethod::kRrtConnect) {
    reactive = std::make_unique<control::RmpflowAccelerationPolicy>(robot, num_obstacles);
  }
  std::unique_ptr<control::AccelerationPolicy> policy;
  planning::PlanFollowPolicy* follower = nullptr;
  if (method == MbmMethod::kRmpflow || method == MbmMethod::kLearned) {
    policy = std::move(reactive);
  } else {  // without a reactive layer (rrt-connect) the follower executes its one plan open loop
    planning::PlanFollowOptions plan = options.plan;
    plan.planner = PlannerOf(options, key);
    auto f = planning::MakePlanFollower(robot, std::move(reactive), controller_options, plan);
    follower = f.get();
    policy = std::move(f);
  }
  control::ReactiveController controller(world_model->servos(), std::move(policy), controller_options);

  sim::EpisodeOptions episode;
  episode.duration = options.duration;
  episode.loop.reach_tolerance = options.goal_tolerance;
  episode.loop.success_max_final_error = options.goal_tolerance;
  episode.video_fps = controller_options.control_rate;  // a frame per control step: the executed path
  Eigen::VectorXd q_last = static_scene.q_start;
  double length = 0.0;
  // the mesh referee at every control step (a frame per control step): the arm's meshes at the loop's kinematics of
  // the world's state against the obstacles where the loop's scene has them now
  std::optional<MeshCollisionData> mesh_data;
  if (options.meshes) {
    mesh_data.emplace(*options.meshes);
    r.mesh_collisions = 0;
  }
  double mesh_seconds = 0.0;
  int mesh_steps = 0;
  const sim::EpisodeMetrics m =
      sim::RunEpisode(episode, world, controller, scenario, [&](const sim::FrameInfo& frame) {
        length += (frame.world->q() - q_last).norm();
        q_last = frame.world->q();
        if (!mesh_data) return;
        const auto start = std::chrono::steady_clock::now();
        const MeshClearance c =
            CalcMeshClearance(*options.meshes, *frame.kinematics, frame.scene->obstacles, &*mesh_data);
        const bool self = CheckMeshSelfCollision(*options.meshes, *frame.kinematics, &*mesh_data).in_collision();
        mesh_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        ++mesh_steps;
        if (c.in_collision() || self) ++r.mesh_collisions;
        if (c.distance < r.min_mesh_clearance) {
          r.min_mesh_clearance = c.distance;
          r.min_mesh_pair =
              fmt::format("{} with {}", robot.model.link(c.link).name, prepared.obstacle_names[c.obstacle]);
        }
      });
  if (mesh_steps > 0) r.mesh_check_us = 1e6 * mesh_seconds / mesh_steps;
  // success: the goal reached without a collision on the capsules and, with the mesh referee, on the meshes
  r.success = m.success && r.mesh_collisions <= 0;
  r.reached = m.reached;
  r.collisions = m.collisions;
  r.time_to_goal = m.time_to_reach;
  r.final_error = m.final_tracking_error;
  r.joint_error = (world.q() - static_scene.q_goal).cwiseAbs().maxCoeff();
  r.path_length = length;
  r.min_clearance = m.min_clearance;
  r.control_us = m.mean_control_us;
  if (follower != nullptr) {
    const planning::PlanFollowStats& s = follower->stats();
    r.plans = s.plans_attempted;
    if (!s.planning_times_s.empty()) r.planning_time = s.planning_times_s.front();
  }
  if (!r.success) r.reason = FailureReason(robot, r, m, follower, options);
  return r;
}

// throws InputError naming the option unless `options` are valid for `robot`
void ValidateMbmOptions(const kinematics::Robot& robot, const MbmOptions& options) {
  if (options.meshes && !options.meshes->available()) {
    throw InputError("MbmOptions.meshes: expected an available mesh model, got one without collision meshes: " +
                     options.meshes->unavailable_reason());
  }
  if (options.meshes && options.meshes->num_links() != robot.model.num_links()) {
    throw InputError(fmt::format("MbmOptions.meshes: expected the mesh model of robot '{}' ({} links), got one of {} "
                                 "links", robot.name, robot.model.num_links(), options.meshes->num_links()));
  }
  for (int k = 0; options.meshes && k < robot.model.num_links(); ++k) {
    if (options.meshes->link_name(k) != robot.model.link(k).name) {
      throw InputError(fmt::format("MbmOptions.meshes: expected the mesh model of robot '{}' (link {} '{}'), got one "
                                   "whose link {} is '{}'", robot.name, k, robot.model.link(k).name, k,
                                   options.meshes->link_name(k)));
    }
  }
  if (!(options.duration > 0.0) || !std::isfinite(options.duration)) {
    throw InputError(fmt::format("--duration: expected a time > 0 s, got {}", options.duration));
  }
  if (!(options.goal_tolerance > 0.0) || !std::isfinite(options.goal_tolerance)) {
    throw InputError(fmt::format("--goal-tolerance: expected a distance > 0 m, got {}", options.goal_tolerance));
  }
  planning::ValidatePlanFollowOptions(options.plan);
  if (options.moving < 0 || options.moving > 64) {
    throw InputError(fmt::format("--moving: expected 0 to 64 crossing obstacles, got {}", options.moving));
  }
  if (!(options.speed_min > 0.0) || !(options.speed_max >= options.speed_min) || !std::isfinite(options.speed_max)) {
    throw InputError(fmt::format("--speed: expected 0 < min <= max, got {} … {} m/s", options.speed_min,
                                 options.speed_max));
  }
  if (!(options.crossing_clearance >= 0.0) || !std::isfinite(options.crossing_clearance)) {
    throw InputError(fmt::format("crossing_clearance: expected a distance >= 0 m, got {}", options.crossing_clearance));
  }
  if (!(options.moving_radius > 0.0) || !std::isfinite(options.moving_radius)) {
    throw InputError(fmt::format("moving_radius: expected a radius > 0 m, got {}", options.moving_radius));
  }
}

}  // namespace

sim::StaticSceneOptions MbmProblemScene(const kinematics::Robot& robot, const MbmProblem& problem,
                                        const MbmOptions& options) {
  ValidateMbmOptions(robot, options);
  const PreparedProblem prepared = Prepare(robot, problem, options, MbmProblemKey(problem));
  if (!prepared.valid || prepared.rejected) {
    throw InputError(fmt::format("{} {}: {}: {}", problem.family, problem.index,
                                 prepared.valid ? "not run" : "not a valid problem", prepared.reason));
  }
  return prepared.scene;
}

MbmResult RunMbmProblem(const kinematics::Robot& robot, const MbmProblem& problem, MbmMethod method,
                        const MbmOptions& options) {
  ValidateMbmOptions(robot, options);
  std::optional<control::PolicyFile> file;
  if (Learned(method)) file = control::LoadPolicyFile(options.policy);
  const std::uint64_t key = MbmProblemKey(problem);
  return RunMethod(robot, problem, Prepare(robot, problem, options, key), method, options, key,
                   file ? &*file : nullptr);
}

std::vector<MbmResult> RunMbmBenchmark(const kinematics::Robot& robot, const std::vector<MbmProblem>& problems,
                                       const std::vector<MbmMethod>& methods, const MbmOptions& options,
                                       const std::function<void(int)>& progress) {
  ValidateMbmOptions(robot, options);
  // the learned controller's file read once for every problem
  std::optional<control::PolicyFile> policy_file;
  if (std::any_of(methods.begin(), methods.end(), Learned)) policy_file = control::LoadPolicyFile(options.policy);
  const size_t n = problems.size() * methods.size();
  std::vector<MbmResult> results(n);
  std::atomic<size_t> next{0};
  std::atomic<int> done{0};
  std::mutex progress_mutex;
  std::exception_ptr error;
  std::mutex error_mutex;
  auto work = [&]() {
    for (size_t p; (p = next.fetch_add(1)) < problems.size();) {
      try {
        // the problem read, checked and its crossings drawn once; every method runs on it. A problem whose files
        // cannot be read or do not fit the robot is not valid, with why; the others still run
        const std::uint64_t key = MbmProblemKey(problems[p]);
        PreparedProblem prepared;
        try {
          prepared = Prepare(robot, problems[p], options, key);
        } catch (const InputError& e) {
          prepared = PreparedProblem{};
          prepared.valid = false;
          prepared.reason = fmt::format("could not be read: {}", e.what());
        }
        for (size_t k = 0; k < methods.size(); ++k) {
          results[p * methods.size() + k] = RunMethod(robot, problems[p], prepared, methods[k], options, key,
                                                      policy_file ? &*policy_file : nullptr);
        }
      } catch (...) {
        std::lock_guard lock(error_mutex);
        if (!error) error = std::current_exception();
        next = problems.size();
        return;
      }
      const int d = ++done;
      if (progress) {
        std::lock_guard lock(progress_mutex);
        progress(d);
      }
    }
  };
  const int jobs = std::max(1, std::min<int>(options.jobs, static_cast<int>(problems.size())));
  std::vector<std::thread> threads;
  for (int j = 1; j < jobs; ++j) threads.emplace_back(work);
  work();
  for (std::thread& t : threads) t.join();
  if (error) std::rethrow_exception(error);
  return results;
}

}  // namespace rmpmarl::experiments
