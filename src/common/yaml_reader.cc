#include "rmpmarl/common/yaml_reader.h"

#include <fmt/format.h>

#include <cmath>

#include "rmpmarl/common/error.h"

namespace rmpmarl::internal {

YAML::Node LoadYamlFile(const std::string& file, std::string_view what) {
  try {
    return YAML::LoadFile(file);
  } catch (const YAML::BadFile&) {
    throw InputError(fmt::format("{}: cannot open {} (missing or unreadable)", file, what));
  } catch (const YAML::Exception& e) {
    throw InputError(fmt::format("{}:{}: malformed YAML: {}", file, e.mark.line + 1, e.msg));
  }
}

YAML::Node LoadYamlText(const std::string& text, const std::string& source) {
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(fmt::format("{}:{}: malformed YAML: {}", source, e.mark.line + 1, e.msg));
  }
}

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

std::array<double, 2> YamlReader::Range(const YAML::Node& node, const std::string& key) const {
  if (node.IsScalar()) {
    const double v = Number(node, key);
    return {v, v};
  }
  if (!node.IsSequence() || node.size() != 2) Fail(node, key, "expected [min, max] or a single number");
  const std::array<double, 2> r = {Number(node[0], key + "[0]"), Number(node[1], key + "[1]")};
  if (r[0] > r[1]) Fail(node, key, fmt::format("expected min <= max, got [{}, {}]", r[0], r[1]));
  return r;
}

std::vector<double> YamlReader::List(const YAML::Node& node, const std::string& key) const {
  if (node.IsScalar()) return {Number(node, key)};
  if (!node.IsSequence() || node.size() == 0) Fail(node, key, "expected a number or a non-empty list of numbers");
  std::vector<double> values;
  for (size_t i = 0; i < node.size(); ++i) values.push_back(Number(node[i], fmt::format("{}[{}]", key, i)));
  return values;
}

int YamlReader::Choice(const YAML::Node& node, const std::string& key,
                       std::initializer_list<std::string_view> names) const {
  const std::string value = String(node, key);
  int i = 0;
  std::string list;
  for (std::string_view n : names) {
    if (value == n) return i;
    list += fmt::format("{}'{}'", i == 0 ? "" : ", ", n);
    ++i;
  }
  Fail(node, key, fmt::format("expected one of {}, got '{}'", list, value));
}

void ReadYamlSection(const YamlReader& r, const YAML::Node& node, const std::string& key,
                     const std::vector<YamlField>& fields, const std::set<std::string>& also_allowed) {
  std::set<std::string> allowed = also_allowed;
  for (const YamlField& f : fields) allowed.insert(f.key);
  r.CheckKeys(node, key, allowed);
  for (const YamlField& f : fields) {
    if (const YAML::Node value = node[f.key]) f.read(value, key + "." + f.key);
  }
}

YamlField NumberField(const YamlReader& r, std::string key, double* target, bool allow_inf) {
  return {std::move(key),
          [&r, target, allow_inf](const YAML::Node& n, const std::string& k) { *target = r.Number(n, k, allow_inf); }};
}
YamlField IntegerField(const YamlReader& r, std::string key, int* target) {
  return {std::move(key), [&r, target](const YAML::Node& n, const std::string& k) { *target = r.Integer(n, k); }};
}
YamlField FlagField(const YamlReader& r, std::string key, bool* target) {
  return {std::move(key), [&r, target](const YAML::Node& n, const std::string& k) { *target = r.Bool(n, k); }};
}
YamlField RangeField(const YamlReader& r, std::string key, std::array<double, 2>* target) {
  return {std::move(key), [&r, target](const YAML::Node& n, const std::string& k) { *target = r.Range(n, k); }};
}

}  // namespace rmpmarl::internal
