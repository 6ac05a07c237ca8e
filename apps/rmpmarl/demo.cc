// `rmpmarl demo`: the README's main job. Until the reactive controller lands, it runs the robots sweep.
#include <fmt/core.h>

#include "commands.h"

namespace rmpmarl::apps {

void RegisterDemo(CLI::App& app) {
  auto* cmd = app.add_subcommand("demo", "Run the main demo (for now: every shipped robot swept in MuJoCo)");
  cmd->callback([] { RunRobotsTable(4.0); });
}

}  // namespace rmpmarl::apps
