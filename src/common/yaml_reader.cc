#include "yaml_reader.h"

#include <fmt/format.h>

#include <cmath>

#include "rmpmarl/common/error.h"

namespace rmpmarl::internal {

void MergeYamlMaps(YAML::Node base, const YAML::Node& over, const std::string& where) {
  for (const auto& kv : over) {
    if (!kv.first.IsScalar()) {  // e.g. {[a]: 1} (found by fuzzing)
      throw InputError(fmt::format("{}: expected plain key names, got a sequence or mapping as a key", where));
    }
    const std::string key = kv.first.Scalar();
    if (kv.second.IsMap() && base[key] && base[key].IsMap()) {
      MergeYamlMaps(base[key], kv.second, where);
    } else {
      base[key] = YAML::Clone(kv.second);
    }
  }
}

void YamlReader::Fail(const YAML::Node& node, const std::string& key, const std::string& message) const {
  if (node.IsDefined() && node.Mark().line >= 0) {
    throw InputError(fmt::format("{}:{}: key '{}': {}", file_, node.Mark().line + 1, key, message));
  }
  throw InputError(fmt::format("{}: key '{}': {}", file_, key, message));
}

void YamlReader::CheckKeys(const YAML::Node& map, const std::string& key, const std::set<std::string>& allowed) const {
  if (!map.IsMap()) Fail(map, key.empty() ? "<root>" : key, "expected a mapping");
  for (const auto& entry : map) {
    // a sequence or mapping as a key (`? [a, b]: 1`, `{[x]: 1}`) is no key of ours
    if (!entry.first.IsScalar()) {
      Fail(entry.first, key.empty() ? "<root>" : key, "expected plain keys, got a sequence or mapping as a key");
    }
    const std::string name = entry.first.Scalar();
    if (!allowed.count(name)) {
      std::string list;
      for (const std::string& a : allowed) list += (list.empty() ? "" : ", ") + a;
      Fail(entry.first, key.empty() ? name : key + "." + name, fmt::format("unknown key (expected one of: {})", list));
    }
  }
}

double YamlReader::Number(const YAML::Node& node, const std::string& key, bool allow_inf) const {
  if (!node.IsDefined()) Fail(node, key, "missing");
  double value = 0.0;
  if (!node.IsScalar() || !YAML::convert<double>::decode(node, value)) {
    Fail(node, key, fmt::format("expected a number, got '{}'", node.IsScalar() ? node.Scalar() : "non-scalar"));
  }
  if (std::isnan(value) || (!allow_inf && !std::isfinite(value))) {
    Fail(node, key, fmt::format("expected a finite number, got {}", node.Scalar()));
  }
  return value;
}

int YamlReader::Integer(const YAML::Node& node, const std::string& key) const {
  const double value = Number(node, key);
  if (value != std::round(value) || std::abs(value) > 1e9) {
    Fail(node, key, fmt::format("expected an integer, got {}", node.Scalar()));
  }
  return static_cast<int>(value);
}

bool YamlReader::Bool(const YAML::Node& node, const std::string& key) const {
  bool value = false;
  if (!node.IsScalar() || !YAML::convert<bool>::decode(node, value)) {
    Fail(node, key, fmt::format("expected true or false, got '{}'", node.IsScalar() ? node.Scalar() : "non-scalar"));
  }
  return value;
}

std::string YamlReader::String(const YAML::Node& node, const std::string& key) const {
  if (!node.IsDefined()) Fail(node, key, "missing");
  if (!node.IsScalar()) Fail(node, key, "expected a string");
  return node.Scalar();
}

}  // namespace rmpmarl::internal
