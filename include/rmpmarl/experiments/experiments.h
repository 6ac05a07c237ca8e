#pragma once
/// The paper's experiments (Wang, Sagawa & Yoshiyasu 2023, section IV), one command each (docs/experiments.md):
///   table3     pre-training (IV.A): HRL-RMP vs PPO on pretrain-2link at the 5K / 10K / 15K budgets
///   table4     line-crossing (IV.C) at 0.2 … 2.8 m/s: every method, success per speed
///   fig3       training curves on reach-avoid (IV.B): env steps to a threshold, the 4.5× / 2.5× ratios
///   fig5       MARL-RMP on each shipped arm with crossing obstacles, success and tracking per arm, frames
///   cluttered  static obstacles 20–50 cm around the start (IV.C)
/// Each trains what it needs (runs.h), evaluates every method on identical episodes (evaluation.h) and writes
/// report.md, results.csv, summary.csv and PNG plots into its output directory.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "rmpmarl/perception/depth_perception.h"

namespace rmpmarl::experiments {

struct ExperimentOptions {
  std::string name;                    ///< one of ExperimentNames()
  bool quick = false;                  ///< tiny budgets (a smoke run of the whole pipeline, < 2 min)
  /// training budgets: "short" (the default: 600 two-link / 300 Panda updates, table4 from scratch in under an
  /// hour on 2 cores) or "full" (1200 / 600, the budgets the shipped policies were trained with)
  std::string budget = "short";
  int seeds = 3;                       ///< training seeds 1..seeds of every learned method
  int episodes = 0;                    ///< per method × condition × training seed (0: the experiment's default)
  std::uint64_t eval_seed = 20231001;  ///< evaluation seed (never a training seed: see EpisodeSeed)
  std::vector<std::string> methods;    ///< method keys to run (empty: the experiment's defaults)
  int jobs = 2;                        ///< training processes / evaluation threads at once
  std::filesystem::path out;           ///< empty: results/<name>
  std::filesystem::path runs;          ///< empty: <out>/../runs (runs-full, runs-quick), shared by experiments
  std::string command_line;            ///< how it was invoked (written into the report)
  std::filesystem::path cli;           ///< the rmpmarl executable for training (empty: this process)
  bool plots = true;                   ///< run scripts/plot_experiment.py (needs python3-matplotlib)
  /// evaluation only: learned methods with a shipped policy (models/policies/) are evaluated from it as their only
  /// "seed", the others are left out, nothing is trained (fig3, which plots training, refuses)
  bool shipped = false;
  /// fig5: users' arms (.urdf paths, collision YAML beside each, else capsules fitted in memory) run after the shipped
  /// ones, labelled by their file stem
  std::vector<std::string> urdfs;
  /// what the controllers know of the obstacles: "truth" (exact shapes) or "depth" (perception::DepthPerception with
  /// `depth`; fixed-option methods are then left out, learned ones run as control::LearnedController)
  std::string perception = "truth";
  perception::DepthPerceptionOptions depth;
  /// learned methods run as control::LearnedController also with "truth" (the baseline of a depth run's learned rows)
  bool as_controller = false;
};

/// table3, table4, fig3, fig5, cluttered.
std::vector<std::string> ExperimentNames();
/// an experiment's default method keys, in report order (configs/experiments/<name>.yaml); any key of
/// MethodKeys() (methods.h) runs with `methods`. Throws InputError for an unknown experiment.
std::vector<std::string> ExperimentMethods(const std::string& name);


/// "short", "full" (ExperimentOptions::budget).
std::vector<std::string> BudgetNames();

/// runs the experiment; returns the report's path. Throws InputError for unknown names/methods or failed runs.
std::filesystem::path RunExperiment(const ExperimentOptions& options);

}  // namespace rmpmarl::experiments
