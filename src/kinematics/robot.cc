// Robot = URDF Model + collision.yaml (capsules, end effector, self-collision exclusions); see
// docs/robot-description.md for the schema.
#include "rmpmarl/kinematics/robot.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <set>

#include "rmpmarl/common/yaml_reader.h"
#include "rmpmarl/common/error.h"

#ifndef RMPMARL_MODELS_DIR
#define RMPMARL_MODELS_DIR ""
#endif
#ifndef RMPMARL_INSTALLED_MODELS_DIR
#define RMPMARL_INSTALLED_MODELS_DIR "/usr/local/share/rmpmarl/models"
#endif

namespace rmpmarl::kinematics {
namespace {

// reads collision.yaml nodes with messages naming the file and key path.
class RobotYamlReader : public internal::YamlReader {
 public:
  using internal::YamlReader::YamlReader;

  Eigen::Vector3d Vec3(const YAML::Node& node, const std::string& key) const {
    if (!node.IsDefined()) Fail(node, key, "missing");
    if (!node.IsSequence() || node.size() != 3) {
      Fail(node, key, fmt::format("expected a list of 3 numbers, got {}",
                                  node.IsSequence() ? fmt::format("{} entries", node.size()) : "no list"));
    }
    return {Number(node[0], key + "[0]"), Number(node[1], key + "[1]"), Number(node[2], key + "[2]")};
  }

  int Link(const Model& model, const YAML::Node& node, const std::string& key) const {
    const std::string name = String(node, key);
    const int k = model.FindLink(name);
    if (k < 0) {
      std::string known;
      for (const auto& link : model.links()) known += (known.empty() ? "" : ", ") + link.name;
      Fail(node, key, fmt::format("no link '{}' in the URDF (links: {})", name, known));
    }
    return k;
  }

};

Eigen::Matrix3d RotationFromRpy(const Eigen::Vector3d& rpy) {
  // URDF convention: fixed-axis roll about x, then pitch about y, then yaw about z: R = Rz(yaw) Ry(pitch) Rx(roll).
  return (Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

// adds every parent–child link pair to the declared exclusions, sorted and unique.
void AddAdjacentExclusions(Robot* robot) {
  for (int k = 1; k < robot->model.num_links(); ++k) {
    robot->excluded_pairs.emplace_back(std::min(k, robot->model.link(k).parent),
                                       std::max(k, robot->model.link(k).parent));
  }
  std::sort(robot->excluded_pairs.begin(), robot->excluded_pairs.end());
  robot->excluded_pairs.erase(std::unique(robot->excluded_pairs.begin(), robot->excluded_pairs.end()),
                              robot->excluded_pairs.end());
}

void ParseCollisionYaml(const std::filesystem::path& path, Robot* robot) {
  const std::string file = path.string();
  const YAML::Node root = internal::LoadYamlFile(file, "collision YAML");
  const RobotYamlReader yaml(file);
  if (!root.IsMap()) yaml.Fail(root, "<root>", "expected a mapping with keys robot, end_effector, capsules");
  yaml.CheckKeys(root, "", {"robot", "end_effector", "capsules", "self_collision_capsules", "links_without_capsule",
                           "self_collision_exclude"});
  const Model& model = robot->model;

  const std::string robot_name = yaml.String(root["robot"], "robot");
  if (robot_name != model.name()) {
    yaml.Fail(root["robot"], "robot", fmt::format("expected the URDF's robot name '{}', got '{}'", model.name(),
                                                  robot_name));
  }

  const YAML::Node ee = root["end_effector"];
  if (!ee.IsDefined()) yaml.Fail(ee, "end_effector", "missing");
  yaml.CheckKeys(ee, "end_effector", {"link", "xyz", "rpy"});
  robot->end_effector.link = yaml.Link(model, ee["link"], "end_effector.link");
  robot->end_effector.X_LE.setIdentity();
  if (ee["xyz"]) robot->end_effector.X_LE.translation() = yaml.Vec3(ee["xyz"], "end_effector.xyz");
  if (ee["rpy"]) robot->end_effector.X_LE.linear() = RotationFromRpy(yaml.Vec3(ee["rpy"], "end_effector.rpy"));

  const YAML::Node capsules = root["capsules"];
  if (!capsules.IsDefined() || !capsules.IsSequence() || capsules.size() == 0) {
    yaml.Fail(capsules, "capsules", "expected a non-empty list of {link, a, b, radius}");
  }
  std::vector<int> capsule_count(model.num_links(), 0);
  auto read_capsules = [&](const YAML::Node& list, const std::string& name, std::vector<LinkCapsule>* out) {
    for (size_t i = 0; i < list.size(); ++i) {
      const std::string key = fmt::format("{}[{}]", name, i);
      yaml.CheckKeys(list[i], key, {"link", "a", "b", "radius"});
      LinkCapsule capsule;
      capsule.link = yaml.Link(model, list[i]["link"], key + ".link");
      capsule.p_LA = yaml.Vec3(list[i]["a"], key + ".a");
      capsule.p_LB = yaml.Vec3(list[i]["b"], key + ".b");
      capsule.radius = yaml.Number(list[i]["radius"], key + ".radius");
      if (!(capsule.radius > 0.0)) {
        yaml.Fail(list[i]["radius"], key + ".radius", fmt::format("expected > 0, got {}", capsule.radius));
      }
      out->push_back(capsule);
    }
  };
  read_capsules(capsules, "capsules", &robot->capsules);
  for (const LinkCapsule& c : robot->capsules) ++capsule_count[c.link];
  if (const YAML::Node self = root["self_collision_capsules"]) {
    if (!self.IsSequence() || self.size() == 0) {
      yaml.Fail(self, "self_collision_capsules", "expected a non-empty list of {link, a, b, radius}");
    }
    read_capsules(self, "self_collision_capsules", &robot->self_capsules);
    if (const int k = robot->LinkInOneCoverOnly(); k >= 0) {
      throw InputError(fmt::format("{}: link '{}' has {} capsules and {} self_collision_capsules: expected both "
                                   "sets to cover the same links", file, model.link(k).name, capsule_count[k],
                                   Robot::CountOn(robot->self_capsules, k)));
    }
  }

  std::vector<char> listed(model.num_links(), 0);
  if (const YAML::Node bare = root["links_without_capsule"]) {
    if (!bare.IsSequence()) yaml.Fail(bare, "links_without_capsule", "expected a list of link names");
    for (size_t i = 0; i < bare.size(); ++i) {
      listed[yaml.Link(model, bare[i], fmt::format("links_without_capsule[{}]", i))] = 1;
    }
  }
  for (int k = 0; k < model.num_links(); ++k) {
    if (capsule_count[k] == 0 && !listed[k]) {
      throw InputError(fmt::format("{}: link '{}' has no capsule: add one under 'capsules' or list the link under "
                                   "'links_without_capsule'", file, model.link(k).name));
    }
  }

  if (const YAML::Node excluded = root["self_collision_exclude"]) {
    if (!excluded.IsSequence()) yaml.Fail(excluded, "self_collision_exclude", "expected a list of [link, link] pairs");
    for (size_t i = 0; i < excluded.size(); ++i) {
      const std::string key = fmt::format("self_collision_exclude[{}]", i);
      if (!excluded[i].IsSequence() || excluded[i].size() != 2) {
        yaml.Fail(excluded[i], key, "expected a pair [link, link]");
      }
      const int a = yaml.Link(model, excluded[i][0], key + "[0]");
      const int b = yaml.Link(model, excluded[i][1], key + "[1]");
      if (a == b) yaml.Fail(excluded[i], key, "expected two different links");
      robot->excluded_pairs.emplace_back(std::min(a, b), std::max(a, b));
    }
  }
  AddAdjacentExclusions(robot);
}

}  // namespace

int Robot::CountOn(const std::vector<LinkCapsule>& set, int link) {
  return static_cast<int>(std::count_if(set.begin(), set.end(), [link](const LinkCapsule& c) { return c.link == link; }));
}

int Robot::LinkInOneCoverOnly() const {
  if (self_capsules.empty()) return -1;
  for (int k = 0; k < model.num_links(); ++k) {
    if ((CountOn(capsules, k) == 0) != (CountOn(self_capsules, k) == 0)) return k;
  }
  return -1;
}

bool Robot::IsExcludedPair(int i, int j) const {
  const std::pair<int, int> key(std::min(i, j), std::max(i, j));
  return std::binary_search(excluded_pairs.begin(), excluded_pairs.end(), key);
}

Robot LoadRobot(const std::filesystem::path& urdf_path, const std::filesystem::path& collision_path) {
  Robot robot;
  robot.model = LoadUrdfModel(urdf_path);
  robot.name = robot.model.name();
  robot.urdf_path = urdf_path;
  robot.collision_path = collision_path;
  ParseCollisionYaml(collision_path, &robot);
  std::error_code ec;
  const std::filesystem::path shipped_urdf = ModelsDirectory() / "robots" / robot.name / (robot.name + ".urdf");
  robot.shipped = std::filesystem::equivalent(urdf_path, shipped_urdf, ec);
  const std::string settings = urdf_path.stem().string() + ".rmpflow.yaml";
  for (const std::filesystem::path& dir : {collision_path.parent_path(), urdf_path.parent_path()}) {
    const std::filesystem::path candidate = (dir.empty() ? std::filesystem::path(".") : dir) / settings;
    if (!robot.shipped && std::filesystem::is_regular_file(candidate, ec)) {
      robot.settings_path = candidate;
      break;
    }
  }
  return robot;
}

std::filesystem::path ModelsDirectory() {
  if (const char* env = std::getenv("RMPMARL_MODELS_DIR"); env != nullptr && *env != '\0') return env;
  const std::filesystem::path source_tree(RMPMARL_MODELS_DIR);
  if (!source_tree.empty() && std::filesystem::is_directory(source_tree / "robots")) return source_tree;
  return RMPMARL_INSTALLED_MODELS_DIR;
}

std::vector<std::string> ShippedRobotNames() {
  std::vector<std::string> names;
  const std::filesystem::path robots = ModelsDirectory() / "robots";
  if (!std::filesystem::is_directory(robots)) {
    throw InputError(fmt::format("robot models directory '{}' not found (set RMPMARL_MODELS_DIR)", robots.string()));
  }
  for (const auto& entry : std::filesystem::directory_iterator(robots)) {
    const std::string name = entry.path().filename().string();
    if (entry.is_directory() && std::filesystem::exists(entry.path() / (name + ".urdf"))) names.push_back(name);
  }
  std::sort(names.begin(), names.end());
  return names;
}

Robot LoadShippedRobot(const std::string& name) {
  const std::filesystem::path dir = ModelsDirectory() / "robots" / name;
  if (!std::filesystem::is_directory(dir)) {
    std::string known;
    for (const std::string& n : ShippedRobotNames()) known += (known.empty() ? "" : ", ") + n;
    throw InputError(fmt::format("unknown robot '{}' (shipped robots: {}, or pass a URDF and collision YAML)", name,
                                 known));
  }
  return LoadRobot(dir / (name + ".urdf"), dir / "collision.yaml");
}

Robot MakePlanar2(const Planar2Options& options) {
  if (!(options.link1_length > 0.0) || !(options.link2_length > 0.0) || !(options.link_radius > 0.0) ||
      !(options.joint_limit > 0.0) || !(options.velocity_limit > 0.0)) {
    throw InputError(fmt::format("planar2: expected positive link lengths, radius and limits, got l1={} l2={} r={} "
                                 "q_max={} qd_max={}", options.link1_length, options.link2_length,
                                 options.link_radius, options.joint_limit, options.velocity_limit));
  }
  std::vector<Link> links(3);
  links[0].name = "base";
  links[1].name = "link1";
  links[1].parent = 0;
  links[1].joint_name = "joint1";
  links[1].joint_type = JointType::kRevolute;
  links[1].q_index = 0;
  links[2].name = "link2";
  links[2].parent = 1;
  links[2].joint_name = "joint2";
  links[2].joint_type = JointType::kRevolute;
  links[2].X_PJ.translation() = Eigen::Vector3d(options.link1_length, 0.0, 0.0);
  links[2].q_index = 1;
  const DofLimits dof{-options.joint_limit, options.joint_limit, options.velocity_limit, 10.0};
  Robot robot;
  robot.name = "planar2";
  robot.shipped = true;
  robot.model = Model("planar2", std::move(links), {dof, dof});
  robot.capsules = {
      {1, Eigen::Vector3d::Zero(), Eigen::Vector3d(options.link1_length, 0.0, 0.0), options.link_radius},
      {2, Eigen::Vector3d::Zero(), Eigen::Vector3d(options.link2_length, 0.0, 0.0), options.link_radius}};
  robot.end_effector.link = 2;
  robot.end_effector.X_LE.translation() = Eigen::Vector3d(options.link2_length, 0.0, 0.0);
  AddAdjacentExclusions(&robot);
  return robot;
}

}  // namespace rmpmarl::kinematics
