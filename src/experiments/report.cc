// results.csv, summary.csv, episodes.csv and report.md of an experiment (report.h).
#include "report.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <set>
#include <thread>

#include "rmpmarl/common/error.h"
#include "rmpmarl/experiments/statistics.h"

namespace rmpmarl::experiments {
namespace fs = std::filesystem;

namespace {

struct Pooled {
  std::string method, condition;
  std::vector<int> seeds;
  std::vector<double> seed_success_rates;  // per training seed
  int episodes = 0, successes = 0;
  Interval success;         ///< pooled over episodes (Wilson)
  Interval seed_success;    ///< mean of the per-seed rates with the Student-t interval across seeds
  Interval tracking, settled;  ///< two-level bootstrap (seeds, then episodes)
  double collisions_per_episode = 0.0, time_in_collision_s = 0.0, min_clearance_mm = 0.0, control_us = 0.0;
};

std::vector<Pooled> Pool(const std::vector<ResultRow>& rows) {
  std::vector<Pooled> pooled;
  for (const ResultRow& r : rows) {
    auto it = std::find_if(pooled.begin(), pooled.end(), [&](const Pooled& p) {
      return p.method == r.method && p.condition == r.condition;
    });
    if (it == pooled.end()) {
      Pooled p;
      p.method = r.method;
      p.condition = r.condition;
      pooled.push_back(std::move(p));
      it = pooled.end() - 1;
    }
    int successes = 0;
    for (const EpisodeRecord& e : r.episodes) successes += e.metrics.success ? 1 : 0;
    it->seeds.push_back(r.train_seed);
    it->seed_success_rates.push_back(r.episodes.empty() ? NAN : static_cast<double>(successes) / r.episodes.size());
  }
  for (Pooled& p : pooled) {
    std::vector<std::vector<double>> tracking, settled;
    std::vector<double> collisions, in_collision, clearance, control;
    for (const ResultRow& r : rows) {
      if (r.method != p.method || r.condition != p.condition) continue;
      tracking.emplace_back();
      settled.emplace_back();
      for (const EpisodeRecord& e : r.episodes) {
        ++p.episodes;
        p.successes += e.metrics.success ? 1 : 0;
        tracking.back().push_back(1000.0 * e.metrics.mean_tracking_error);
        settled.back().push_back(1000.0 * e.metrics.settled_tracking_error);
        collisions.push_back(e.metrics.collisions);
        in_collision.push_back(e.metrics.time_in_collision);
        clearance.push_back(std::isfinite(e.metrics.min_clearance) ? 1000.0 * e.metrics.min_clearance : NAN);
        control.push_back(e.control_step_us);
      }
    }
    const std::uint64_t seed = LabelSeed(p.method + "|" + p.condition);
    p.success = WilsonInterval(p.successes, p.episodes);
    p.seed_success = SeedMeanInterval(p.seed_success_rates);
    p.tracking = HierarchicalBootstrapMeanInterval(tracking, seed);
    p.settled = HierarchicalBootstrapMeanInterval(settled, seed + 1);
    p.collisions_per_episode = FiniteMean(collisions);
    p.time_in_collision_s = FiniteMean(in_collision);
    p.min_clearance_mm = FiniteMean(clearance);
    p.control_us = FiniteMedian(control);
  }
  return pooled;
}

std::string Num(double v, const char* format = "{:.1f}") {
  return std::isfinite(v) ? fmt::format(fmt::runtime(format), v) : std::string("nan");
}

std::string Pct(const Interval& i) {
  if (!std::isfinite(i.value)) return "–";
  return fmt::format("{:.1f} % [{:.1f}, {:.1f}]", 100.0 * i.value, 100.0 * i.low, 100.0 * i.high);
}

std::string Mm(const Interval& i) {
  if (!std::isfinite(i.value)) return "–";
  return fmt::format("{:.1f} [{:.1f}, {:.1f}]", i.value, i.low, i.high);
}

}  // namespace

std::string CsvField(const std::string& text) {
  if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
  std::string quoted = "\"";
  for (const char c : text) {
    if (c == '"') quoted += '"';
    quoted += c;
  }
  return quoted + '"';
}

namespace {

std::ofstream Open(const fs::path& path) {
  std::ofstream out(path, std::ios::trunc);
  if (!out) throw InputError(fmt::format("cannot write {}", path.string()));
  return out;
}

}  // namespace

void WriteResultFiles(const std::vector<ResultRow>& rows, const fs::path& out) {
  fs::create_directories(out);
  std::ofstream csv = Open(out / "results.csv");
  csv << "method,condition,train_seed,episodes,success_rate,tracking_mm,settled_tracking_mm,collisions_per_episode,"
         "time_in_collision_s,min_clearance_mm,control_step_us\n";
  std::ofstream episodes = Open(out / "episodes.csv");
  episodes << "method,condition,train_seed,episode,episode_seed,variant,setting,success,collisions,"
              "time_in_collision_s,tracking_mm,settled_tracking_mm,final_tracking_mm,min_clearance_mm,length,"
              "return,control_step_us,plans,plans_succeeded,planning_ms_mean,planning_ms_max\n";
  for (const ResultRow& r : rows) {
    std::vector<double> tracking, settled, collisions, in_collision, clearance, control;
    int successes = 0;
    for (const EpisodeRecord& e : r.episodes) {
      const tasks::EpisodeMetrics& m = e.metrics;
      successes += m.success ? 1 : 0;
      tracking.push_back(1000.0 * m.mean_tracking_error);
      settled.push_back(1000.0 * m.settled_tracking_error);
      collisions.push_back(m.collisions);
      in_collision.push_back(m.time_in_collision);
      clearance.push_back(std::isfinite(m.min_clearance) ? 1000.0 * m.min_clearance : NAN);
      control.push_back(e.control_step_us);
      episodes << fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n", CsvField(r.method),
                              CsvField(r.condition),
                              r.train_seed, e.index, e.episode_seed, e.variant, e.setting, m.success ? 1 : 0,
                              m.collisions, Num(m.time_in_collision, "{:.3f}"), Num(1000.0 * m.mean_tracking_error, "{:.2f}"),
                              Num(1000.0 * m.settled_tracking_error, "{:.2f}"), Num(1000.0 * m.final_tracking_error, "{:.2f}"),
                              Num(std::isfinite(m.min_clearance) ? 1000.0 * m.min_clearance : NAN, "{:.1f}"),
                              m.length, Num(m.episode_return, "{:.2f}"), Num(e.control_step_us, "{:.2f}"), e.plans,
                              e.plans_succeeded, Num(e.planning_ms_mean, "{:.3f}"), Num(e.planning_ms_max, "{:.3f}"));
    }
    const double n = static_cast<double>(r.episodes.size());
    csv << fmt::format("{},{},{},{},{},{},{},{},{},{},{}\n", CsvField(r.method), CsvField(r.condition), r.train_seed,
                       r.episodes.size(),
                       Num(n > 0 ? successes / n : NAN, "{:.4f}"), Num(FiniteMean(tracking), "{:.2f}"),
                       Num(FiniteMean(settled), "{:.2f}"), Num(FiniteMean(collisions), "{:.3f}"), Num(FiniteMean(in_collision), "{:.3f}"),
                       Num(FiniteMean(clearance), "{:.1f}"), Num(FiniteMedian(control), "{:.2f}"));
  }
  std::ofstream summary = Open(out / "summary.csv");
  summary << "method,condition,train_seeds,episodes,success_rate,success_low,success_high,seed_success_low,"
             "seed_success_high,tracking_mm,tracking_low,"
             "tracking_high,settled_tracking_mm,settled_low,settled_high,collisions_per_episode,control_step_us\n";
  for (const Pooled& p : Pool(rows)) {
    summary << fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n", CsvField(p.method),
                           CsvField(p.condition),
                           p.seeds.size(), p.episodes, Num(p.success.value, "{:.4f}"), Num(p.success.low, "{:.4f}"),
                           Num(p.success.high, "{:.4f}"), Num(p.seed_success.low, "{:.4f}"),
                           Num(p.seed_success.high, "{:.4f}"), Num(p.tracking.value, "{:.2f}"), Num(p.tracking.low, "{:.2f}"),
                           Num(p.tracking.high, "{:.2f}"), Num(p.settled.value, "{:.2f}"), Num(p.settled.low, "{:.2f}"),
                           Num(p.settled.high, "{:.2f}"), Num(p.collisions_per_episode, "{:.3f}"),
                           Num(p.control_us, "{:.2f}"));
  }
}

void WriteReport(const std::vector<ResultRow>& rows, const ReportText& text, const fs::path& out) {
  std::ofstream md = Open(out / "report.md");
  md << "# " << text.title << "\n\n";
  md << fmt::format("Command: `{}`  \nWall clock: {:.1f} min on this machine ({} hardware threads).\n\n",
                    text.command, text.wall_seconds / 60.0, std::thread::hardware_concurrency());
  md << text.setup << "\n\n";
  md << "Success = no collision event in the episode. *success*: pooled over the training seeds' episodes with the "
        "95 % Wilson interval (it treats episodes as independent; every seed replays the same episodes); *across "
        "seeds*: the mean of the per-seed rates with the 95 % Student-t interval over seeds (the spread between "
        "training runs; wide with 3 seeds). Means: 95 % two-level bootstrap (training seeds, then episodes). "
        "Tracking = mean end-effector–target distance over the episode; settled = over t ≥ 1 s.\n\n";
  md << "| method | condition | seeds | episodes | success [95 % CI] | across seeds [95 % t] | per seed | tracking mm "
        "[CI] | settled mm [CI] | collisions / ep | min clearance mm | step µs | paper success | paper tracking |\n";
  md << "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  const std::vector<Pooled> pooled = Pool(rows);  // the bootstraps once, for both tables
  for (const Pooled& p : pooled) {
    std::string per_seed;
    for (double s : p.seed_success_rates) per_seed += (per_seed.empty() ? "" : " / ") + Num(100.0 * s, "{:.0f}");
    PaperValue paper;
    if (auto it = text.paper.find({p.method, p.condition}); it != text.paper.end()) paper = it->second;
    const bool untrained = p.seeds.size() == 1 && p.seeds[0] == 0;
    md << fmt::format("| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n", p.method,
                      p.condition, untrained ? "–" : std::to_string(p.seeds.size()), p.episodes, Pct(p.success),
                      untrained || p.seeds.size() < 2 ? "–" : Pct(p.seed_success), untrained ? "–" : per_seed,
                      Mm(p.tracking), Mm(p.settled), Num(p.collisions_per_episode, "{:.2f}"),
                      Num(p.min_clearance_mm, "{:.0f}"), Num(p.control_us, "{:.1f}"),
                      paper.success.empty() ? "–" : paper.success, paper.tracking.empty() ? "–" : paper.tracking);
  }
  // per method and condition, over its episodes: planning statistics of planner rows (RRT), and what the sensor
  // perceived (--perception depth): frame cost, points, obstacles, and the error of the velocities it estimated
  // against the true obstacles' (a sensed obstacle scored against the true one within 0.15 m)
  std::string planners, sensed;
  for (const Pooled& p : pooled) {
    long plans = 0, succeeded = 0;
    double sum_ms = 0.0, max_ms = 0.0;
    long frames = 0, samples = 0, tracked = 0;
    double frame_us = 0.0, points = 0.0, obstacles = 0.0, hidden = 0.0, error = 0.0, tracked_error = 0.0;
    std::vector<double> p90;
    for (const ResultRow& r : rows) {
      if (r.method != p.method || r.condition != p.condition) continue;
      for (const EpisodeRecord& e : r.episodes) {
        plans += e.plans;
        succeeded += e.plans_succeeded;
        sum_ms += e.planning_ms_mean * e.plans;
        max_ms = std::max(max_ms, e.planning_ms_max);
        const sim::SensorSummary& s = e.sensor;
        frames += s.updates;
        frame_us += s.update_mean_us * s.updates;
        points += s.points_mean * s.updates;
        obstacles += s.obstacles_mean * s.updates;
        hidden += s.hidden_mean * s.updates;
        samples += s.velocity_samples;
        error += s.velocity_error_mean * s.velocity_samples;
        tracked += s.velocity_samples_tracked;
        tracked_error += s.velocity_error_tracked_mean * s.velocity_samples_tracked;
        if (s.velocity_samples > 0) p90.push_back(s.velocity_error_p90);
      }
    }
    if (plans > 0) {
      planners += fmt::format("| {} | {} | {:.1f} | {:.0f} % | {:.2f} ms | {:.1f} ms |\n", p.method, p.condition,
                              static_cast<double>(plans) / p.episodes, 100.0 * succeeded / plans, sum_ms / plans,
                              max_ms);
    }
    if (frames > 0) {
      const double nan = std::numeric_limits<double>::quiet_NaN();
      sensed += fmt::format("| {} | {} | {:.1f} | {:.2f} ms | {:.0f} | {:.1f} | {:.1f} | {} | {} | {} |\n", p.method,
                            p.condition, static_cast<double>(frames) / p.episodes, frame_us / frames / 1000.0,
                            points / frames, hidden / frames, obstacles / frames, Num(samples > 0 ? error / samples : nan, "{:.3f}"),
                            Num(p90.empty() ? nan : FiniteMedian(p90), "{:.3f}"),
                            Num(tracked > 0 ? tracked_error / tracked : nan, "{:.3f}"));
    }
  }
  if (!planners.empty()) {
    md << "\nPlanning (wall clock of each replan: IK + RRT-Connect + shortcut; the simulation waits for it):\n\n"
          "| method | condition | replans / episode | found a path | mean | max |\n|---|---|---|---|---|---|\n"
       << planners;
  }
  if (!sensed.empty()) {
    md << "\nPerception (per camera frame: rendering, back-projection and the cloud pipeline; velocity error = "
          "|v_sensed − v_true| of each sensed obstacle whose centre lies within 0.15 m of a true one, over every frame; "
          "p90: the median over episodes of each episode's 90th percentile; followed: obstacles seen for two frames "
          "or more; remembered hidden: voxels of static obstacles the camera could not see, kept from earlier frames):\n\n"
          "| method | condition | frames / episode | frame | voxels kept | remembered hidden | obstacles | "
          "velocity error m/s | p90 | followed |\n|---|---|---|---|---|---|---|---|---|---|\n"
       << sensed;
  }
  md << "\n" << text.notes << "\n";
  if (!text.plots.empty()) {
    md << "\n## Plots\n\n";
    for (const std::string& png : text.plots) md << "![" << png << "](" << png << ")\n\n";
  }
  md << "\nFiles: `results.csv` (one row per method × condition × training seed), `summary.csv` (pooled, with "
        "intervals), `episodes.csv` (every episode with its seed).\n";
}

std::vector<std::string> MakePlots(const std::string& name, const fs::path& out) {
  const fs::path script = fs::path(RMPMARL_SCRIPTS_DIR) / "plot_experiment.py";
  // Debian's interpreter (where python3-matplotlib lives), not whichever python3 comes first on PATH
  const std::string python = fs::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  const std::string command = fmt::format("{} '{}' '{}' '{}' 2>&1", python, script.string(), name, out.string());
  FILE* pipe = popen(command.c_str(), "r");
  std::string output;
  if (pipe != nullptr) {
    char buffer[512];
    while (fgets(buffer, sizeof buffer, pipe) != nullptr) output += buffer;
  }
  const int status = pipe != nullptr ? pclose(pipe) : -1;
  std::vector<std::string> pngs;
  if (status != 0) {
    fmt::print("plots: {} failed ({}); the CSVs are written, plot them with: python3 {} {} {}\n", script.string(),
               output.empty() ? "no output" : output, script.string(), name, out.string());
    return pngs;
  }
  std::set<std::string> sorted;
  for (const auto& entry : fs::directory_iterator(out)) {
    if (entry.path().extension() == ".png") sorted.insert(entry.path().filename().string());
  }
  return {sorted.begin(), sorted.end()};
}

}  // namespace rmpmarl::experiments
