#pragma once
// Internal (not installed): reads YAML configuration nodes with messages that name the file, line and dotted key and
// say expected vs got. Shared by the robot description, RMPflow and task config loaders; yaml-cpp stays private.
#include <yaml-cpp/yaml.h>

#include <set>
#include <string>

namespace rmpmarl::internal {

class YamlReader {
 public:
  explicit YamlReader(std::string file) : file_(std::move(file)) {}
  const std::string& file() const { return file_; }

  /// throws InputError "<file>:<line>: key '<key>': <message>" (without the line when the node has none).
  [[noreturn]] void Fail(const YAML::Node& node, const std::string& key, const std::string& message) const;
  /// throws unless `map` is a mapping whose keys are all in `allowed` (key "" is the document root).
  void CheckKeys(const YAML::Node& map, const std::string& key, const std::set<std::string>& allowed) const;
  /// a finite number (±inf too when allow_inf); "missing" when the node is absent.
  double Number(const YAML::Node& node, const std::string& key, bool allow_inf = false) const;
  /// an integral number of magnitude ≤ 1e9.
  int Integer(const YAML::Node& node, const std::string& key) const;
  bool Bool(const YAML::Node& node, const std::string& key) const;
  std::string String(const YAML::Node& node, const std::string& key) const;

 private:
  std::string file_;
};

/// merges the mapping `over` into `base`: nested mappings key by key, anything else replaced (by a copy). Throws
/// InputError "<where>: ..." when a key of `over` is a sequence or mapping instead of a plain name.
void MergeYamlMaps(YAML::Node base, const YAML::Node& over, const std::string& where);

}  // namespace rmpmarl::internal
