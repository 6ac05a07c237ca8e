#pragma once
// Runs the rmpmarl CLI from a test, as a user runs it: one command line, its output and exit code.
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace rmpmarl::test {

struct CommandResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

// runs the rmpmarl CLI (RMPMARL_CLI_PATH) with `args` and captures its output and exit code.
inline CommandResult RunCli(const std::string& args) {
  const std::string command = std::string(RMPMARL_CLI_PATH) + " " + args + " 2>&1";
  CommandResult result;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return result;
  std::array<char, 4096> buffer{};
  while (fgets(buffer.data(), buffer.size(), pipe) != nullptr) result.output += buffer.data();
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

}  // namespace rmpmarl::test
