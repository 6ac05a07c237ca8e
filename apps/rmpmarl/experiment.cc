// `rmpmarl experiment NAME [--quick] [--seeds N] [--episodes N] [--eval-seed S] [--methods a,b] [--jobs N]
// [--out DIR]`: the paper's tables and figures, one command each (docs/experiments.md).
#include "commands.h"

#ifdef RMPMARL_HAS_TORCH
#include <fmt/core.h>
#include <fmt/format.h>

#include <memory>
#include <string>
#include <vector>

#include "rmpmarl/experiments/experiments.h"

namespace rmpmarl::apps {

void RegisterExperiment(CLI::App& app, int argc, char** argv) {
  auto options = std::make_shared<experiments::ExperimentOptions>();
  auto out = std::make_shared<std::string>();
  auto runs = std::make_shared<std::string>();
  auto methods = std::make_shared<std::string>();
  auto* cmd = app.add_subcommand("experiment", "Reproduce a table or figure of the paper: trains what it needs, "
                                               "evaluates every method on identical episodes, writes report.md, "
                                               "CSVs and plots");
  cmd->add_option("name", options->name, "table3 | table4 | fig3 | fig5 | cluttered")
      ->required()
      ->check(CLI::IsMember(experiments::ExperimentNames()));
  cmd->add_flag("--quick", options->quick, "tiny budgets: the whole pipeline in under 2 minutes (numbers meaningless)");
  cmd->add_option("--seeds", options->seeds, "training seeds per learned method (default 3)")
      ->check(CLI::Range(1, 20));
  cmd->add_option("--episodes", options->episodes,
                  "episodes per method x condition x seed (default: the experiment's)")
      ->check(CLI::Range(1, 100000));
  cmd->add_option("--eval-seed", options->eval_seed, "evaluation seed (default 20231001)");
  cmd->add_option("--methods", *methods, "comma-separated method keys (default: all of the experiment's)");
  cmd->add_option("--jobs", options->jobs, "training processes / evaluation threads (default 2)")
      ->check(CLI::Range(1, 64));
  cmd->add_option("--out", *out, "output directory (default results/NAME)");
  cmd->add_option("--runs", *runs, "training runs directory, shared by experiments (default: beside --out, runs/)");
  cmd->add_flag("--no-plots", [options](std::int64_t) { options->plots = false; }, "skip the PNG plots");
  cmd->add_flag("--shipped", options->shipped,
                "evaluation only: learned methods from the policies shipped in models/policies/ (others left out)");
  std::string command_line = "rmpmarl";
  for (int k = 1; k < argc; ++k) command_line += std::string(" ") + argv[k];
  cmd->callback([options, out, runs, methods, command_line] {
    options->out = *out;
    options->runs = *runs;
    options->command_line = command_line;
    options->methods.clear();
    for (size_t start = 0; start < methods->size();) {
      const size_t comma = std::min(methods->find(',', start), methods->size());
      if (comma > start) options->methods.push_back(methods->substr(start, comma - start));
      start = comma + 1;
    }
    experiments::RunExperiment(*options);
  });
}

}  // namespace rmpmarl::apps
#endif  // RMPMARL_HAS_TORCH
