// The SRDF's part of setting up a robot: which SRDF, its disabled pairs as exclusions, its end effector.
#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "rmpmarl/common/error.h"
#include "rmpmarl/setup/robot_setup.h"
#include "rmpmarl/setup/srdf.h"
#include "robot_setup_internal.h"

namespace rmpmarl::setup {

using namespace kinematics;  // the robot description being set up: kinematics' types throughout
namespace {

namespace fs = std::filesystem;

// the SRDF SetupRobot uses: options.srdf, else <urdf stem>.srdf beside the URDF, else the only *.srdf there; "" when
// none (or use_srdf is off). `how` says which; several SRDFs and none of the URDF's name is a warning.
fs::path FindSrdf(const fs::path& urdf_path, const RobotSetupOptions& options, std::string* how,
                  std::vector<std::string>* warnings) {
  if (!options.use_srdf) {
    if (!options.srdf.empty()) {
      throw InputError(fmt::format("--srdf: expected no SRDF with --no-srdf (use_srdf false), got {}",
                                   options.srdf.string()));
    }
    return {};
  }
  if (!options.srdf.empty()) {
    *how = "--srdf";
    return options.srdf;
  }
  const fs::path dir = urdf_path.has_parent_path() ? urdf_path.parent_path() : fs::path(".");
  const fs::path same_name = dir / (urdf_path.stem().string() + ".srdf");
  if (fs::is_regular_file(same_name)) {
    *how = "beside the URDF, of the same name";
    return same_name;
  }
  std::vector<fs::path> found;
  std::error_code error;
  for (fs::directory_iterator it(dir, error), end; !error && it != end; it.increment(error)) {
    if (it->path().extension() == ".srdf" && fs::is_regular_file(it->path())) found.push_back(it->path());
  }
  std::sort(found.begin(), found.end());
  if (found.size() == 1) {
    *how = "the only SRDF beside the URDF";
    return found.front();
  }
  if (found.size() > 1) {
    std::string names;
    for (const fs::path& p : found) names += (names.empty() ? "" : ", ") + p.filename().string();
    warnings->push_back(fmt::format("{} SRDFs beside the URDF ({}) and none named {}: none used (--srdf FILE picks "
                                    "one)", found.size(), names, same_name.filename().string()));
  }
  return {};
}

}  // namespace

namespace internal {

// the SRDF's disabled pairs not yet excluded become kSrdf exclusions, and its first end effector's parent link the
// end effector unless options.end_effector names one; setup->notes say what was used.
void ApplySrdf(const fs::path& urdf_path, const RobotSetupOptions& options, RobotSetup* setup) {
  Robot& robot = setup->robot;
  const Model& model = robot.model;
  setup->end_effector_from = options.end_effector.empty()
                                 ? "the tip of the longest revolute chain or a tool frame below it"
                                 : "--ee";
  std::string how;
  setup->srdf = FindSrdf(urdf_path, options, &how, &setup->warnings);
  if (setup->srdf.empty()) return;
  Srdf srdf;
  std::vector<std::string> srdf_warnings;
  try {
    srdf = LoadSrdf(setup->srdf);
    srdf_warnings = CheckSrdfAgainstModel(srdf, model);
  } catch (const InputError& e) {
    // an SRDF given or named like the URDF must be this robot's; the only SRDF found beside it may be another's
    if (how != "the only SRDF beside the URDF") throw;
    setup->warnings.push_back(fmt::format("{} (the only SRDF beside the URDF) is not used: {}", setup->srdf.string(),
                                          e.what()));
    setup->srdf.clear();
    return;
  }
  for (std::string& w : srdf_warnings) setup->warnings.push_back(std::move(w));
  int added = 0, already = 0, skipped = 0;
  for (const SrdfDisabledPair& p : srdf.disabled_collisions) {
    const int a = model.FindLink(p.link1), b = model.FindLink(p.link2);
    if (a < 0 || b < 0 || a == b) {
      ++skipped;
      continue;
    }
    const std::pair<int, int> pair(std::min(a, b), std::max(a, b));
    if (robot.IsExcludedPair(a, b)) {  // adjacent, one gripper, or listed twice
      ++already;
      continue;
    }
    setup->exclusions.push_back({pair.first, pair.second, ExclusionReason::kSrdf, 0.0, 0.0, p.reason});
    // excluded_pairs stays sorted: IsExcludedPair searches it
    robot.excluded_pairs.insert(std::lower_bound(robot.excluded_pairs.begin(), robot.excluded_pairs.end(), pair),
                                pair);
    ++added;
  }
  const std::string name = setup->srdf.filename().string();
  setup->notes.push_back(fmt::format("SRDF {} ({}): {} disabled pairs: {} excluded as disabled in the SRDF, {} "
                                     "already excluded (adjacent or one gripper), {} skipped (links not in the URDF)",
                                     setup->srdf.string(), how, srdf.disabled_collisions.size(), added, already,
                                     skipped));
  if (srdf.end_effectors.empty()) return;
  const SrdfEndEffector& ee = srdf.end_effectors.front();
  if (!options.end_effector.empty()) {
    setup->notes.push_back(fmt::format("end effector {} (--ee), not the parent link {} of {}'s end effector '{}'",
                                       options.end_effector, ee.parent_link, name, ee.name));
    return;
  }
  // the link the end effector is attached to (CheckSrdfAgainstModel: it exists), or a tool frame fixed below it
  const int parent = model.FindLink(ee.parent_link);
  robot.end_effector.link = ToolFrameAtOrBelow(model, parent);
  robot.end_effector.X_LE.setIdentity();
  setup->end_effector_from =
      robot.end_effector.link == parent
          ? fmt::format("the parent link of {}'s end effector '{}'", name, ee.name)
          : fmt::format("the tool frame fixed below {}, the parent link of {}'s end effector '{}'", ee.parent_link,
                        name, ee.name);
  if (srdf.end_effectors.size() > 1) {
    std::string others;
    for (size_t i = 1; i < srdf.end_effectors.size(); ++i) {
      others += fmt::format("{}'{}' on {}", i > 1 ? ", " : "", srdf.end_effectors[i].name,
                            srdf.end_effectors[i].parent_link);
    }
    setup->notes.push_back(fmt::format("{} has {} end effectors: the first, '{}' on {}, is used (others: {}; --ee LINK "
                                       "picks one)", name, srdf.end_effectors.size(), ee.name, ee.parent_link,
                                       others));
  }
}

}  // namespace internal
}  // namespace rmpmarl::setup
