// The paper's experiments, one command each (experiments.h, docs/experiments.md).
#include "rmpmarl/experiments/experiments.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <map>
#include <set>
#include <functional>

#include <yaml-cpp/yaml.h>

#include "rmpmarl/common/yaml_reader.h"
#include "figures.h"
#include "report.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/experiments/evaluation.h"
#include "rmpmarl/experiments/methods.h"
#include "rmpmarl/experiments/runs.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/tasks/task_config.h"
#include "rmpmarl/sim/scenario.h"

namespace rmpmarl::experiments {
namespace fs = std::filesystem;

namespace {

/// obstacle slots of every experiment task: the global state (PPO's observation, the critics') must have the same
/// size on reach-avoid (training, 1–4 cubes), line-crossing (5) and cluttered (6).
constexpr int kObstacleSlots = 6;

/// merges YAML flow mappings ("" ones skipped; later ones win; nested mappings merge key by key, so two parts may both
/// set keys of one section) into one flow mapping ("" when every part is empty): a run's task overrides
std::string MergeOverrides(const std::vector<std::string>& parts) {
  YAML::Node merged(YAML::NodeType::Map);
  for (const std::string& p : parts) {
    if (p.empty()) continue;
    YAML::Node node;
    try {
      node = YAML::Load(p);
    } catch (const YAML::Exception& e) {
      throw InputError(fmt::format("training run task overrides: malformed YAML '{}': {}", p, e.msg));
    }
    internal::MergeYamlMaps(merged, node, "training run task overrides");
  }
  if (merged.size() == 0) return "";
  YAML::Emitter out;
  out << YAML::Flow << merged;
  return out.c_str();
}

std::string RunId(const std::string& prefix, int seed) { return fmt::format("{}-seed{}", prefix, seed); }

/// the shipped policy of a learned method (models/policies/, written by scripts/ship-policies); "" when it has none.
fs::path ShippedPolicy(const MethodSpec& m) {
  if (m.shipped.empty()) return {};
  return ConfigsDirectory().parent_path() / "models" / "policies" / m.shipped;
}

/// training budgets in updates (of 16 envs × 128 steps): "full" is what the shipped policies were trained with,
/// "short" half of it (table4 with training in under an hour on 2 cores), --quick a few updates.
struct Budgets {
  int pretrain = 600;  ///< two-link pre-training (the paper's 15K, see table3)
  int panda = 300;     ///< reach-avoid training
};

Budgets BudgetsFor(const ExperimentOptions& o) {
  if (o.quick) return {3, 2};
  if (o.budget == "full") return {1200, 600};
  return {};
}

/// the runs of the learned methods in `keys` (and their pre-training) for seeds 1..N.
std::vector<TrainingRun> RunsFor(const std::vector<std::string>& keys, int seeds, const Budgets& b) {
  // every pre-training run keeps the 1/3 and 2/3 budget snapshots (Table 3's 5K and 10K), whichever experiment
  // trains it first
  const std::vector<int> pretrain_snapshots = {b.pretrain / 3, 2 * b.pretrain / 3};
  std::vector<TrainingRun> runs;
  std::set<std::string> added;
  std::function<void(const MethodSpec&, int)> add = [&](const MethodSpec& m, int seed) {
    const std::string id = RunId(m.key, seed);
    if (added.count(id)) return;
    const TrainingRecipe& r = *m.training;
    std::string init;
    if (!r.init.empty()) {
      const MethodSpec& p = FindMethod(r.init);
      if (p.kind != MethodSpec::Kind::kLearned) {
        throw InputError(fmt::format("{}: key 'train.init': '{}' is not a learned method", m.file.string(), r.init));
      }
      add(p, seed);
      init = RunId(p.key, seed);
    }
    TrainingRun run;
    run.id = id;
    run.base_config = TrainConfigPath(r.config).string();
    run.seed = static_cast<std::uint64_t>(seed);
    run.total_updates = r.two_link ? b.pretrain : b.panda;
    if (r.updates > 0) run.total_updates = std::min(run.total_updates, r.updates);
    if (r.two_link) run.snapshot_updates = pretrain_snapshots;
    run.init_from = init;
    const std::string slots = r.two_link ? "" : fmt::format("{{observation: {{max_obstacles: {}}}}}", kObstacleSlots);
    auto parts = [&](const std::string& own) { return MergeOverrides({slots, m.layer_yaml, own, r.reward}); };
    run.task_overrides = parts(r.overrides);
    if (!r.mix_task.empty()) {
      run.mix_task = r.mix_task;
      run.mix_overrides = parts(r.mix_overrides);
    }
    runs.push_back(run);
    added.insert(id);
  };
  for (const std::string& k : keys) {
    for (int s = 1; s <= seeds; ++s) add(FindMethod(k), s);
  }
  return runs;
}


tasks::TaskConfig ExperimentTask(const std::string& name, bool quick) {
  tasks::TaskConfig task = tasks::LoadShippedTaskConfig(name);
  if (name != "pretrain-2link") task.observation.max_obstacles = kObstacleSlots;
  if (quick) task.episode.max_steps = std::min(task.episode.max_steps, 150);
  return task;
}

/// Table 3's split of the episodes: where the target option alone passes the cube ("free") and where tracking the
/// target drives a link into it ("blocked"), for the untrained rows and the learned ones at `budget` (training seeds
/// pooled). "" when the target option's row is not among `rows`.
std::string Table3Split(const std::vector<ResultRow>& rows, const std::string& budget) {
  const std::string reference = FindMethod("basic").label;  // the target option at every joint
  const auto ref = std::find_if(rows.begin(), rows.end(), [&](const ResultRow& r) { return r.method == reference; });
  if (ref == rows.end()) return "";
  std::vector<std::string> order;
  std::map<std::string, std::vector<EpisodeRecord>> pooled;
  for (const ResultRow& r : rows) {
    if (r.train_seed != 0 && r.condition != budget) continue;
    const std::string name = r.train_seed != 0 ? fmt::format("{} ({})", r.method, budget) : r.method;
    if (!pooled.count(name)) order.push_back(name);
    pooled[name].insert(pooled[name].end(), r.episodes.begin(), r.episodes.end());
  }
  const EpisodeSplit counts = SplitByReference(ref->episodes, ref->episodes);
  std::string out = fmt::format(
      "\n## Where the cube blocks the arm\n\nThe episodes split by what the target option alone (`{}`) does on them: "
      "**free** ({} episodes): it tracks past the cube without a collision; **blocked** ({}): tracking the target "
      "drives a link into the cube, so every controller that avoids it must leave the target there. Success and mean "
      "settled tracking error (t ≥ 1 s) over each part, training seeds pooled.\n\n"
      "| method | free: success | free: settled mm | blocked: success | blocked: settled mm |\n|---|---|---|---|---|\n",
      reference, counts.free_count, counts.blocked_count);
  for (const std::string& name : order) {
    const EpisodeSplit s = SplitByReference(pooled[name], ref->episodes);
    out += fmt::format("| {} | {:.1f} % | {:.1f} | {:.1f} % | {:.1f} |\n", name, 100.0 * s.free_success,
                       s.free_settled_mm, 100.0 * s.blocked_success, s.blocked_settled_mm);
  }
  return out;
}

/// the method whose episodes split fig5's rows: a pure tracker on the stiff coupled layer
constexpr const char* kPureTracker = "basic-target-v2c-stiff";

/// Fig. 5's split of each arm's episodes by what the pure tracker (kPureTracker) does on them: **free**, it
/// tracks past the cube without a collision; **blocked**, tracking the target drives a link into the cube. Per method
/// (training seeds pooled) and arm: mean settled tracking error and success over each part. "" when the reference is
/// not among `rows`.
std::string Fig5Split(const std::vector<ResultRow>& rows) {
  std::map<std::string, const ResultRow*> reference;  // arm -> the pure tracker's row
  const std::string tracker = FindMethod(kPureTracker).label;
  for (const ResultRow& r : rows) {
    if (r.method == tracker) reference[r.condition] = &r;
  }
  if (reference.empty()) return "";
  std::vector<std::string> order, arms;
  std::map<std::pair<std::string, std::string>, std::vector<EpisodeRecord>> pooled;  // (method, arm) -> episodes
  for (const ResultRow& r : rows) {
    if (!reference.count(r.condition)) continue;
    if (std::find(order.begin(), order.end(), r.method) == order.end()) order.push_back(r.method);
    if (std::find(arms.begin(), arms.end(), r.condition) == arms.end()) arms.push_back(r.condition);
    auto& e = pooled[{r.method, r.condition}];
    e.insert(e.end(), r.episodes.begin(), r.episodes.end());
  }
  std::string out = fmt::format(
      "\n## Where the cube blocks the arm\n\nEach arm's episodes split by what a pure tracker (`{}`) does on them: "
      "**free**: it tracks past the cube without a collision; **blocked**: tracking the target drives a link into the "
      "cube, so a controller that avoids it must leave the target there. Mean settled tracking error (t ≥ 1 s) in mm "
      "and success over each part, training seeds pooled.\n\n| method |", tracker);
  std::string rule = "|---|";
  for (const std::string& arm : arms) {
    const EpisodeSplit counts = SplitByReference(reference[arm]->episodes, reference[arm]->episodes);
    out += fmt::format(" {}: free ({}) | {}: blocked ({}) |", arm, counts.free_count, arm, counts.blocked_count);
    rule += "---|---|";
  }
  out += "\n" + rule + "\n";
  auto cell = [](double settled, double success) {
    return std::isnan(success) ? std::string("–") : fmt::format("{:.1f} ({:.0f} %)", settled, 100.0 * success);
  };
  for (const std::string& method : order) {
    out += fmt::format("| {} |", method);
    for (const std::string& arm : arms) {
      const auto it = pooled.find({method, arm});
      if (it == pooled.end()) {
        out += " | |";
        continue;
      }
      const EpisodeSplit s = SplitByReference(it->second, reference[arm]->episodes);
      out += fmt::format(" {} | {} |", cell(s.free_settled_mm, s.free_success),
                         cell(s.blocked_settled_mm, s.blocked_success));
    }
    out += "\n";
  }
  return out;
}

/// the methods an experiment runs: --methods, else its default list
std::vector<const MethodSpec*> Selected(const ExperimentOptions& o) {
  std::vector<const MethodSpec*> out;
  for (const std::string& key : o.methods.empty() ? DefaultMethods(o.name) : o.methods) {
    try {
      out.push_back(&FindMethod(key));
    } catch (const InputError& e) {
      throw InputError(fmt::format("--methods: {}", e.what()));
    }
  }
  return out;
}


/// One evaluation to run: a method on a task under a condition, for one training seed.
struct Job {
  Method method;
  std::string condition;
  int train_seed = 0;
  tasks::TaskConfig task;
};

std::vector<ResultRow> RunJobs(const std::vector<Job>& jobs, const EvalProtocol& protocol) {
  std::vector<ResultRow> rows;
  const auto start = std::chrono::steady_clock::now();
  for (size_t k = 0; k < jobs.size(); ++k) {
    const Job& j = jobs[k];
    ResultRow row{j.method.name, j.condition, j.train_seed, EvaluateMethod(j.method, j.task, protocol)};
    int successes = 0;
    for (const EpisodeRecord& e : row.episodes) successes += e.metrics.success ? 1 : 0;
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const double eta = elapsed / (k + 1) * (jobs.size() - k - 1);
    fmt::print("  eval [{}/{}] {} | {} | {}: success {}/{}  (elapsed {:.0f} s, ETA {:.0f} s)\n", k + 1, jobs.size(),
               j.method.name, j.condition, j.train_seed > 0 ? fmt::format("seed {}", j.train_seed) : "untrained",
               successes, row.episodes.size(), elapsed, eta);
    std::fflush(stdout);
    rows.push_back(std::move(row));
  }
  return rows;
}

/// the jobs of `methods` under one condition: learned ones per seed with `policy(method, seed)`.
void AddJobs(const std::vector<const MethodSpec*>& methods, const std::string& condition, const tasks::TaskConfig& task,
             int seeds, const std::function<fs::path(const MethodSpec&, int)>& policy, std::vector<Job>* jobs) {
  for (const MethodSpec* m : methods) {
    if (m->kind != MethodSpec::Kind::kLearned) {
      jobs->push_back({MakeMethod(*m), condition, 0, task});
      continue;
    }
    for (int s = 1; s <= seeds; ++s) jobs->push_back({MakeMethod(*m, policy(*m, s).string()), condition, s, task});
  }
}

/// what an experiment must train before it evaluates, and about how long: the unfinished runs, their updates and
/// the measured per-update cost of their methods (train.seconds_per_update), `jobs` runs at once.
std::string TrainingPlan(const std::vector<TrainingRun>& runs, const RunnerOptions& runner) {
  std::map<std::string, std::pair<int, int>> todo;  // method key -> (runs, updates each)
  std::vector<std::string> order, unknown;
  double seconds = 0.0;
  int count = 0;
  for (const TrainingRun& r : runs) {
    if (RunFinished(runner, r.id)) continue;
    const std::string key = r.id.substr(0, r.id.rfind("-seed"));
    if (!todo.count(key)) order.push_back(key);
    todo[key] = {todo[key].first + 1, r.total_updates};
    ++count;
    const double per_update = FindMethod(key).training->seconds_per_update;
    if (per_update > 0.0) {
      seconds += per_update * r.total_updates;
    } else if (std::find(unknown.begin(), unknown.end(), key) == unknown.end()) {
      unknown.push_back(key);
    }
  }
  if (count == 0) return fmt::format("training: all {} runs finished before, reused\n", runs.size());
  std::vector<std::string> parts;
  for (const std::string& k : order) parts.push_back(fmt::format("{} x{} ({} updates)", k, todo[k].first, todo[k].second));
  std::string out = fmt::format("training {} of {} runs before evaluating: {}\n", count, runs.size(),
                                fmt::join(parts, ", "));
  out += fmt::format("  about {:.0f} min with {} at once (per-update times measured on a 2-core AMD EPYC in fp32, one "
                     "process per core; dependencies may idle a core){}\n", seconds / 60.0 / std::max(1, runner.jobs),
                     runner.jobs,
                     unknown.empty() ? "" : fmt::format(", plus {} without a measured cost", fmt::join(unknown, ", ")));
  return out;
}

std::vector<std::string> LearnedKeys(const std::vector<const MethodSpec*>& methods) {
  std::vector<std::string> keys;
  for (const MethodSpec* m : methods) {
    if (m->kind == MethodSpec::Kind::kLearned) keys.push_back(m->key);
  }
  return keys;
}

// What every experiment's part of RunExperiment shares: the options, the methods, the training runs and budgets,
// the evaluation protocol, and the report and rows it fills.
struct ExperimentRun {
  const ExperimentOptions& o;
  const std::vector<const MethodSpec*>& entries;
  const Budgets& budgets;
  const RunnerOptions& runner;
  EvalProtocol& protocol;
  std::function<int(int)> episodes;  // --episodes, or `full` (2 with --quick)
  std::function<void()> train;       // trains what the methods need (nothing with --shipped)
  std::function<fs::path(const MethodSpec&, int)> final_policy;
  const std::string& training_note;
  ReportText& text;
  std::vector<ResultRow>& rows;
  std::vector<Job>& jobs;

  void Table3();                   // pre-training on the two-link arm at the paper's three budgets
  void LineCrossingOrCluttered();    void Fig3();                     // training curves and the final policies on reach-avoid
  void Fig5();                     // every shipped arm (and --urdf arms) with a crossing cube
};

void ExperimentRun::Table3() {
  // The paper's budgets 5K / 10K / 15K: 15K is the pre-training budget (1200 updates × 16 envs × 128 steps =
  // 2.46 M env steps with --budget full, as the shipped policy); 5K and 10K are the snapshots after 1/3 and 2/3.
  const std::vector<int> at = {budgets.pretrain / 3, 2 * budgets.pretrain / 3, budgets.pretrain};
  train();
  protocol.episodes = episodes(100);
  const tasks::TaskConfig task = ExperimentTask("pretrain-2link", o.quick);
  const std::vector<std::string> names = {"5K", "10K", "15K"};
  for (int b = 0; b < 3; ++b) {
    if (o.shipped && b < 2) continue;  // the shipped policy is the full budget's
    AddJobs(entries, names[b], task, o.seeds, [&](const MethodSpec& m, int s) {
      return b == 2 ? final_policy(m, s) : RunPolicy(runner, RunId(m.key, s), at[b]);
    }, &jobs);
    // the untrained rows once, at the first budget evaluated
    const int first = o.shipped ? 2 : 0;
    std::erase_if(jobs, [&](const Job& j) { return b > first && j.train_seed == 0 && j.condition == names[b]; });
  }
  for (Job& j : jobs) {
    if (j.train_seed == 0) j.condition = "-";
  }
  rows = RunJobs(jobs, protocol);
  text.title = "Table 3 — pre-training on the two-link arm (paper IV.A)";
  text.setup = fmt::format(
      "Task `pretrain-2link` (configs/tasks/pretrain-2link.yaml): the randomised two-link arm tracks a target in "
      "linear motion with a cube beside its path (its surface 5–12 cm from the path 1–3 s ahead, ≥ 5 cm everywhere). "
      "HRL-RMP = the per-joint RMP options agent (MAPPO, shared actor, "
      "configs/train/pretrain-2link.yaml); PPO = one agent commanding both joints directly "
      "(configs/train/ppo-pretrain-2link.yaml). **Budgets:** the paper's 5K / 10K / 15K are mapped to 1/3, 2/3 and "
      "all of our pre-training budget: {} / {} / {} updates of 16 envs × 128 steps ({:.2f} / {:.2f} / {:.2f} M env "
      "steps, i.e. 1K ≈ {} updates); the 5K and 10K policies are snapshots of the 15K runs. {} episodes per "
      "budget and seed.\n\n{}", at[0], at[1], at[2], at[0] * 2048e-6, at[1] * 2048e-6, at[2] * 2048e-6,
      at[2] / 15, protocol.episodes, training_note);
  const std::map<std::string, std::pair<std::string, std::string>> hrl = {
      {"5K", {"83.4 %", "22.6 ± 12.1"}}, {"10K", {"95.6 %", "14.3 ± 5.4"}}, {"15K", {"99.6 %", "6.3 ± 0.6"}}};
  const std::map<std::string, std::pair<std::string, std::string>> ppo = {
      {"5K", {"45.5 %", "172.6 ± 44.2"}}, {"10K", {"73.7 %", "76.2 ± 26.2"}}, {"15K", {"87.1 %", "44.8 ± 14.6"}}};
  for (const auto& [c, v] : hrl) text.paper[{"HRL-RMP", c}] = {v.first, v.second + " mm"};
  for (const auto& [c, v] : ppo) text.paper[{"PPO", c}] = {v.first, v.second + " mm"};
  text.notes += Table3Split(rows, "15K");
}

// table4 (line-crossing at five speeds) or cluttered
void ExperimentRun::LineCrossingOrCluttered() {
  train();
  if (o.name == "table4") {
    protocol.episodes = episodes(40);
    for (double v : {0.2, 0.6, 1.2, 1.8, 2.8}) {
      tasks::TaskConfig task = ExperimentTask("line-crossing", o.quick);
      task.scenario.line_speeds = {v};
      AddJobs(entries, fmt::format("{:.1f} m/s", v), task, o.seeds, final_policy, &jobs);
    }
    rows = RunJobs(jobs, protocol);
    text.title = "Table 4 — line-crossing at 0.2 … 2.8 m/s (paper IV.C)";
    std::vector<std::string> on_lines;  // learned methods whose training scenes were line-crossing
    for (const MethodSpec* m : entries) {
      if (m->training && m->training->config.find("line-crossing") != std::string::npos) {
        on_lines.push_back(m->label);
      }
    }
    const std::string trained_on =
        on_lines.empty()
            ? std::string("never saw line-crossing")
            : fmt::format("never saw line-crossing, except {} (trained on line-crossing scenes of the training "
                          "seeds, never on these evaluation episodes)", fmt::join(on_lines, "; "));
    text.setup = fmt::format(
        "Task `line-crossing` (configs/tasks/line-crossing.yaml): Panda, a line of five 8 cm cubes crossing the "
        "workspace again and again at the given speed; a cube that hits the robot stops there (Fig. 7). 6 s "
        "episodes; {} episodes per speed and seed; the same episodes at every speed except for the speed. Learned "
        "methods are trained on `reach-avoid` (paper IV.B) and {}. RMPflow: configs/rmpflow, "
        "the demo's controller (2 ms substeps). RRT: RRT-Connect replanning in joint space (planning/rrt.h). "
        "Basic layer: every joint's agent replaced by a fixed option with unit scales.\n\n{}",
        protocol.episodes, trained_on, training_note);
    const std::map<std::string, std::vector<std::string>> paper = {
        {"PPO", {"90.4 %", "83.6 %", "Failed", "Failed", "Failed"}},
        {"MAPPO (no pre-training)", {"95.2 %", "92.4 %", "52.2 %", "Failed", "Failed"}},
        {"RMPflow", {"100 %", "94.4 %", "82.4 %", "74.8 %", "65.3 %"}},
        {"MARL-RMP", {"100 %", "100 %", "87.6 %", "85.5 %", "80.5 %"}}};
    const std::vector<std::string> speeds = {"0.2 m/s", "0.6 m/s", "1.2 m/s", "1.8 m/s", "2.8 m/s"};
    for (const auto& [m, v] : paper) {
      for (size_t k = 0; k < speeds.size(); ++k) text.paper[{m, speeds[k]}] = {v[k], ""};
    }
  } else {
    protocol.episodes = episodes(50);
    AddJobs(entries, "static 20–50 cm", ExperimentTask("cluttered", o.quick), o.seeds, final_policy, &jobs);
    rows = RunJobs(jobs, protocol);
    text.title = "Cluttered — static obstacles 20–50 cm around the start (paper IV.C, second experiment)";
    text.setup = fmt::format(
        "Task `cluttered` (configs/tasks/cluttered.yaml): Panda, six static 8 cm cubes at 20–50 cm from the start "
        "end effector in random directions, a target moving at 0.1 m/s. The paper reports this experiment "
        "qualitatively only. {} episodes per seed.\n\n{}", protocol.episodes, training_note);
  }
}

void ExperimentRun::Fig3() {
  train();
  std::vector<LearnedRuns> learned;
  for (const MethodSpec* m : entries) {
    if (m->kind != MethodSpec::Kind::kLearned) {
      throw InputError(fmt::format("--methods: fig3 plots training curves; {} is not learned", m->key));
    }
    LearnedRuns l{m->label, m->interface, {}};
    for (int s = 1; s <= o.seeds; ++s) l.run_ids.push_back(RunId(m->key, s));
    learned.push_back(l);
  }
  WriteFig3Curves(learned, runner, o.out, &text.notes);
  protocol.episodes = episodes(50);
  AddJobs(entries, "reach-avoid", ExperimentTask("reach-avoid", o.quick), o.seeds, final_policy, &jobs);
  rows = RunJobs(jobs, protocol);
  text.title = "Figure 3 — training curves on reach-avoid (paper IV.B)";
  text.setup = fmt::format(
      "Training curves (`curves.csv`, `fig3_curves.png`: mean over seeds, band = min–max) of PPO (one agent, "
      "direct joint control), MARL-PPO (per-joint direct agents pre-trained on the two-link arm with MAPPO), MAPPO "
      "without pre-training (per-joint RMP agents from scratch) and MARL-RMP (per-joint RMP agents pre-trained with "
      "HRL-RMP) on `reach-avoid` (Panda, one crossing cube, ±15 % link lengths), {} updates × 2048 env steps each. "
      "The table below the curves evaluates each final policy on {} held-out reach-avoid episodes per seed.\n\n{}",
      budgets.panda, protocol.episodes, training_note);
}

void ExperimentRun::Fig5() {
  train();
  protocol.episodes = episodes(30);
  std::vector<std::string> arms = kinematics::ShippedRobotNames();
  if (o.quick) arms.resize(std::min<size_t>(arms.size(), 2));
  std::vector<std::pair<std::string, std::string>> robots;  // (label, robot)
  for (const std::string& arm : arms) robots.emplace_back(arm, arm);
  for (const std::string& urdf : o.urdfs) {
    if (!tasks::IsUrdfPath(urdf) || !std::filesystem::is_regular_file(urdf)) {
      throw InputError(fmt::format("--urdf: expected existing .urdf files, got '{}'", urdf));
    }
    robots.emplace_back(std::filesystem::path(urdf).stem().string(), urdf);
  }
  for (const auto& [label, robot] : robots) {
    tasks::TaskConfig task = ExperimentTask("reach-avoid", o.quick);
    task.robot = robot;
    task.scenario.crossing.num_obstacles = 1;
    AddJobs(entries, label, task, o.seeds, final_policy, &jobs);
  }
  rows = RunJobs(jobs, protocol);
  text.title = "Figure 5 — MARL-RMP on every shipped arm with a crossing obstacle (paper IV.B)";
  text.setup = fmt::format(
      "Task `reach-avoid` on each arm (link lengths randomised ±15 % as in training, one 10 cm cube crossing at "
      "0.3 m/s, a target moving at 0.1 m/s, 5 s episodes). MARL-RMP was trained on the **Panda only**: every other "
      "arm is unseen (its per-joint agents share the Panda-trained actor). RMPflow and the basic layer run on the "
      "same episodes. {} episodes per arm and seed.\n\n{}", protocol.episodes, training_note);
  if (std::find_if(entries.begin(), entries.end(), [](const MethodSpec* m) { return m->key == "marl-rmp"; }) !=
      entries.end()) {
    tasks::TaskConfig task = ExperimentTask("reach-avoid", o.quick);
    task.scenario.crossing.num_obstacles = 1;
    RenderFig5Frames(arms, task, final_policy(FindMethod("marl-rmp"), 1), o.eval_seed, o.out, &text.notes);
  }
  text.notes += Fig5Split(rows);
}

}  // namespace


std::vector<std::string> ExperimentNames() { return {"table3", "table4", "fig3", "fig5", "cluttered"}; }

std::vector<std::string> BudgetNames() { return {"short", "full"}; }

std::vector<std::string> ExperimentMethods(const std::string& name) {
  if (std::find(ExperimentNames().begin(), ExperimentNames().end(), name) == ExperimentNames().end()) {
    throw InputError(fmt::format("unknown experiment '{}' (known: {})", name, fmt::join(ExperimentNames(), ", ")));
  }
  return DefaultMethods(name);
}

fs::path RunExperiment(const ExperimentOptions& options) {
  ExperimentOptions o = options;
  ExperimentMethods(o.name);  // validates the name
  std::vector<const MethodSpec*> entries = Selected(o);
  if (!o.urdfs.empty() && o.name != "fig5") {
    throw InputError(fmt::format("--urdf: adds arms to fig5, not to {}", o.name));
  }
  if (o.shipped) {
    if (o.name == "fig3") throw InputError("--shipped: fig3 plots training curves, it needs the training runs");
    o.seeds = 1;
    std::erase_if(entries, [](const MethodSpec* m) {
      const bool missing = m->kind == MethodSpec::Kind::kLearned && !fs::exists(ShippedPolicy(*m));
      if (missing) {
        fmt::print("--shipped: {} ({}) has no shipped policy; left out\n", m->label, m->key);
      }
      return missing;
    });
  }
  if (o.seeds < 1) throw InputError(fmt::format("--seeds: expected >= 1, got {}", o.seeds));
  if (o.jobs < 1) throw InputError(fmt::format("--jobs: expected >= 1, got {}", o.jobs));
  if (o.episodes < 0) throw InputError(fmt::format("--episodes: expected >= 1 (0: the default), got {}", o.episodes));
  if (o.perception != "truth" && o.perception != "depth") {
    throw InputError(fmt::format("--perception: expected truth or depth, got '{}'", o.perception));
  }
  const bool depth = o.perception == "depth";
  if (o.out.empty()) o.out = fs::path("results") / (depth ? o.name + "-depth" : o.name);
  if (std::find(BudgetNames().begin(), BudgetNames().end(), o.budget) == BudgetNames().end()) {
    throw InputError(fmt::format("--budget: expected one of {}, got '{}'", fmt::join(BudgetNames(), ", "), o.budget));
  }
  if (o.runs.empty()) {
    o.runs = o.out.parent_path() / (o.quick ? "runs-quick" : o.budget == "full" ? "runs-full" : "runs");
  }
  fs::create_directories(o.out);
  const auto start = std::chrono::steady_clock::now();
  const Budgets budgets = BudgetsFor(o);
  RunnerOptions runner{o.runs, o.cli, o.jobs, 30.0};
  EvalProtocol protocol;
  protocol.episodes = 0;
  protocol.eval_seed = o.eval_seed;
  protocol.jobs = o.jobs;
  protocol.learned_as_controller = o.as_controller;
  if (depth) {
    protocol.make_sensor = perception::DepthSensorMaker(o.depth);
    protocol.sensor_obstacle_slots = o.depth.cloud.max_obstacles;
  }
  auto episodes = [&](int full) { return o.episodes > 0 ? o.episodes : (o.quick ? 2 : full); };
  std::vector<TrainingRun> runs;
  auto train = [&] {
    if (o.shipped) return;
    runs = RunsFor(LearnedKeys(entries), o.seeds, budgets);
    fmt::print("{}", TrainingPlan(runs, runner));
    std::fflush(stdout);
    TrainAll(runs, runner);
  };

  ReportText text;
  text.command = o.command_line;
  if (o.as_controller) {
    text.notes += "Learned methods run as control::LearnedController: their warnings come from the obstacles the controller "
                  "is told (as in a user's loop), not from MuJoCo's contacts.\n\n";
  }
  if (depth) {
    const perception::DepthCameraOptions& c = o.depth.cameras.front();
    text.notes += fmt::format(
        "Perception: depth. The controllers know the obstacles only through one simulated {}×{} depth camera at "
        "{:g} Hz (noise σ = {:g} m × z², dropout {:g}), as point-set obstacles from {:g} m voxels (each point a "
        "sphere of half a voxel + {:g} m) with tracked velocities{} (docs/perception.md); learned methods run as "
        "control::LearnedController; fixed-option methods are left out.\n\n", c.width, c.height, c.rate,
        c.noise.sigma_at_1m, c.noise.dropout, o.depth.cloud.voxel_size, o.depth.cloud.point_margin,
        o.depth.memory.enabled ? ", and obstacles at rest remembered while the arm hides them" : "");
  }
  std::vector<ResultRow> rows;
  std::vector<Job> jobs;
  auto final_policy = [&](const MethodSpec& m, int s) {
    return o.shipped ? ShippedPolicy(m) : RunPolicy(runner, RunId(m.key, s));
  };
  const std::string training_note =
      (o.shipped ? std::string("Learned methods: the policies shipped in models/policies/ (training seed 1, see the "
                               "YAML beside each), evaluated only (`--shipped`); learned methods without a shipped "
                               "policy are left out.")
                 : fmt::format("Training: every learned method with training seeds 1..{} (shipped configs in "
                               "configs/train/, one process per core), runs kept in `{}` and reused by every "
                               "experiment. **Budget `{}`:** {} updates of two-link pre-training and {} on the Panda "
                               "(16 envs × 128 steps each; at most a method's own `train.updates`){}.", o.seeds,
                               o.runs.string(), o.quick ? "quick" : o.budget, budgets.pretrain, budgets.panda,
                               o.quick || o.budget == "full"
                                   ? ""
                                   : ", half of what the shipped policies were trained with (`--budget full`)")) +
      fmt::format(" Evaluation: deterministic actions, evaluation seed {} (episode i is seeded with splitmix64(seed, "
                  "i) ≥ 2^32, never a training seed), the same episodes for every method and training seed.",
                  o.eval_seed);

  fmt::print("experiment {}{}: output {}, runs {}\n", o.name, o.quick ? " (quick)" : "", o.out.string(),
             o.runs.string());
  ExperimentRun x{o, entries, budgets, runner, protocol, episodes, train, final_policy, training_note, text, rows, jobs};
  if (o.name == "table3") {
    x.Table3();
  } else if (o.name == "table4" || o.name == "cluttered") {
    x.LineCrossingOrCluttered();
  } else if (o.name == "fig3") {
    x.Fig3();
  } else if (o.name == "fig5") {
    x.Fig5();
  }
  if (!runs.empty()) text.notes += "\n## Training runs\n\n" + DescribeRuns(runs, runner);
  WriteResultFiles(rows, o.out);
  text.plots = o.plots ? MakePlots(o.name, o.out) : std::vector<std::string>{};
  text.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  WriteReport(rows, text, o.out);
  fmt::print("experiment {}: wrote {} ({:.1f} min)\n", o.name, (o.out / "report.md").string(), text.wall_seconds / 60);
  return o.out / "report.md";
}

}  // namespace rmpmarl::experiments
