#include "temp_files.h"

#include <fmt/format.h>
#include <unistd.h>

#include <fstream>

namespace rmpmarl::test {

std::filesystem::path FreshTempDir(std::string_view suite, std::string_view name) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / fmt::format("rmpmarl-{}-{}-{}", suite, name, ::getpid());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

void WriteTextFile(const std::filesystem::path& path, std::string_view text) {
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

}  // namespace rmpmarl::test
