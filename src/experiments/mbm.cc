// The MotionBenchMaker benchmark: problems found on disk, each method run in MuJoCo on each, results and report.
#include "rmpmarl/experiments/mbm.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <atomic>
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
#include "rmpmarl/common/random.h"
#include "rmpmarl/control/learned_controller.h"
#include "rmpmarl/control/planning_scene.h"
#include "rmpmarl/control/policy_file.h"
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
    throw InputError(fmt::format("--problems: no sceneNNNN.yaml with a requestNNNN.yaml beside it in the folders of "
                                 "'{}'", dir.string()));
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

// the dynamic variant's spheres (MbmOptions::moving): each passes through the end effector of the open-loop plan's
// execution at a drawn time
std::vector<sim::LinearMotion> CrossingObstacles(const kinematics::Robot& robot, const Eigen::VectorXd& q_start,
                                                 const Eigen::VectorXd& q_goal, const rmp::Scene& scene,
                                                 const MbmOptions& options, std::uint64_t key) {
  planning::RrtPolicy planner(robot, PlannerOf(options, key));
  std::vector<Eigen::VectorXd> path = planner.PlanPath(q_start, q_goal, scene);
  if (path.empty()) path = {q_start, q_goal};  // no plan: the straight way, timed the same
  // timed as PlanFollowPolicy executes a plan open loop: each segment at path_speed_fraction × the velocity limits
  Eigen::VectorXd speeds(robot.model.nq());
  for (int i = 0; i < robot.model.nq(); ++i) {
    speeds[i] = options.plan.planner.path_speed_fraction * robot.model.limits()[i].velocity;
  }
  const std::vector<double> times = planning::PathArrivalTimes(path, speeds);
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
  std::string invalid_reason;
  sim::StaticSceneOptions scene;
};

PreparedProblem Prepare(const kinematics::Robot& robot, const MbmProblem& problem, const MbmOptions& options,
                        std::uint64_t key) {
  PreparedProblem p;
  const control::PlanningScene scene = control::ReadPlanningScene(problem.scene);
  const control::MotionPlanRequest request = control::ReadMotionPlanRequest(problem.request);
  p.scene = sim::StaticSceneOf(robot, scene, &request, problem.request.string());
  rmp::Scene rmp_scene;
  rmp_scene.obstacles = scene.Obstacles();
  rmp::ValidateScene(rmp_scene, problem.scene.string());

  // valid: the capsule model is collision-free at the start and the goal (no floor: the cell's own surfaces count)
  planning::RrtOptions check = options.plan.planner;
  check.check_floor = false;
  check.safety_margin = 0.0;
  planning::RrtPolicy checker(robot, check);
  for (const auto& [what, q] : {std::pair{"start", &p.scene.q_start}, std::pair{"goal", &p.scene.q_goal}}) {
    const double clearance = checker.Clearance(*q, rmp_scene);
    if (!(clearance > 0.0)) {
      p.valid = false;
      p.invalid_reason = fmt::format("{} in collision in the capsule model ({:.1f} mm)", what, 1e3 * clearance);
      return p;
    }
  }
  if (options.moving > 0) {
    p.scene.moving =
        CrossingObstacles(robot, p.scene.q_start, p.scene.q_goal, rmp_scene, options, key);
  }
  return p;
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
  r.invalid_reason = prepared.invalid_reason;
  if (!r.valid) return r;
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
  const sim::EpisodeMetrics m =
      sim::RunEpisode(episode, world, controller, scenario, [&](const sim::FrameInfo& frame) {
        length += (frame.world->q() - q_last).norm();
        q_last = frame.world->q();
      });
  r.success = m.success;
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
  return r;
}

// throws InputError naming the option unless `options` are valid
void ValidateMbmOptions(const MbmOptions& options) {
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
  ValidateMbmOptions(options);
  const PreparedProblem prepared = Prepare(robot, problem, options, MbmProblemKey(problem));
  if (!prepared.valid) {
    throw InputError(fmt::format("{} {}: not a valid problem: {}", problem.family, problem.index,
                                 prepared.invalid_reason));
  }
  return prepared.scene;
}

MbmResult RunMbmProblem(const kinematics::Robot& robot, const MbmProblem& problem, MbmMethod method,
                        const MbmOptions& options) {
  std::optional<control::PolicyFile> file;
  if (Learned(method)) file = control::LoadPolicyFile(options.policy);
  const std::uint64_t key = MbmProblemKey(problem);
  return RunMethod(robot, problem, Prepare(robot, problem, options, key), method, options, key,
                   file ? &*file : nullptr);
}

std::vector<MbmResult> RunMbmBenchmark(const kinematics::Robot& robot, const std::vector<MbmProblem>& problems,
                                       const std::vector<MbmMethod>& methods, const MbmOptions& options,
                                       const std::function<void(int)>& progress) {
  ValidateMbmOptions(options);
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
        // the problem read, checked and its crossings drawn once; every method runs on it
        const std::uint64_t key = MbmProblemKey(problems[p]);
        const PreparedProblem prepared = Prepare(robot, problems[p], options, key);
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

namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const size_t h = v.size() / 2;
  return v.size() % 2 == 1 ? v[h] : 0.5 * (v[h - 1] + v[h]);
}

std::string Num(double v, const char* format) {
  return std::isfinite(v) ? fmt::format(fmt::runtime(format), v) : std::string("–");
}

// Wilson's 95 % interval of k successes in n, in percent
std::pair<double, double> Wilson(int k, int n) {
  if (n == 0) return {std::nan(""), std::nan("")};
  const double z = 1.959963984540054, p = static_cast<double>(k) / n;
  const double d = 1.0 + z * z / n;
  const double c = (p + z * z / (2.0 * n)) / d;
  const double h = z * std::sqrt(p * (1.0 - p) / n + z * z / (4.0 * n * n)) / d;
  return {100.0 * std::max(0.0, c - h), 100.0 * std::min(1.0, c + h)};
}

}  // namespace

std::string MbmSummaryTable(const std::vector<MbmResult>& results) {
  std::vector<std::string> families, methods;
  for (const MbmResult& r : results) {
    if (std::find(families.begin(), families.end(), r.family) == families.end()) families.push_back(r.family);
    if (std::find(methods.begin(), methods.end(), r.method) == methods.end()) methods.push_back(r.method);
  }
  families.push_back("all");
  std::string md =
      "| family | method | valid | success [95 % CI] | with collisions | time to goal (median) | path length "
      "(median) | first plan (median) |\n|---|---|---|---|---|---|---|---|\n";
  for (const std::string& family : families) {
    for (const std::string& method : methods) {
      int valid = 0, success = 0, collided = 0, total = 0;
      std::vector<double> times, lengths, plans;
      for (const MbmResult& r : results) {
        if (r.method != method || (family != "all" && r.family != family)) continue;
        ++total;
        if (!r.valid) continue;
        ++valid;
        success += r.success;
        collided += r.collisions > 0;
        if (r.time_to_goal >= 0.0) times.push_back(r.time_to_goal);
        if (r.success) lengths.push_back(r.path_length);
        if (r.planning_time >= 0.0) plans.push_back(1e3 * r.planning_time);
      }
      if (total == 0) continue;
      const auto [lo, hi] = Wilson(success, valid);
      md += fmt::format("| {} | {} | {} of {} | {} % [{}, {}] | {} | {} s | {} rad | {} ms |\n", family, method, valid,
                        total, Num(valid > 0 ? 100.0 * success / valid : std::nan(""), "{:.1f}"), Num(lo, "{:.1f}"),
                        Num(hi, "{:.1f}"), collided, Num(Median(times), "{:.2f}"), Num(Median(lengths), "{:.2f}"),
                        Num(Median(plans), "{:.1f}"));
    }
  }
  return md;
}

void WriteMbmResults(const std::vector<MbmResult>& results, const fs::path& out, const std::string& command,
                     const std::string& setup) {
  fs::create_directories(out);
  std::ofstream csv(out / "results.csv");
  csv << "family,problem,method,valid,success,reached,collisions,time_to_goal_s,final_error_mm,joint_error_rad,"
         "path_length_rad,min_clearance_mm,planning_time_ms,plans,control_us,invalid_reason\n";
  for (const MbmResult& r : results) {
    // the smallest clearance "nan" where nothing came within the sensing margin, as the experiments' CSVs write it
    const std::string min_clearance =
        std::isfinite(r.min_clearance) ? fmt::format("{:.2f}", 1e3 * r.min_clearance) : std::string("nan");
    csv << fmt::format("{},{},{},{},{},{},{},{:.3f},{:.2f},{:.4f},{:.4f},{},{:.3f},{},{:.2f},{}\n",
                       CsvField(r.family), r.index, r.method, r.valid ? 1 : 0, r.success ? 1 : 0, r.reached ? 1 : 0,
                       r.collisions, r.time_to_goal, 1e3 * r.final_error, r.joint_error, r.path_length,
                       min_clearance,
                       r.planning_time >= 0.0 ? 1e3 * r.planning_time : -1.0, r.plans, r.control_us,
                       CsvField(r.invalid_reason));
  }
  if (!csv) throw InputError(fmt::format("could not write '{}'", (out / "results.csv").string()));
  csv.close();
  const std::vector<std::string> plots = MakePlots("mbm", out);
  std::ofstream md(out / "report.md");
  md << "# MotionBenchMaker benchmark\n\n" << "Command: `" << command << "`\n\n" << setup << "\n\n"
     << MbmSummaryTable(results) << "\n";
  for (const std::string& png : plots) md << "![" << png << "](" << png << ")\n\n";
  std::vector<std::string> invalid;
  for (const MbmResult& r : results) {
    if (!r.valid && r.method == results.front().method) {
      invalid.push_back(fmt::format("{} {}: {}", r.family, r.index, r.invalid_reason));
    }
  }
  if (!invalid.empty()) {
    md << "Problems not run (" << invalid.size() << "):\n\n";
    for (const std::string& s : invalid) md << "- " << s << "\n";
  }
  if (!md) throw InputError(fmt::format("could not write '{}'", (out / "report.md").string()));
}

}  // namespace rmpmarl::experiments
