// The MotionBenchMaker benchmark's outputs: the summary table, why runs failed, results.csv and report.md.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "report.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/experiments/mbm.h"
#include "rmpmarl/experiments/statistics.h"

namespace rmpmarl::experiments {
namespace fs = std::filesystem;

namespace {

std::string Num(double v, const char* format) {
  return std::isfinite(v) ? fmt::format(fmt::runtime(format), v) : std::string("–");
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
      "| family | method | valid | rejected by the model | success [95 % CI] | with collisions (capsules) | with "
      "collisions (meshes) | time to goal (median) | path length (median) | first plan (median) |\n"
      "|---|---|---|---|---|---|---|---|---|---|\n";
  for (const std::string& family : families) {
    for (const std::string& method : methods) {
      int valid = 0, rejected = 0, success = 0, collided = 0, mesh_judged = 0, mesh_collided = 0, total = 0;
      std::vector<double> times, lengths, plans;
      for (const MbmResult& r : results) {
        if (r.method != method || (family != "all" && r.family != family)) continue;
        ++total;
        if (!r.valid) continue;
        ++valid;
        rejected += r.rejected;
        success += r.success;
        collided += r.collisions > 0;
        mesh_judged += r.mesh_collisions >= 0;
        mesh_collided += r.mesh_collisions > 0;
        if (r.success && r.time_to_goal >= 0.0) times.push_back(r.time_to_goal);  // as the path length: successes
        if (r.success) lengths.push_back(r.path_length);
        if (r.planning_time >= 0.0) plans.push_back(1e3 * r.planning_time);
      }
      if (total == 0) continue;
      const Interval ci = WilsonInterval(success, valid);
      md += fmt::format("| {} | {} | {} of {} | {} | {} % [{}, {}] | {} | {} | {} s | {} rad | {} ms |\n", family,
                        method, valid, total, rejected,
                        Num(valid > 0 ? 100.0 * success / valid : std::nan(""), "{:.1f}"), Num(100.0 * ci.low, "{:.1f}"),
                        Num(100.0 * ci.high, "{:.1f}"), collided, mesh_judged > 0 ? std::to_string(mesh_collided) : "–",
                        Num(FiniteMedian(times), "{:.2f}"), Num(FiniteMedian(lengths), "{:.2f}"),
                        Num(FiniteMedian(plans), "{:.1f}"));
    }
  }
  return md;
}

namespace {

// why the runs of each method failed: a count per kind (the reason's words before its colon) and each run that
// failed while it ran (not the problems the model rejected, listed above); "" when every run succeeded
std::string FailureTable(const std::vector<MbmResult>& results) {
  const std::vector<std::string> kinds = {"rejected by the model", "collided", "no plan", "timed out", "stopped short",
                                          "not settled"};
  std::vector<std::string> methods;
  std::map<std::string, std::vector<int>> counts;
  std::vector<std::string> runs;
  for (const MbmResult& r : results) {
    if (!r.valid || r.success) continue;
    if (std::find(methods.begin(), methods.end(), r.method) == methods.end()) {
      methods.push_back(r.method);
      counts[r.method].assign(kinds.size(), 0);
    }
    const std::string kind = r.reason.substr(0, r.reason.find(':'));
    const auto k = std::find(kinds.begin(), kinds.end(), kind);
    if (k != kinds.end()) ++counts[r.method][static_cast<size_t>(k - kinds.begin())];
    if (!r.rejected) runs.push_back(fmt::format("{} {} {}: {}", r.family, r.index, r.method, r.reason));
  }
  if (methods.empty()) return "";
  std::string out = fmt::format("Why runs failed (results.csv's reason):\n\n| method | {} |\n|---|",
                                fmt::join(kinds, " | "));
  for (size_t i = 0; i < kinds.size(); ++i) out += "---|";
  out += "\n";
  for (const std::string& m : methods) out += fmt::format("| {} | {} |\n", m, fmt::join(counts[m], " | "));
  if (!runs.empty()) {
    out += fmt::format("\nRuns that failed ({}):\n\n", runs.size());
    for (const std::string& s : runs) out += "- " + s + "\n";
  }
  return out;
}

}  // namespace

void WriteMbmResults(const std::vector<MbmResult>& results, const fs::path& out, const std::string& command,
                     const std::string& setup) {
  fs::create_directories(out);
  std::ofstream csv(out / "results.csv");
  csv << "family,problem,method,valid,rejected,success,reached,collisions,mesh_collisions,time_to_goal_s,"
         "final_error_mm,joint_error_rad,path_length_rad,min_clearance_mm,min_mesh_clearance_mm,min_mesh_pair,"
         "planning_time_ms,plans,control_us,mesh_check_us,reason\n";
  // "none" is "nan" in every column, as the experiments' CSVs write it: a smallest clearance where nothing came
  // within the sensing margin, a goal never reached, no plan attempted, no mesh referee
  auto millimetres = [](double metres) {
    return std::isfinite(metres) ? fmt::format("{:.2f}", 1e3 * metres) : std::string("nan");
  };
  auto when = [](bool present, double value, int decimals) {
    return present ? fmt::format("{:.{}f}", value, decimals) : std::string("nan");
  };
  for (const MbmResult& r : results) {
    csv << fmt::format("{},{},{},{},{},{},{},{},{},{},{:.2f},{:.4f},{:.4f},{},{},{},{},{},{:.2f},{:.2f},{}\n",
                       CsvField(r.family), r.index, r.method, r.valid ? 1 : 0, r.rejected ? 1 : 0, r.success ? 1 : 0,
                       r.reached ? 1 : 0, r.collisions,
                       r.mesh_collisions >= 0 ? std::to_string(r.mesh_collisions) : std::string("nan"),
                       when(r.time_to_goal >= 0.0, r.time_to_goal, 3), 1e3 * r.final_error, r.joint_error,
                       r.path_length, millimetres(r.min_clearance), millimetres(r.min_mesh_clearance),
                       CsvField(r.min_mesh_pair), when(r.planning_time >= 0.0, 1e3 * r.planning_time, 3), r.plans,
                       r.control_us, r.mesh_check_us, CsvField(r.reason));
  }
  if (!csv) throw InputError(fmt::format("could not write '{}'", (out / "results.csv").string()));
  csv.close();
  const std::vector<std::string> plots = MakePlots("mbm", out);
  std::ofstream md(out / "report.md");
  // which referees judged: the meshes where any result was judged on them (or rejected against them)
  const bool meshes = std::any_of(results.begin(), results.end(),
                                  [](const MbmResult& r) { return r.mesh_collisions >= 0 || r.rejected; });
  const std::string referees =
      meshes ? "Referees: validity on the collision meshes (FCL: start and goal clear of the cell); collisions on "
               "both the capsules (MuJoCo's contacts) and the meshes (FCL, every control step); success needs none "
               "on either. A valid problem whose start or goal the capsule model puts in collision is rejected by "
               "the model: not run, a failure of every method."
             : "Referee: the capsule model alone (no collision meshes judged: validity and collisions on the model "
               "under test, MuJoCo's contacts).";
  md << "# MotionBenchMaker benchmark\n\n" << "Command: `" << command << "`\n\n" << setup << "\n\n" << referees
     << "\n\n" << MbmSummaryTable(results) << "\n";
  for (const std::string& png : plots) md << "![" << png << "](" << png << ")\n\n";
  std::vector<std::string> invalid, rejected;
  for (const MbmResult& r : results) {
    if (r.method != results.front().method) continue;
    if (!r.valid) invalid.push_back(fmt::format("{} {}: {}", r.family, r.index, r.reason));
    if (r.rejected) rejected.push_back(fmt::format("{} {}: {}", r.family, r.index, r.reason));
  }
  if (!invalid.empty()) {
    md << "Problems not valid, not run (" << invalid.size() << "):\n\n";
    for (const std::string& s : invalid) md << "- " << s << "\n";
    md << "\n";
  }
  if (!rejected.empty()) {
    md << "Problems rejected by the model, not run, counted as failures (" << rejected.size() << "):\n\n";
    for (const std::string& s : rejected) md << "- " << s << "\n";
    md << "\n";
  }
  md << FailureTable(results);
  if (!md) throw InputError(fmt::format("could not write '{}'", (out / "report.md").string()));
}

}  // namespace rmpmarl::experiments
