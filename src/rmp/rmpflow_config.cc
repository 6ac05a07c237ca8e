// Loading RMPflow parameters from configs/rmpflow/<robot>.yaml with file/key error messages.
#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <initializer_list>
#include <set>
#include <string>

#include "rmpmarl/common/yaml_reader.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/rmp/rmpflow.h"

namespace rmpmarl::rmp {
namespace {

// a numeric field of a config section: its key and where it is stored
struct Field {
  const char* key;
  double* value;
};

// reads config nodes with messages naming the file and key path.
class ConfigReader : public internal::YamlReader {
 public:
  using internal::YamlReader::YamlReader;

  // reads the numeric fields present in `section` (others keep their value); `extra` keys are allowed too.
  void Section(const YAML::Node& section, const std::string& key, std::initializer_list<Field> fields,
               std::set<std::string> extra = {}) const {
    std::set<std::string> allowed = std::move(extra);
    for (const Field& f : fields) allowed.insert(f.key);
    CheckKeys(section, key, allowed);
    for (const Field& f : fields) {
      if (const YAML::Node value = section[f.key]) *f.value = Number(value, key + "." + f.key);
    }
  }
};

void ReadCollision(const ConfigReader& reader, const YAML::Node& node, const std::string& key, CollisionRmpParams* p) {
  reader.Section(node, key,
                 {{"repulsion_gain", &p->repulsion_gain},
                  {"repulsion_std_dev", &p->repulsion_std_dev},
                  {"damping_gain", &p->damping_gain},
                  {"damping_std_dev", &p->damping_std_dev},
                  {"damping_robustness_eps", &p->damping_robustness_eps},
                  {"damping_velocity_gate_length_scale", &p->damping_velocity_gate_length_scale},
                  {"metric_scalar", &p->metric_scalar},
                  {"metric_exploder_std_dev", &p->metric_exploder_std_dev},
                  {"metric_exploder_eps", &p->metric_exploder_eps},
                  {"metric_modulation_radius", &p->metric_modulation_radius}});
}

void ReadRmpflowNode(const YAML::Node& root, const std::string& file, RmpflowOptions& o);

}  // namespace

RmpflowOptions LoadRmpflowOptions(const std::filesystem::path& path) {
  const std::string file = path.string();
  const YAML::Node root = internal::LoadYamlFile(file, "RMPflow config");
  RmpflowOptions o;
  if (root.IsNull()) return o;  // an empty file keeps every default
  ReadRmpflowNode(root, file, o);
  return o;
}

void ApplyRmpflowOverrides(RmpflowOptions& options, const std::string& overrides_yaml, const std::string& source) {
  const YAML::Node root = internal::LoadYamlText(overrides_yaml, source);
  if (root.IsNull()) return;
  if (!root.IsMap()) throw InputError(fmt::format("{}: expected a mapping of RMPflow config keys", source));
  RmpflowOptions o = options;
  ReadRmpflowNode(root, source, o);
  options = std::move(o);
}

namespace {

// reads the keys present in `root` onto `o` and validates the result
void ReadRmpflowNode(const YAML::Node& root, const std::string& file, RmpflowOptions& o) {
  const ConfigReader reader(file);
  reader.CheckKeys(root, "",
                   {"rmp_params", "self_collision_enabled", "joint_limit_buffer", "canonical_resolve", "home"});
  if (const YAML::Node params = root["rmp_params"]) {
    reader.CheckKeys(params, "rmp_params",
                     {"cspace_target_rmp", "cspace_damping_rmp", "joint_limit_rmp", "joint_velocity_cap_rmp",
                      "target_rmp", "collision_rmp", "self_collision_rmp"});
    if (const YAML::Node n = params["cspace_target_rmp"]) {
      CSpaceTargetRmpParams& p = o.cspace_target;
      reader.Section(n, "rmp_params.cspace_target_rmp",
                     {{"metric_scalar", &p.metric_scalar},
                      {"position_gain", &p.position_gain},
                      {"damping_gain", &p.damping_gain},
                      {"robust_position_term_thresh", &p.robust_position_term_thresh},
                      {"inertia", &p.inertia}});
    }
    if (const YAML::Node n = params["cspace_damping_rmp"]) {
      CSpaceDampingRmpParams& p = o.cspace_damping;
      reader.Section(n, "rmp_params.cspace_damping_rmp",
                     {{"accel_d_gain", &p.accel_d_gain}, {"metric_scalar", &p.metric_scalar}});
    }
    if (const YAML::Node n = params["joint_limit_rmp"]) {
      JointLimitRmpParams& p = o.joint_limit;
      reader.Section(n, "rmp_params.joint_limit_rmp",
                     {{"metric_scalar", &p.metric_scalar},
                      {"metric_length_scale", &p.metric_length_scale},
                      {"metric_exploder_eps", &p.metric_exploder_eps},
                      {"metric_velocity_gate_length_scale", &p.metric_velocity_gate_length_scale},
                      {"accel_damper_gain", &p.accel_damper_gain},
                      {"accel_potential_gain", &p.accel_potential_gain},
                      {"accel_potential_exploder_length_scale", &p.accel_potential_exploder_length_scale},
                      {"accel_potential_exploder_eps", &p.accel_potential_exploder_eps}});
    }
    if (const YAML::Node n = params["joint_velocity_cap_rmp"]) {
      JointVelocityCapRmpParams& p = o.joint_velocity_cap;
      reader.Section(n, "rmp_params.joint_velocity_cap_rmp",
                     {{"max_velocity", &p.max_velocity},
                      {"velocity_damping_region", &p.velocity_damping_region},
                      {"damping_gain", &p.damping_gain},
                      {"metric_weight", &p.metric_weight}});
    }
    if (const YAML::Node n = params["target_rmp"]) {
      TargetRmpParams& p = o.target;
      const std::string key = "rmp_params.target_rmp";
      reader.Section(n, key,
                     {{"accel_p_gain", &p.accel_p_gain},
                      {"accel_d_gain", &p.accel_d_gain},
                      {"accel_norm_eps", &p.accel_norm_eps},
                      {"metric_alpha_length_scale", &p.metric_alpha_length_scale},
                      {"min_metric_alpha", &p.min_metric_alpha},
                      {"max_metric_scalar", &p.max_metric_scalar},
                      {"min_metric_scalar", &p.min_metric_scalar},
                      {"proximity_metric_boost_scalar", &p.proximity_metric_boost_scalar},
                      {"proximity_metric_boost_length_scale", &p.proximity_metric_boost_length_scale}},
                     {"damping"});
      if (const YAML::Node d = n["damping"]) {
        const std::string value = d.IsScalar() ? d.Scalar() : "";
        if (value == "linear") {
          p.damping = TargetDamping::kLinear;
        } else if (value == "quadratic") {
          p.damping = TargetDamping::kQuadratic;
        } else {
          reader.Fail(d, key + ".damping", fmt::format("expected 'linear' or 'quadratic', got '{}'", value));
        }
      }
    }
    if (const YAML::Node n = params["collision_rmp"]) {
      ReadCollision(reader, n, "rmp_params.collision_rmp", &o.collision);
    }
    if (const YAML::Node n = params["self_collision_rmp"]) {
      ReadCollision(reader, n, "rmp_params.self_collision_rmp", &o.self_collision);
    }
  }
  if (const YAML::Node n = root["self_collision_enabled"]) {
    o.self_collision_enabled = reader.Bool(n, "self_collision_enabled");
  }
  if (const YAML::Node n = root["joint_limit_buffer"]) o.joint_limit_buffer = reader.Number(n, "joint_limit_buffer");
  if (const YAML::Node n = root["canonical_resolve"]) {
    reader.Section(n, "canonical_resolve",
                   {{"max_acceleration_norm", &o.max_acceleration_norm},
                    {"relative_regularizer", &o.resolve.relative_regularizer}});
  }
  if (const YAML::Node n = root["home"]) {
    if (!n.IsSequence()) reader.Fail(n, "home", "expected a list of joint positions");
    o.home.clear();
    for (size_t i = 0; i < n.size(); ++i) o.home.push_back(reader.Number(n[i], fmt::format("home[{}]", i)));
  }
  ValidateRmpflowOptions(o, file);
}

}  // namespace

std::filesystem::path RmpflowConfigDirectory() {
  return kinematics::ModelsDirectory().parent_path() / "configs" / "rmpflow";
}

std::filesystem::path RmpflowConfigPath(const std::string& robot_name) {
  const std::filesystem::path dir = RmpflowConfigDirectory();
  const std::filesystem::path specific = dir / (robot_name + ".yaml");
  return std::filesystem::exists(specific) ? specific : dir / "default.yaml";
}

std::filesystem::path RmpflowConfigPath(const kinematics::Robot& robot) {
  if (!robot.settings_path.empty()) return robot.settings_path;
  if (robot.shipped) return RmpflowConfigPath(robot.name);
  return RmpflowConfigDirectory() / "default.yaml";
}

RmpflowOptions LoadRmpflowOptions(const kinematics::Robot& robot) {
  RmpflowOptions options = LoadRmpflowOptions(RmpflowConfigPath(robot));
  if (robot.home.size() > 0) options.home.assign(robot.home.data(), robot.home.data() + robot.home.size());
  return options;
}

}  // namespace rmpmarl::rmp
