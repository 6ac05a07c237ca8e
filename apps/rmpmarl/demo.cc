// `rmpmarl demo`: placeholder until the world sweep lands.
#include <fmt/core.h>

#include "commands.h"

namespace rmpmarl::apps {

void RegisterDemo(CLI::App& app) {
  auto* cmd = app.add_subcommand("demo", "Run the main demo");
  cmd->callback([] { fmt::print("demo\n"); });
}

}  // namespace rmpmarl::apps
