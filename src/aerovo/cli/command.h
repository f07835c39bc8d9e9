// Subcommand registry of the `aerovo` CLI. Each cmd_*.cc registers its subcommands with
// AEROVO_REGISTER_COMMAND, so adding a command never edits main.cc.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>
#include <vector>

namespace aerovo::cli {

/// Adds one or more subcommands (with their callbacks) to the root app.
using CommandRegistrar = void (*)(CLI::App& app);

std::vector<CommandRegistrar>& Registry();

/// The root's -v/--verbose flag (also accepted after the command): debug logging, and the
/// commands' longer output (`aerovo run` prints its configuration).
bool& VerboseFlag();

struct RegisterCommand {
  explicit RegisterCommand(CommandRegistrar r) { Registry().push_back(r); }
};

}  // namespace aerovo::cli

#define AEROVO_CLI_CONCAT_(a, b) a##b
#define AEROVO_CLI_CONCAT(a, b) AEROVO_CLI_CONCAT_(a, b)
#define AEROVO_REGISTER_COMMAND(fn) \
  static ::aerovo::cli::RegisterCommand AEROVO_CLI_CONCAT(aerovo_cli_register_, __COUNTER__)(fn)
