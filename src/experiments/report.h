#pragma once
// Internal to src/experiments: the rows of an experiment and how they are written (results.csv, summary.csv,
// report.md) — kept apart from what is run (experiments.cc).
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "rmpmarl/experiments/evaluation.h"

namespace rmpmarl::experiments {

/// One method × condition × training seed: its evaluated episodes.
struct ResultRow {
  std::string method;       ///< label
  std::string condition;    ///< e.g. "0.6 m/s", "10K", "ur5e"
  int train_seed = 0;       ///< 0: untrained (baselines, basic layer)
  std::vector<EpisodeRecord> episodes;
};

/// What the paper reports for a method × condition (success %, tracking mm), when it does.
struct PaperValue {
  std::string success;   ///< e.g. "87.6 %", "Failed"
  std::string tracking;  ///< e.g. "6.3 ± 0.6 mm" (empty: not reported)
};

/// Everything report.md says besides the rows.
struct ReportText {
  std::string title;
  std::string command;
  std::string setup;       ///< markdown: protocol, training budgets, unit mapping
  std::string notes;       ///< markdown after the tables (observations, threshold tables)
  double wall_seconds = 0.0;
  std::map<std::pair<std::string, std::string>, PaperValue> paper;  ///< (method, condition) ↦ paper
  std::vector<std::string> plots;  ///< PNG file names in the output directory
};

/// The training runs of one learned method, one per training seed (seed = index + 1).
struct LearnedRuns {
  std::string label;                 ///< e.g. "MARL-RMP"
  tasks::InterfaceMode interface = tasks::InterfaceMode::kPerJointRmp;
  std::vector<std::string> run_ids;  ///< per seed
};

/// results.csv: one line per row; summary.csv: one line per method × condition pooled over training seeds with
/// 95 % intervals; episodes.csv: every episode.
/// one CSV field (RFC 4180): quoted, with quotes doubled, when it holds a comma, quote or line break.
std::string CsvField(const std::string& text);

void WriteResultFiles(const std::vector<ResultRow>& rows, const std::filesystem::path& out);
/// report.md from the pooled rows and the text.
void WriteReport(const std::vector<ResultRow>& rows, const ReportText& text, const std::filesystem::path& out);
/// runs scripts/plot_experiment.py NAME OUT; returns the PNGs written, or prints why none were.
std::vector<std::string> MakePlots(const std::string& name, const std::filesystem::path& out);

}  // namespace rmpmarl::experiments
