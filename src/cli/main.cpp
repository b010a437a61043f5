// hullgauge — the maintenance and offline tool (docs/contracts.md §5).
#include <algorithm>
#include <iostream>
#include <memory>

#include <CLI/CLI.hpp>

#include "command.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"

namespace hg::cli {

CommandRegistration::CommandRegistration(std::string name, CommandFactory factory)
{
    commands().emplace_back(std::move(name), std::move(factory));
}

std::vector<std::pair<std::string, CommandFactory>>& commands()
{
    static std::vector<std::pair<std::string, CommandFactory>> list;
    return list;
}

} // namespace hg::cli

int main(int argc, char** argv)
{
    CLI::App app{"hullgauge: silhouette inspection station — offline and maintenance tool"};
    app.require_subcommand(1);
    std::string logSpec;
    app.add_option("--log", logSpec, "log levels, e.g. 'info' or 'warn,inspect=debug' (also $HULLGAUGE_LOG)");

    auto& registered = hg::cli::commands();
    std::sort(registered.begin(), registered.end(), [](auto& a, auto& b) { return a.first < b.first; });
    std::vector<std::pair<CLI::App*, std::function<int()>>> runners;
    for (auto& [name, factory] : registered) {
        // Each factory adds the subcommand `name` with its options.
        auto run = factory(app);
        runners.emplace_back(app.get_subcommand(name), std::move(run));
    }

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        // Usage errors are bad input (exit 2), help is success.
        int rc = app.exit(e);
        return rc == 0 ? 0 : static_cast<int>(hg::ExitStatus::BadInput);
    }

    try {
        if (!logSpec.empty()) hg::log::configure(logSpec);
        for (auto& [sub, run] : runners)
            if (sub->parsed()) return run();
    } catch (const hg::InputError& e) {
        std::cerr << "hullgauge: " << e.what() << '\n';
        return static_cast<int>(hg::ExitStatus::BadInput);
    } catch (const hg::FaultError& e) {
        std::cerr << "hullgauge: " << e.what() << '\n';
        return static_cast<int>(hg::ExitStatus::Fault);
    } catch (const std::exception& e) {
        // An ArgumentError that reaches here is a broken precondition no command turned into bad input: an
        // internal error, as anything else unexpected (docs/style.md point 4).
        std::cerr << "hullgauge: internal error: " << e.what() << '\n';
        return static_cast<int>(hg::ExitStatus::Fault);
    }
    return static_cast<int>(hg::ExitStatus::BadInput);
}
