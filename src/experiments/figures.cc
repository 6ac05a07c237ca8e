// The figure-specific parts of the experiments (figures.h): Fig. 3's training curves and thresholds, Fig. 5's frames.
#include "figures.h"

#include "report.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>

#include "rmpmarl/common/error.h"
#include "rmpmarl/experiments/statistics.h"
#include "rmpmarl/tasks/manipulator_env.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/control/policy_runtime.h"
#include "rmpmarl/sim/render.h"

namespace rmpmarl::experiments {
namespace fs = std::filesystem;

namespace {

struct CurvePoint {
  int update = 0;
  long env_steps = 0;
  double mean_return = NAN, success_rate = NAN, tracking_mm = NAN;
};

std::vector<std::string> SplitCsv(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream ss(line);
  for (std::string f; std::getline(ss, f, ',');) fields.push_back(f);
  return fields;
}

std::vector<CurvePoint> ReadCurve(const fs::path& csv) {
  std::ifstream in(csv);
  if (!in) throw InputError(fmt::format("cannot read the training curve {}", csv.string()));
  std::string line;
  std::getline(in, line);
  const std::vector<std::string> header = SplitCsv(line);
  const auto column = [&](const std::string& name) {
    const auto it = std::find(header.begin(), header.end(), name);
    if (it == header.end()) throw InputError(fmt::format("{}: no column {}", csv.string(), name));
    return static_cast<size_t>(it - header.begin());
  };
  const size_t c_update = column("update"), c_steps = column("env_steps"), c_return = column("mean_return"),
               c_success = column("success_rate"), c_tracking = column("tracking_error_mm");
  const auto num = [](const std::string& s) { return s == "nan" || s.empty() ? NAN : std::stod(s); };
  std::vector<CurvePoint> curve;
  while (std::getline(in, line)) {
    const std::vector<std::string> f = SplitCsv(line);
    if (f.size() < header.size()) continue;
    curve.push_back({std::stoi(f[c_update]), std::stol(f[c_steps]), num(f[c_return]), num(f[c_success]),
                     num(f[c_tracking])});
  }
  return curve;
}

/// the moving average of `value` over the last `window` updates (NaN entries skipped).
std::vector<double> Smoothed(const std::vector<CurvePoint>& c, int window, double CurvePoint::*value) {
  std::vector<double> out(c.size(), NAN);
  for (size_t k = 0; k < c.size(); ++k) {
    double sum = 0.0;
    int n = 0;
    for (size_t j = k + 1 > static_cast<size_t>(window) ? k + 1 - window : 0; j <= k; ++j) {
      if (std::isfinite(c[j].*value)) {
        sum += c[j].*value;
        ++n;
      }
    }
    if (n > 0) out[k] = sum / n;
  }
  return out;
}

struct Run {
  std::string method;
  int seed;
  std::vector<CurvePoint> curve;
  std::vector<double> smooth_return;
  std::vector<double> task_reached;  ///< 1 where smoothed success and tracking both meet the task threshold, else 0
};

/// per method: the env steps at which each seed's smoothed curve first reaches `threshold`, the median and the ratio
/// to MARL-RMP, as a markdown table.
std::string StepsToThreshold(const std::vector<LearnedRuns>& methods, const std::vector<Run>& runs,
                             std::vector<double> Run::*curve, double threshold, const char* what) {
  std::string table = fmt::format("| method | env steps to {} per seed | median | × MARL-RMP |\n|---|---|---|---|\n",
                                  what);
  std::vector<std::pair<std::string, double>> medians;
  std::vector<std::string> lines;
  for (const LearnedRuns& m : methods) {
    std::vector<double> steps;
    std::string per_seed;
    for (const Run& r : runs) {
      if (r.method != m.label) continue;
      double reached = INFINITY;
      for (size_t k = 0; k < r.curve.size(); ++k) {
        if (std::isfinite((r.*curve)[k]) && (r.*curve)[k] >= threshold) {
          reached = static_cast<double>(r.curve[k].env_steps);
          break;
        }
      }
      steps.push_back(reached);
      per_seed += (per_seed.empty() ? "" : " / ") +
                  (std::isfinite(reached) ? fmt::format("{:.2f} M", reached * 1e-6)
                                          : fmt::format("not reached (> {:.2f} M)",
                                                        r.curve.empty() ? 0.0 : r.curve.back().env_steps * 1e-6));
    }
    std::sort(steps.begin(), steps.end());
    // the median; with an even count the upper middle (a run that never reaches counts as +inf)
    medians.emplace_back(m.label, steps.empty() ? NAN : steps[steps.size() / 2]);
    lines.push_back(per_seed);
  }
  double ours = NAN;
  for (const auto& [label, median] : medians) {
    if (label == "MARL-RMP") ours = median;
  }
  for (size_t k = 0; k < medians.size(); ++k) {
    const double v = medians[k].second;
    std::string ratio = "–";
    if (std::isfinite(v) && std::isfinite(ours) && ours > 0) {
      ratio = fmt::format("{:.2f}×", v / ours);
    } else if (!std::isfinite(v) && std::isfinite(ours)) {
      ratio = "∞ (never)";
    } else if (std::isfinite(v) && !std::isfinite(ours)) {
      ratio = "< 1 (MARL-RMP never)";
    }
    table += fmt::format("| {} | {} | {} | {} |\n", medians[k].first, lines[k],
                         std::isfinite(v) ? fmt::format("{:.2f} M", v * 1e-6) : std::string("not reached"), ratio);
  }
  return table;
}

}  // namespace

void WriteFig3Curves(const std::vector<LearnedRuns>& methods, const RunnerOptions& runner, const fs::path& out,
                     std::string* notes) {
  constexpr int kWindow = 10;               // updates of smoothing
  constexpr double kSuccessThreshold = 0.85;  // training-window success ...
  constexpr double kTrackingThreshold = 60.0;  // ... and tracking error [mm]
  std::vector<Run> runs;
  std::ofstream csv(out / "curves.csv", std::ios::trunc);
  csv << "method,train_seed,update,env_steps,mean_return,success_rate\n";
  for (const LearnedRuns& m : methods) {
    for (size_t s = 0; s < m.run_ids.size(); ++s) {
      Run r{m.label, static_cast<int>(s) + 1, ReadCurve(RunDirectory(runner, m.run_ids[s]) / "metrics.csv"), {}, {}};
      r.smooth_return = Smoothed(r.curve, kWindow, &CurvePoint::mean_return);
      const std::vector<double> success = Smoothed(r.curve, kWindow, &CurvePoint::success_rate);
      const std::vector<double> tracking = Smoothed(r.curve, kWindow, &CurvePoint::tracking_mm);
      for (size_t k = 0; k < r.curve.size(); ++k) {
        r.task_reached.push_back(success[k] >= kSuccessThreshold && tracking[k] <= kTrackingThreshold ? 1.0 : 0.0);
      }
      for (const CurvePoint& p : r.curve) {
        csv << fmt::format("{},{},{},{},{:.4f},{:.4f}\n", CsvField(m.label), r.seed, p.update, p.env_steps, p.mean_return,
                           p.success_rate);
      }
      runs.push_back(std::move(r));
    }
  }
  // return threshold: 80 % of the way from the lowest early return to the highest final return (seed means)
  double low = INFINITY, high = -INFINITY;
  for (const LearnedRuns& m : methods) {
    std::vector<double> first, last;
    for (const Run& r : runs) {
      if (r.method != m.label || r.smooth_return.empty()) continue;
      first.push_back(r.smooth_return[std::min<size_t>(kWindow - 1, r.smooth_return.size() - 1)]);
      last.push_back(r.smooth_return.back());
    }
    if (!first.empty()) {
      low = std::min(low, FiniteMean(first));
      high = std::max(high, FiniteMean(last));
    }
  }
  const double threshold = low + 0.8 * (high - low);
  *notes += fmt::format(
      "**Two thresholds.** (a) The return, as the paper's Fig. 3 plots: a run reaches R* = R_low + 0.8 (R_high − "
      "R_low) = **{:.1f}** at the first update where its training return, smoothed over {} updates, is ≥ R*, with R_low "
      "= {:.1f} the lowest seed-mean return after {} updates and R_high = {:.1f} the highest seed-mean final return. "
      "The returns of the interfaces are not on one scale, though: eq. 14's R_i pays every joint that brings the end "
      "effector closer, so an agent that moves every joint at full speed (PPO's direct Δq) collects more of it than the "
      "RMP agents, whose joints share one task-space motion. (b) Therefore also the task itself: the training-window "
      "success rate (no collision) ≥ **{:.0f} %** and tracking error ≤ **{:.0f} mm**, both smoothed over {} updates "
      "(success alone is no criterion: an arm that barely moves rarely collides). Rule (b) was chosen after the "
      "curves of rule (a) had been seen.\n\n{}\n{}",
      threshold, kWindow, low, kWindow, high, 100.0 * kSuccessThreshold, kTrackingThreshold, kWindow,
      StepsToThreshold(methods, runs, &Run::smooth_return, threshold, "R*"),
      StepsToThreshold(methods, runs, &Run::task_reached, 1.0, "the task threshold (b)"));
  *notes += "\nThe paper reports that PPO needs 4.5× and MARL-PPO 2.5× the training steps of MARL-RMP, and that MAPPO "
            "without pre-training does not converge.\n";
}

void RenderFig5Frames(const std::vector<std::string>& arms, const tasks::TaskConfig& base_task,
                      const fs::path& policy_path, std::uint64_t eval_seed, const fs::path& out, std::string* notes) {
  const control::PolicyWeights weights = control::LoadPolicyFile(policy_path).weights;
  constexpr int kLead = 30;  // the earlier frame: 0.3 s before the closest approach
  std::string written;
  for (const std::string& arm : arms) {
    tasks::TaskConfig task = base_task;
    task.robot = arm;
    task.interface = tasks::InterfaceMode::kPerJointRmp;
    const auto context = tasks::MakeTaskContext(task);
    tasks::ManipulatorEnv env(context);
    control::PolicyRuntime runtime(weights, context->num_agents());
    tasks::StepBuffers step(context->spec());
    std::vector<float> actions(static_cast<size_t>(context->num_agents()) * context->spec().action.size());
    // pass 1: the step of the closest approach to an obstacle; pass 2 (the same episode): render the frames
    int critical = 0;
    for (int pass = 0; pass < 2; ++pass) {
      std::mt19937_64 rng(EpisodeSeed(eval_seed, 0));
      env.Reset(rng, step.out());
      std::unique_ptr<sim::OffscreenRenderer> renderer;
      if (pass == 1) {
        const sim::RenderOptions camera = sim::CameraForWorkspace(env.scenario().workspace(), 640, 480);
        std::string why_not;
        renderer = sim::OffscreenRenderer::Create(env.world().mj_model(), camera, &why_not);
        if (renderer == nullptr) {
          *notes += fmt::format("\nFrames: not rendered ({}).\n", why_not);
          return;
        }
      }
      const std::vector<int> frames = {0, std::max(0, critical - kLead), critical};
      const std::vector<std::string> names = {"start", "early", "late"};
      double closest = INFINITY;
      std::vector<std::uint8_t> rgb;
      for (int t = 0;; ++t) {
        if (pass == 1) {
          for (size_t f = 0; f < frames.size(); ++f) {
            if (frames[f] != t) continue;
            renderer->Render(env.world().mj_data(), &rgb);
            sim::WritePng(out / fmt::format("fig5_{}_{}.png", arm, names[f]), rgb, renderer->width(),
                          renderer->height());
          }
        }
        if (t >= critical && pass == 1) break;
        runtime.Act(step.local_obs.data(), context->num_agents(), actions.data());
        env.Step(actions.data(), rng, step.out());
        if (pass == 0 && env.metrics().min_clearance < closest) {
          closest = env.metrics().min_clearance;
          critical = t + 1;
        }
        if (step.terminated || step.truncated) break;
      }
      if (pass == 0 && !std::isfinite(closest)) critical = context->spec().max_episode_steps / 2;
    }
    written += (written.empty() ? "" : ", ") + arm;
  }
  *notes += fmt::format("\nFrames (episode 0 of the evaluation seed, MARL-RMP seed 1): start pose, then the state "
                        "{:.1f} s before the closest approach to the obstacle (translucent) and at it, for {}: "
                        "`fig5_<arm>_{{start,early,late}}.png`, composed into `fig5_frames.png`.\n", kLead / 100.0,
                        written);
}

}  // namespace rmpmarl::experiments
