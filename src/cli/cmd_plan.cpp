// hullgauge plan --part P.yaml --station S.yaml [--out plan.json] [--report plan.md]
// Weak-convexity check and view planning (docs/contracts.md §5, docs/planning.md).
// plan.json goes to --out (or stdout); beside it a poses file for
// `hullgauge simulate` and the capture sequence. A plan that cannot be made
// (a landmark in a concavity, a fixture range that excludes every witness, a
// tolerance below the station's MED, too few views allowed) exits 2 with one
// sentence per problem on stderr; so does a plan whose views cannot decide a
// landmark's tolerance (the capability check: tolerance zone < 4 U,
// docs/inspection.md, "Capability") unless --force.
#include "command.h"
#include "hullgauge/common/error.h"
#include "hullgauge/geometry/station.h"
#include "hullgauge/inspect/capability.h"
#include "hullgauge/model/part_program.h"
#include "hullgauge/plan/plan_report.h"
#include "hullgauge/plan/program_plan.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <string>

namespace hg::cli {
namespace {

namespace fs = std::filesystem;

struct PlanArgs {
    std::string part;
    std::string station;
    std::string out;
    std::string report;
    std::string poses;
    std::size_t maxViews = 0;
    bool exact = false;
    double rotationStep = 5.0;
    double declinationStep = 5.0;
    double railStep = 5.0;
    double band = 2.0;
    double floorRadius = 0.0;
    int samples = 7;
    bool force = false;
};

void writeText(const fs::path& file, const std::string& text)
{
    std::ofstream f(file);
    f << text;
    if (!f) throw FaultError("cannot write " + file.string());
}

/// Prints the expected U of every landmark; false when one is refused and not forced.
bool reportCapability(const std::vector<inspect::LandmarkCapability>& capability, const PlanArgs& args)
{
    std::cerr << "hullgauge plan: expected uncertainty (k = 2) at the planned views:\n";
    bool refused = false;
    for (const auto& c : capability) {
        std::cerr << "  " << inspect::describe(c) << '\n';
        refused = refused || !c.capable;
    }
    if (!refused) return true;
    if (args.force) {
        std::cerr << "hullgauge plan: --force: the landmarks this station cannot prove are inspected as never ok\n";
        return true;
    }
    std::cerr << "hullgauge plan: " << args.part
              << ": the station cannot decide every tolerance (test uncertainty ratio 4:1); loosen the tolerance, "
                 "bring the camera closer, or give --force\n";
    return false;
}

int run(const PlanArgs& args)
{
    const model::PartProgram program = model::loadPartProgram(args.part);
    const geometry::Station station = geometry::loadStation(args.station);
    if (program.bestViewFixture && *program.bestViewFixture != station.fixture.type)
        throw InputError(args.part, "landmarks[].best_views",
                         "best views are written for a different fixture type than the station's");

    plan::PlanOptions options;
    options.grid.rotationStepDeg = args.rotationStep;
    options.grid.declinationStepDeg = args.declinationStep;
    options.grid.railStepMm = args.railStep;
    options.bandDeg = args.band;
    options.maxViews = args.maxViews;
    options.exact = args.exact;
    options.rules.samplesPerSide = args.samples;
    if (args.floorRadius > 0.0) options.rules.floorRadiusMm = args.floorRadius;
    options.pareLayers = std::max(1, program.octree.adjacencyDepth);

    std::cerr << "hullgauge plan: " << program.landmarks.size() << " landmarks of " << program.part << "...\n";
    const plan::ProgramPlan planned = plan::planProgram(program, station, options);
    const plan::ViewPlan& result = planned.plan;
    const plan::PlanProblem& problem = planned.problem;
    const auto json = plan::toJson(planned);
    const auto& capability = planned.capability;

    if (args.out.empty()) {
        std::cout << json.dump(2) << '\n';
    } else {
        writeText(args.out, json.dump(2) + "\n");
    }
    fs::path posesFile = args.poses;
    if (posesFile.empty() && !args.out.empty()) {
        posesFile = fs::path(args.out);
        posesFile.replace_extension(".poses.yaml");
    }
    if (!posesFile.empty() && result.feasible) writeText(posesFile, plan::posesYaml(result, station.fixture.type));

    const std::string report = plan::planMarkdown(result, problem);
    if (!args.report.empty())
        writeText(args.report, report);
    else
        std::cerr << report;

    if (!result.feasible) {
        std::cerr << "hullgauge plan: " << args.part << ": no plan:\n";
        for (const auto& p : result.problems) std::cerr << "  " << p << '\n';
        return static_cast<int>(ExitStatus::BadInput);
    }
    if (capability && !reportCapability(*capability, args)) return static_cast<int>(ExitStatus::BadInput);
    std::cerr << "hullgauge plan: " << result.views.size() << " views";
    if (!posesFile.empty()) std::cerr << "; poses in " << posesFile.string();
    std::cerr << '\n';
    return 0;
}

std::function<int()> factory(CLI::App& app)
{
    auto args = std::make_shared<PlanArgs>();
    auto* cmd = app.add_subcommand("plan", "weak-convexity check and view planning for a part on a station");
    cmd->add_option("--part", args->part, "part program (YAML)")->required()->check(CLI::ExistingFile);
    cmd->add_option("--station", args->station, "station description (YAML)")->required()->check(CLI::ExistingFile);
    cmd->add_option("--out", args->out, "plan.json (default: stdout); a poses file is written beside it");
    cmd->add_option("--report", args->report, "Markdown report for the designer (default: stderr)");
    cmd->add_option("--poses", args->poses, "poses YAML of the planned views (default: <out>.poses.yaml)");
    cmd->add_option("--max-views", args->maxViews, "requested view count; fail when the accuracy needs more (0: any)");
    cmd->add_flag("--force", args->force,
                  "plan although a landmark's tolerance zone is narrower than 4 U at the planned views");
    cmd->add_flag("--exact", args->exact, "also solve the view cover exactly (GLPK) and report the optimum");
    cmd->add_option("--rotation-step", args->rotationStep, "pose grid: rotation step, degrees")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    cmd->add_option("--declination-step", args->declinationStep, "pose grid: declination step, degrees")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    cmd->add_option("--rail-step", args->railStep, "pose grid: rail step, mm")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    cmd->add_option("--band", args->band, "tangent-plane band for non-grazing candidates, degrees")
        ->check(CLI::NonNegativeNumber)
        ->capture_default_str();
    cmd->add_option("--floor-radius", args->floorRadius,
                    "radius of the floor disc about the turntable axis, mm (default: the part's footprint)")
        ->check(CLI::NonNegativeNumber);
    cmd->add_option("--samples", args->samples, "Rule 1: lines of sight per side of a voxel footprint")
        ->check(CLI::Range(2, 32))
        ->capture_default_str();
    return [args] { return run(*args); };
}

HG_REGISTER_COMMAND("plan", factory);

} // namespace
} // namespace hg::cli
