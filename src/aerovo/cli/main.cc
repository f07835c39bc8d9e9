// aerovo: visual odometry for a downward-looking UAV camera (Ivanov & Muzychuk 2023, and more).
#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <unistd.h>

#include <cstdlib>
#include <exception>
#include <iostream>

#include "aerovo/cli/command.h"

namespace aerovo::cli {
std::vector<CommandRegistrar>& Registry() {
  static std::vector<CommandRegistrar> registry;
  return registry;
}
}  // namespace aerovo::cli

namespace {

// Passive OpenMP waits by default (issue 19): libgomp's threads spin up to ~300,000 iterations
// before sleeping at the end of each parallel region, which on a machine whose cores are shared
// with other work (an autopilot link, an encoder, a logger) steals the CPU those need and halves
// a 1080p run's speed (BENCHMARKS.md, "Busy machine"). libgomp reads OMP_WAIT_POLICY and
// GOMP_SPINCOUNT once, when it is loaded, before main runs: setting them here is too late for
// this process, so aerovo sets OMP_WAIT_POLICY=passive and executes itself again, once
// (/proc/self/exe, the same arguments). A user who sets either variable keeps it (and no
// re-execution happens); if the re-execution fails, the run goes on with libgomp's defaults.
void PreferPassiveOpenMpWaits(char** argv) {
  if (std::getenv("OMP_WAIT_POLICY") != nullptr || std::getenv("GOMP_SPINCOUNT") != nullptr) {
    return;
  }
  if (::setenv("OMP_WAIT_POLICY", "passive", 1) != 0) return;
  ::execv("/proc/self/exe", argv);
  ::unsetenv("OMP_WAIT_POLICY");  // exec failed: nothing changed
}

}  // namespace

int main(int argc, char** argv) {
  PreferPassiveOpenMpWaits(argv);
  CLI::App app{
      "aerovo: where a UAV is, from its downward-looking camera alone.\n"
      "Visual odometry after Ivanov & Muzychuk (2023): SURF, matching, (clustered) RANSAC."};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("aerovo ") + AEROVO_VERSION);
  bool verbose = false;
  app.add_flag("-v,--verbose", verbose, "Debug logging");
  app.parse_complete_callback([&] {
    spdlog::set_level(verbose ? spdlog::level::debug : spdlog::level::info);
  });
  for (auto registrar : aerovo::cli::Registry()) registrar(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    std::cerr << "aerovo: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
