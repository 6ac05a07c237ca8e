#pragma once
/// The range checks of configuration structs built in code or read from files, with messages "<where>: key '<key>':
/// expected <expected>, got <got>". Shared by the agent and task config validators. Namespace internal: for the
/// library's own validators, not a stable API.
#include <fmt/format.h>

#include <array>
#include <cmath>
#include <string>
#include <string_view>

#include "rmpmarl/common/error.h"

namespace rmpmarl::internal {

class ConfigChecker {
 public:
  explicit ConfigChecker(std::string_view where) : where_(where) {}
  /// throws InputError "<where>: key '<key>': expected <expected>, got <got>" unless ok.
  template <typename T>
  void operator()(bool ok, std::string_view key, std::string_view expected, const T& got) const {
    if (!ok) throw InputError(fmt::format("{}: key '{}': expected {}, got {}", where_, key, expected, got));
  }
  /// a finite [min, max] with lo <= min <= max <= hi.
  void Range(const std::array<double, 2>& r, std::string_view key, double lo, double hi) const {
    (*this)(std::isfinite(r[0]) && std::isfinite(r[1]) && r[0] >= lo && r[0] <= r[1] && r[1] <= hi, key,
            fmt::format("[min, max] with {} <= min <= max <= {}", lo, hi), fmt::format("[{}, {}]", r[0], r[1]));
  }
  const std::string& where() const { return where_; }

 private:
  std::string where_;
};

}  // namespace rmpmarl::internal
