// aerovo: visual odometry for a downward-looking UAV camera (Ivanov & Muzychuk 2023, and more).
#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <exception>
#include <iostream>

#include "aerovo/cli/command.h"

namespace aerovo::cli {
std::vector<CommandRegistrar>& Registry() {
  static std::vector<CommandRegistrar> registry;
  return registry;
}
}  // namespace aerovo::cli

int main(int argc, char** argv) {
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
