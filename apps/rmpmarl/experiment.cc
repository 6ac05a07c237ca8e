// `rmpmarl experiment NAME [--quick | --budget short|full] [--seeds N] [--episodes N] [--eval-seed S] [--methods a,b] [--jobs N]
// [--out DIR]`: the paper's tables and figures, one command each (docs/experiments.md);
// `rmpmarl experiment NAME --list`: its default method keys, one per line;
// `rmpmarl probe-lookahead POLICY`: what a learned agent does with the look-ahead block.
#include "commands.h"

#ifdef RMPMARL_HAS_TORCH
#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "rmpmarl/experiments/experiments.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/experiments/methods.h"
#include "rmpmarl/experiments/probe.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/rl/policy_task.h"
#include "rmpmarl/tasks/task_config.h"

namespace rmpmarl::apps {

void RegisterExperiment(CLI::App& app, int argc, char** argv) {
  auto options = std::make_shared<experiments::ExperimentOptions>();
  auto out = std::make_shared<std::string>();
  auto runs = std::make_shared<std::string>();
  auto methods = std::make_shared<std::string>();
  auto list = std::make_shared<bool>(false);
  auto* cmd = app.add_subcommand("experiment", "Reproduce a table or figure of the paper: trains what it needs, "
                                               "evaluates every method on identical episodes, writes report.md, "
                                               "CSVs and plots");
  cmd->add_option("name", options->name, "table3 | table4 | fig3 | fig5 | cluttered")
      ->required()
      ->check(CLI::IsMember(experiments::ExperimentNames()));
  cmd->add_flag("--quick", options->quick, "tiny budgets: the whole pipeline in under 2 minutes (numbers meaningless)");
  cmd->add_option("--budget", options->budget,
                  "training budgets: short (600 two-link / 300 Panda updates; table4 with training in under an hour "
                  "on 2 cores) or full (1200 / 600, as the shipped policies were trained)")
      ->check(CLI::IsMember(experiments::BudgetNames()))
      ->capture_default_str();
  cmd->add_option("--seeds", options->seeds, "training seeds per learned method (default 3)")
      ->check(CLI::Range(1, 20));
  cmd->add_option("--episodes", options->episodes,
                  "episodes per method x condition x seed (default: the experiment's)")
      ->check(CLI::Range(1, 100000));
  cmd->add_option("--eval-seed", options->eval_seed, "evaluation seed (default 20231001)")
      ->check(SeedCheck());
  CLI::Option* methods_option = cmd->add_option("--methods", *methods,
                  "comma-separated method keys (default: the experiment's, see --list; any file stem of "
                  "configs/methods/ or configs/ablations/)");
  cmd->add_flag("--list", *list, "print the experiment's default method keys, one per line, and exit");
  cmd->add_option("--urdf", options->urdfs, "fig5: your arms (comma-separated .urdf paths) after the shipped ones")
      ->delimiter(',');
  cmd->add_option("--jobs", options->jobs, "training processes / evaluation threads (default 2)")
      ->check(CLI::Range(1, 64));
  cmd->add_option("--out", *out, "output directory (default results/NAME)");
  cmd->add_option("--runs", *runs, "training runs directory, shared by experiments (default: beside --out, runs/; runs-full/ with "
                  "--budget full)");
  cmd->add_flag("--no-plots", [options](std::int64_t) { options->plots = false; }, "skip the PNG plots");
  cmd->add_flag("--shipped", options->shipped,
                "evaluation only: learned methods from the policies shipped in models/policies/ (others left out)");
  auto perception_args = std::make_shared<PerceptionArgs>();
  AddPerceptionOptions(cmd, perception_args.get());
  cmd->add_flag("--as-controller", options->as_controller,
                "learned methods run as control::LearnedController, as in a user's loop (always so with --perception depth)");
  std::string command_line = "rmpmarl";
  for (int k = 1; k < argc; ++k) command_line += std::string(" ") + argv[k];
  cmd->callback([options, out, runs, methods, methods_option, list, command_line, perception_args] {
    options->perception = perception_args->mode;
    if (UsesDepth(*perception_args)) options->depth = DepthOptions(*perception_args, options->eval_seed);
    if (*list) {
      for (const std::string& key : experiments::ExperimentMethods(options->name)) fmt::print("{}\n", key);
      return;
    }
    options->out = *out;
    options->runs = *runs;
    options->command_line = command_line;
    options->methods.clear();
    for (size_t start = 0; start < methods->size();) {
      const size_t comma = std::min(methods->find(',', start), methods->size());
      if (comma > start) options->methods.push_back(methods->substr(start, comma - start));
      start = comma + 1;
    }
    if (methods_option->count() > 0 && options->methods.empty()) {
      throw InputError(fmt::format("--methods: expected method keys separated by commas (`rmpmarl experiment {} "
                                   "--list` names them), got '{}'", options->name, *methods));
    }
    experiments::RunExperiment(*options);
  });
}

void RegisterProbeLookahead(CLI::App& app) {
  struct Args {
    std::string policy, task = "line-crossing";
    double speed = 2.8;
    experiments::ProbeOptions probe;
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("probe-lookahead",
                                 "What a learned agent does with the look-ahead block: its target-stiffness action "
                                 "with the block as observed, as 'no pass predicted' and as 'a pass at --clearance "
                                 "in --time'");
  cmd->add_option("policy", args->policy, "controller file (.rmpp) trained with observation.lookahead")->required();
  cmd->add_option("--task", args->task, "the scene it runs in, on its own basic layer (configs/tasks)")
      ->capture_default_str();
  cmd->add_option("--speed", args->speed, "line-crossing: the line's speed [m/s], also the substituted pass's")
      ->check(CLI::Range(0.01, 20.0))->capture_default_str();
  cmd->add_option("--episodes", args->probe.episodes, "episodes")->check(CLI::Range(1, 100000))->capture_default_str();
  cmd->add_option("--eval-seed", args->probe.eval_seed, "evaluation seed of the episodes")
      ->check(SeedCheck())->capture_default_str();
  cmd->add_option("--clearance", args->probe.threat_clearance, "substituted pass: predicted clearance [m]")
      ->capture_default_str();
  cmd->add_option("--time", args->probe.threat_time, "substituted pass: time of closest approach [s]")
      ->capture_default_str();
  cmd->callback([args] {
    const control::PolicyFile file = control::LoadPolicyFile(args->policy);
    rl::TaskMove move;
    move.scene = std::string(tasks::TaskSceneName(tasks::ParseTaskKind(args->task)));
    tasks::TaskConfig task = rl::PolicyTaskConfig(file, args->policy, move);
    if (task.task == tasks::TaskKind::kLineCrossing) task.scenario.line_speeds = {args->speed};
    args->probe.threat_speed = args->speed;
    const experiments::LookaheadProbe p = experiments::ProbeLookahead(args->policy, task, args->probe);
    const double g = task.options.TargetGainRange();
    fmt::print("probe-lookahead {} ({}, {} episodes at {} m/s, {} with a collision)\n", args->policy, args->task,
               p.episodes, args->speed, p.failures);
    fmt::print("  target stiffness action u (scale = {}^u); block as observed: {:.3f} with a pass predicted within "
               "{:.0f} cm ({} agent-steps), {:.3f} otherwise ({})\n", g, p.u_observed_threatened,
               100.0 * args->probe.threat_threshold, p.threatened_steps, p.u_observed_clear, p.clear_steps);
    fmt::print("  block substituted, other features as observed:\n");
    fmt::print("  {:>6} {:>10} {:>10} {:>12}\n", "joint", "u none", "u pass", "k_p ratio");
    for (size_t a = 0; a < p.u_none.size(); ++a) {
      // the env clips u to [−1, 1] before the scale g^u
      const double clipped = std::clamp(p.u_none[a], -1.0, 1.0) - std::clamp(p.u_threat[a], -1.0, 1.0);
      fmt::print("  {:>6} {:>10.3f} {:>10.3f} {:>12.2f}\n", a + 1, p.u_none[a], p.u_threat[a], std::pow(g, clipped));
    }
  });
}

}  // namespace rmpmarl::apps
#endif  // RMPMARL_HAS_TORCH
