// Reading the plan follower's options (configs/planning/*.yaml) with file/key error messages.
#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "rmpmarl/common/yaml_reader.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/planning/plan_follow.h"

namespace rmpmarl::planning {

PlanFollowOptions LoadPlanFollowOptions(const std::filesystem::path& path, PlanFollowOptions options) {
  const std::string file = path.string();
  const YAML::Node root = internal::LoadYamlFile(file, "the plan follower's config");
  if (root.IsNull()) return options;  // an empty file keeps every value
  const internal::YamlReader r(file);
  PlanFollowOptions& o = options;
  RrtOptions& p = o.planner;
  internal::ReadYamlSection(
      r, root, "",
      {internal::FlagField(r, "replan", &o.replan), internal::FlagField(r, "plan_beside_loop", &o.plan_beside_loop),
       internal::NumberField(r, "lookahead", &o.lookahead),
       internal::NumberField(r, "corner_velocity_jump", &o.corner_velocity_jump),
       internal::NumberField(r, "approach_distance", &o.approach_distance),
       internal::FlagField(r, "acceleration_feedforward", &o.acceleration_feedforward),
       internal::NumberField(r, "posture_metric", &o.posture_metric),
       internal::NumberField(r, "yield_metric", &o.yield_metric), internal::NumberField(r, "yield_near", &o.yield_near),
       internal::NumberField(r, "yield_far", &o.yield_far),
       internal::FlagField(r, "yield_slows", &o.yield_slows), internal::NumberField(r, "stall_time", &o.stall_time),
       internal::NumberField(r, "check_period", &o.check_period),
       internal::NumberField(r, "goal_tolerance", &o.goal_tolerance),
       internal::NumberField(r, "goal_shift", &o.goal_shift),
       {"planner", [&](const YAML::Node& n, const std::string& k) {
          internal::ReadYamlSection(r, n, k,
                                    {internal::NumberField(r, "path_speed_fraction", &p.path_speed_fraction),
                                     internal::NumberField(r, "validity_resolution", &p.validity_resolution),
                                     internal::NumberField(r, "retry_period", &p.retry_period),
                                     internal::IntegerField(r, "shortcut_iterations", &p.shortcut_iterations),
                                     internal::NumberField(r, "range", &p.range),
                                     internal::NumberField(r, "end_margin_distance", &p.end_margin_distance),
                                     internal::NumberField(r, "kp", &p.kp), internal::NumberField(r, "kd", &p.kd)});
        }}});
  try {
    ValidatePlanFollowOptions(options);
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}: {}", file, e.what()));
  }
  return options;
}

}  // namespace rmpmarl::planning
