#pragma once
/// Reads YAML configuration nodes with messages that name the file, line and dotted key and say expected vs got: the
/// building blocks of every config loader of the library (robot description, RMPflow, agents, tasks, planning,
/// experiments). Namespace internal: for the library's own loaders, not a stable API.
#include <yaml-cpp/yaml.h>

#include <array>
#include <functional>
#include <initializer_list>
#include <set>
#include <string>
#include <string_view>
#include <vector>

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
  /// [min, max] (or one number for both), min <= max.
  std::array<double, 2> Range(const YAML::Node& node, const std::string& key) const;
  /// a number or a non-empty list of numbers.
  std::vector<double> List(const YAML::Node& node, const std::string& key) const;
  /// the index of the node's value among `names`.
  int Choice(const YAML::Node& node, const std::string& key, std::initializer_list<std::string_view> names) const;

 private:
  std::string file_;
};

/// A field of a configuration section: its key and how to read it (value node, dotted key).
struct YamlField {
  std::string key;
  std::function<void(const YAML::Node&, const std::string&)> read;
};

/// reads a mapping whose allowed keys are exactly those of `fields` plus `also_allowed` (keys another reader of the
/// same section reads); `key` is the section's dotted key.
void ReadYamlSection(const YamlReader& r, const YAML::Node& node, const std::string& key,
                     const std::vector<YamlField>& fields, const std::set<std::string>& also_allowed = {});

/// fields that store into `target` (which must outlive the read): a number, an integer, a flag, a range.
YamlField NumberField(const YamlReader& r, std::string key, double* target, bool allow_inf = false);
YamlField IntegerField(const YamlReader& r, std::string key, int* target);
YamlField FlagField(const YamlReader& r, std::string key, bool* target);
YamlField RangeField(const YamlReader& r, std::string key, std::array<double, 2>* target);

/// reads a YAML file; throws InputError "<file>: cannot open <what> (missing or unreadable)" or
/// "<file>:<line>: malformed YAML: ...".
YAML::Node LoadYamlFile(const std::string& file, std::string_view what);

/// parses YAML text; throws InputError "<source>:<line>: malformed YAML: ..." on a syntax error.
YAML::Node LoadYamlText(const std::string& text, const std::string& source);

/// merges the mapping `over` into `base`: nested mappings key by key, anything else replaced (by a copy). Throws
/// InputError "<where>: ..." when a key of `over` is a sequence or mapping instead of a plain name.
void MergeYamlMaps(YAML::Node base, const YAML::Node& over, const std::string& where);

}  // namespace rmpmarl::internal
