// hullgauge landmarks suggest --mesh M [--count N] [--station S] [--depth D] ...
// Landmarks proposed on a CAD model — on its faces, edges and holes, each
// inspectable at the station and spread over the part — written as a part
// program's `landmarks:` list for the engineer to edit (dissertation 6.2,
// future work 6; docs/part-program.md, "Suggesting landmarks"). The method is
// in include/hullgauge/plan/landmark_suggest.h.
#include "command.h"
#include "hullgauge/commission/screen.h"
#include "hullgauge/common/durable_file.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"
#include "hullgauge/geometry/station.h"
#include "hullgauge/model/part_program.h"
#include "hullgauge/plan/landmark_suggest.h"

#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>

namespace hg::cli {
namespace {

namespace fs = std::filesystem;

/// The station the installed package's daemon runs: the simulated line's,
/// until the engineer replaces it (docs/daemon.md, "Installing the package").
constexpr const char* kInstalledStation = "/etc/hullgauge/station.yaml";

struct SuggestArgs {
    std::string mesh;
    std::string solid;
    std::string station;
    std::string out;
    std::size_t count = 8;
    int depth = 8;
    int adjacencyDepth = 3;
    double toleranceMm = 0.5;
    std::size_t twinSeats = 8;
    std::string refused;
};

std::string stationFile(const SuggestArgs& args)
{
    if (!args.station.empty()) return args.station;
    if (!fs::exists(kInstalledStation))
        throw InputError("", "--station",
                         std::string("no --station given and the installed station ") + kInstalledStation +
                             " does not exist; name one, e.g. --station config/sim/station.yaml");
    return kInstalledStation;
}

/// The fragment's header: what was suggested from, and how to use it.
std::vector<std::string> header(const SuggestArgs& args, const std::string& station, const model::CadModel& cad,
                                const plan::Suggestion& s)
{
    const std::size_t found = s.candidates[0] + s.candidates[1] + s.candidates[2];
    const std::size_t inspectable = s.inspectable[0] + s.inspectable[1] + s.inspectable[2];
    return {
        "Landmarks suggested for " + args.mesh + (args.solid.empty() ? "" : " (solid " + args.solid + ")") +
            " at the station " + station +
            " (hullgauge landmarks suggest; docs/part-program.md, \"Suggesting landmarks\").",
        "Judged with octree depth " + std::to_string(args.depth) + ", adjacency_depth " +
            std::to_string(args.adjacencyDepth) + " (ΔV = " + formatNumber(cad.octree.voxelSize(), 4) +
            " mm, the default cube) and tolerance_mm " + formatNumber(args.toleranceMm, 6) +
            ": give the part program that octree, and each landmark its tolerance from the drawing.",
        std::to_string(s.landmarks.size()) + " of " + std::to_string(inspectable) + " inspectable candidates (" +
            std::to_string(found) + " on the part: " + std::to_string(s.candidates[0]) + " face, " +
            std::to_string(s.candidates[1]) + " edge, " + std::to_string(s.candidates[2]) +
            " hole), spread by farthest-point selection" +
            (args.twinSeats > 0 ? ", each proven at " + std::to_string(args.twinSeats) +
                                      " seats of the nominal part on the station's digital twin"
                                : std::string()) +
            ".",
        "Candidates refused, by rule: " + plan::refusedSummary(s) +
            (args.refused.empty() ? " (--refused FILE lists each)." : " (each in " + args.refused + ")."),
    };
}

int run(const SuggestArgs& args)
{
    const std::string station = stationFile(args);
    const model::CadModel cad = model::loadCadModel(args.mesh, args.depth, args.adjacencyDepth, args.solid);
    const geometry::Station st = geometry::loadStation(station);

    plan::SuggestOptions options;
    options.count = args.count;
    options.toleranceMm = args.toleranceMm;
    options.plan.pareLayers = args.adjacencyDepth; // as `hullgauge plan` plans the program
    if (args.twinSeats > 0) {
        commission::ScreenOptions screen;
        screen.seats = args.twinSeats;
        screen.toleranceMm = args.toleranceMm;
        options.screen = commission::twinScreen(
            commission::draftProgram(cad, fs::path(args.mesh).stem().string(), options.alignment), st, screen);
    }

    std::cerr << "hullgauge landmarks suggest: " << args.mesh << " at " << station << "...\n";
    const plan::Suggestion s = plan::suggestLandmarks(plan::suggestProblem(cad, st), options);
    if (!args.refused.empty())
        replaceFileDurably(args.refused, "# Candidates refused for " + args.mesh + "\n\n" + plan::refusedSummary(s) +
                                             ".\n\n" + plan::refusedMarkdown(s));
    // A part program needs at least one landmark: an empty list is no suggestion.
    if (s.landmarks.empty())
        throw InputError(args.mesh, "landmarks",
                         "no point of the part found (" +
                             std::to_string(s.candidates[0] + s.candidates[1] + s.candidates[2]) +
                             " candidates) is inspectable at the station " + station + " with tolerance_mm " +
                             formatNumber(args.toleranceMm, 6) + (s.notes.empty() ? "" : ": " + s.notes.front()));
    const std::string yaml = plan::landmarksYaml(s, args.toleranceMm, header(args, station, cad, s));
    if (args.out.empty()) {
        std::cout << yaml;
    } else {
        std::ofstream f(args.out);
        f << yaml;
        if (!f) throw FaultError("cannot write " + args.out);
    }
    for (const std::string& note : s.notes) std::cerr << "hullgauge landmarks suggest: note: " << note << '\n';
    std::cerr << "hullgauge landmarks suggest: " << s.landmarks.size() << " landmarks";
    if (!args.out.empty()) std::cerr << " in " << args.out;
    std::cerr << '\n';
    return 0;
}

std::function<int()> factory(CLI::App& app)
{
    auto* cmd = app.add_subcommand("landmarks", "landmark help for part programs");
    cmd->require_subcommand(1);
    auto args = std::make_shared<SuggestArgs>();
    auto* sub =
        cmd->add_subcommand("suggest", "propose inspectable landmarks on faces, edges and holes of a CAD model, "
                                       "spread over the part, as a part program's landmarks list");
    sub->add_option("--mesh", args->mesh, "CAD model: STL, OBJ, PLY, OFF or STEP")
        ->required()
        ->check(CLI::ExistingFile);
    sub->add_option("--solid", args->solid,
                    "the STEP file's solid to suggest on, by product or instance name, as a part program's mesh_solid "
                    "(default: the union of all)");
    sub->add_option("--station", args->station,
                    std::string("station the landmarks must be inspectable at (default: ") + kInstalledStation + ")");
    sub->add_option("--count", args->count, "landmarks to suggest")->check(CLI::Range(1, 10000))->capture_default_str();
    sub->add_option("--depth", args->depth, "octree depth the landmarks are judged at (ΔV)")
        ->check(CLI::Range(1, model::kMaxOctreeDepth))
        ->capture_default_str();
    sub->add_option("--adjacency-depth", args->adjacencyDepth, "octree adjacency_depth (type-four layers)")
        ->check(CLI::Range(1, 64))
        ->capture_default_str();
    sub->add_option("--tolerance", args->toleranceMm, "tolerance_mm the landmarks are judged and written with, mm")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    sub->add_option("--out", args->out, "write the landmarks list here (default: stdout)");
    sub->add_option("--twin-seats", args->twinSeats,
                    "seats of the nominal part each suggestion is proven at on the station's digital twin "
                    "(0: not on the twin)")
        ->check(CLI::Range(0, 1000))
        ->capture_default_str();
    sub->add_option("--refused", args->refused,
                    "write every refused candidate with the rule that removed it here (Markdown)");
    return [args] { return run(*args); };
}

HG_REGISTER_COMMAND("landmarks", factory);

} // namespace
} // namespace hg::cli
