#pragma once
// Temporary files of the tests: a fresh folder per test, text files written into it.
#include <filesystem>
#include <string_view>

namespace rmpmarl::test {

/// an empty folder <system temp>/rmpmarl-<suite>-<name>-<pid> (emptied when it is there from an earlier run)
std::filesystem::path FreshTempDir(std::string_view suite, std::string_view name);

/// writes `text` to `path`, creating the folders above it
void WriteTextFile(const std::filesystem::path& path, std::string_view text);

}  // namespace rmpmarl::test
