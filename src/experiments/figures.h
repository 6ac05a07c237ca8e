#pragma once
// Internal to src/experiments: the figure-specific parts (Fig. 3's curves and thresholds, Fig. 5's frames).
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "report.h"
#include "rmpmarl/experiments/runs.h"
#include "rmpmarl/tasks/task_config.h"

namespace rmpmarl::experiments {

/// writes curves.csv (return and success vs env steps of every run) and appends to `notes` the threshold rule and
/// the env steps each method needs to reach it, with the ratios to MARL-RMP (the paper's 4.5× and 2.5×).
void WriteFig3Curves(const std::vector<LearnedRuns>& methods, const RunnerOptions& runner,
                     const std::filesystem::path& out, std::string* notes);

/// renders, for each arm, episode 0 of `eval_seed` under the policy: fig5_<arm>_start.png, fig5_<arm>_early.png (0.3 s
/// before the closest approach to an obstacle) and fig5_<arm>_late.png (at it). Appends what it did to `notes`.
void RenderFig5Frames(const std::vector<std::string>& arms, const tasks::TaskConfig& task,
                      const std::filesystem::path& policy, std::uint64_t eval_seed,
                      const std::filesystem::path& out, std::string* notes);

}  // namespace rmpmarl::experiments
