// The one registry of scenes: MakeScenario, ScenarioNames, RegisterScenario (users add their own).
#include <fmt/format.h>

#include <string>
#include <utility>
#include <vector>

#include "rmpmarl/common/error.h"
#include "rmpmarl/sim/pretrain_scenario.h"
#include "rmpmarl/sim/scenario.h"

namespace rmpmarl::sim {

namespace {

struct Entry {
  std::string name;
  ScenarioFactory factory;
};

void RejectOverride(bool given, std::string_view scenario, std::string_view what) {
  if (given) {
    throw InputError(fmt::format("scenario '{}': expected no {} override (it does not apply), got one", scenario,
                                 what));
  }
}

std::vector<Entry>& Registry() {
  static std::vector<Entry> registry = [] {
    std::vector<Entry> r;
    r.push_back({"crossing", [](const kinematics::Robot& robot, const SceneOptions& s, const ScenarioOverrides& o) {
                   CrossingOptions options = s.crossing;
                   if (o.obstacle_speed) options.obstacle_speed = *o.obstacle_speed;
                   if (o.target_speed) options.target_speed = *o.target_speed;
                   if (o.num_obstacles) options.num_obstacles = *o.num_obstacles;
                   return std::unique_ptr<Scenario>(new CrossingScenario(robot, options));
                 }});
    r.push_back({"line-crossing",
                 [](const kinematics::Robot& robot, const SceneOptions& s, const ScenarioOverrides& o) {
                   LineCrossingOptions options = s.line_crossing;
                   if (o.obstacle_speed) options.speed = *o.obstacle_speed;
                   if (o.target_speed) options.target_speed = *o.target_speed;
                   if (o.num_obstacles) options.num_obstacles = *o.num_obstacles;
                   return std::unique_ptr<Scenario>(new LineCrossingScenario(robot, options));
                 }});
    r.push_back({"cluttered", [](const kinematics::Robot& robot, const SceneOptions& s, const ScenarioOverrides& o) {
                   RejectOverride(o.obstacle_speed.has_value(), "cluttered", "obstacle speed");
                   ClutteredOptions options = s.cluttered;
                   if (o.target_speed) options.target_speed = *o.target_speed;
                   if (o.num_obstacles) options.num_obstacles = *o.num_obstacles;
                   return std::unique_ptr<Scenario>(new ClutteredScenario(robot, options));
                 }});
    for (const bool obstacle : {false, true}) {
      const std::string name = obstacle ? "static-obstacle" : "static-reach";
      r.push_back({name, [obstacle, name](const kinematics::Robot& robot, const SceneOptions& s,
                                          const ScenarioOverrides& o) {
                     RejectOverride(o.obstacle_speed.has_value(), name, "obstacle speed");
                     RejectOverride(o.target_speed.has_value(), name, "target speed");
                     RejectOverride(o.num_obstacles.has_value(), name, "obstacle count");
                     StaticReachOptions options = s.static_reach;
                     options.obstacle_on_path = obstacle;
                     return std::unique_ptr<Scenario>(new StaticReachScenario(robot, options));
                   }});
    }
    r.push_back({"pretrain-2link",
                 [](const kinematics::Robot& robot, const SceneOptions& s, const ScenarioOverrides& o) {
                   RejectOverride(o.obstacle_speed.has_value(), "pretrain-2link", "obstacle speed");
                   RejectOverride(o.target_speed.has_value(), "pretrain-2link", "target speed");
                   RejectOverride(o.num_obstacles.has_value(), "pretrain-2link", "obstacle count");
                   return std::unique_ptr<Scenario>(new PretrainScenario(robot, s.pretrain));
                 }});
    r.push_back({"cells", [](const kinematics::Robot& robot, const SceneOptions& s, const ScenarioOverrides& o) {
                   RejectOverride(o.target_speed.has_value(), "cells", "target speed");
                   CellsOptions options = s.cells;
                   if (o.obstacle_speed) {  // every crossing cube at this speed
                     options.crossing_speed = *o.obstacle_speed;
                     options.crossing_speed_max = 0.0;
                   }
                   if (o.num_obstacles) options.num_crossing = *o.num_obstacles;
                   return std::unique_ptr<Scenario>(new CellsScenario(robot, options));
                 }});
    return r;
  }();
  return registry;
}

}  // namespace

std::vector<std::string> ScenarioNames() {
  std::vector<std::string> names;
  for (const Entry& e : Registry()) names.push_back(e.name);
  return names;
}

bool HasScenario(std::string_view name) {
  for (const Entry& e : Registry()) {
    if (e.name == name) return true;
  }
  return false;
}

std::unique_ptr<Scenario> MakeScenario(std::string_view name, const kinematics::Robot& robot,
                                       const ScenarioOverrides& overrides, const SceneOptions& options) {
  for (const Entry& e : Registry()) {
    if (e.name == name) return e.factory(robot, options, overrides);
  }
  std::string known;
  for (const Entry& e : Registry()) known += (known.empty() ? "" : ", ") + e.name;
  throw InputError(fmt::format("unknown scenario '{}': expected one of {}", name, known));
}

void RegisterScenario(const std::string& name, ScenarioFactory factory) {
  if (name.empty() || !factory) throw InputError("RegisterScenario: expected a name and a factory, got an empty one");
  for (const Entry& e : Registry()) {
    if (e.name == name) throw InputError(fmt::format("RegisterScenario: expected a new name, got '{}' (taken)", name));
  }
  Registry().push_back({name, std::move(factory)});
}

}  // namespace rmpmarl::sim
