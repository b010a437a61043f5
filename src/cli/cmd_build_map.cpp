// hullgauge build-map --part P.yaml --out M.hgmap [--levels N]
// Builds the octree inspection map of a part program once (3.5.1) and writes
// it to a versioned binary file that `hullgauge inspect --map` loads in
// milliseconds (docs/inspection.md).
#include <iostream>
#include <string>

#include "command.h"
#include "hullgauge/common/error.h"
#include "hullgauge/inspect/part_map.h"

namespace hg::cli {
namespace {

struct BuildMapArgs {
    std::string part;
    std::string out;
    int levels = 3;
};

int run(const BuildMapArgs& args)
{
    const model::PartProgram program = model::loadPartProgram(args.part);
    const inspect::InspectionMap map = inspect::buildInspectionMap(program, args.levels);
    map.save(args.out);
    std::cerr << "hullgauge build-map: " << program.part << ": " << map.landmarks().size() << " landmarks, "
              << map.nodes().size() << " nodes, levels " << map.geometry().coarsestLevel << ".." << map.geometry().depth
              << " -> " << args.out << '\n';
    return 0;
}

std::function<int()> factory(CLI::App& app)
{
    auto args = std::make_shared<BuildMapArgs>();
    auto* cmd = app.add_subcommand("build-map", "build the octree inspection map of a part program");
    cmd->add_option("--part", args->part, "part program (YAML)")->required();
    cmd->add_option("--out", args->out, "inspection map file (.hgmap)")->required();
    cmd->add_option("--levels", args->levels, "inspection levels to prepare, counted up from the depth")
        ->check(CLI::Range(1, 16))
        ->capture_default_str();
    return [args] { return run(*args); };
}

HG_REGISTER_COMMAND("build-map", factory);

} // namespace
} // namespace hg::cli
