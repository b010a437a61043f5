// Subcommands of the `hullgauge` tool register themselves here, one file per
// command (cmd_<name>.cpp), so adding a command never touches main.cpp.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace hg::cli {

/// Adds a subcommand to `app` and returns the function that runs it; that
/// function returns the process exit status (docs/contracts.md §5).
using CommandFactory = std::function<std::function<int()>(CLI::App& app)>;

struct CommandRegistration {
    CommandRegistration(std::string name, CommandFactory factory);
};

std::vector<std::pair<std::string, CommandFactory>>& commands();

} // namespace hg::cli

#define HG_CLI_CONCAT2(a, b) a##b
#define HG_CLI_CONCAT(a, b) HG_CLI_CONCAT2(a, b)
/// HG_REGISTER_COMMAND("simulate", factory) at namespace scope in cmd_simulate.cpp.
#define HG_REGISTER_COMMAND(name, factory)                                                                             \
    static const ::hg::cli::CommandRegistration HG_CLI_CONCAT(hgCommand_, __LINE__)(name, factory)
