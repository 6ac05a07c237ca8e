// rmpmarl: command-line entry point; user errors print one clear line and exit non-zero.
#include <fmt/core.h>

#include <CLI/CLI.hpp>
#include <exception>

#include "commands.h"
#include "rmpmarl/common/error.h"

int main(int argc, char** argv) {
  CLI::App app{"rmpmarl — reactive motion generation for robot manipulators (RMPs + hierarchical multi-agent RL)"};
  app.require_subcommand(1);
  rmpmarl::apps::RegisterCheckRobot(app);
  rmpmarl::apps::RegisterSetupRobot(app);
  rmpmarl::apps::RegisterRobots(app);
  rmpmarl::apps::RegisterDemo(app);
  rmpmarl::apps::RegisterView(app);
  rmpmarl::apps::RegisterPolicy(app);
#ifdef RMPMARL_HAS_TORCH
  rmpmarl::apps::RegisterTrain(app, argc, argv);
  rmpmarl::apps::RegisterEval(app);
  rmpmarl::apps::RegisterExportPolicy(app);
  rmpmarl::apps::RegisterUpgradeCheckpoint(app);
  rmpmarl::apps::RegisterExperiment(app, argc, argv);
  rmpmarl::apps::RegisterBenchmark(app, argc, argv);
  rmpmarl::apps::RegisterProbeLookahead(app);
#endif
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const rmpmarl::InputError& e) {
    fmt::print(stderr, "rmpmarl: error: {}\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    fmt::print(stderr, "rmpmarl: unexpected error: {}\n", e.what());
    return 1;
  }
  return 0;
}
