// hullgauge part add|landmark|suggest|plan|view|commission|release|versions|diff|rollback --workspace W ...
// The part workbench on the command line (docs/workbench.md): a CAD model
// taken to a released part program in a workspace of parts — landmarks
// placed on the surface, suggested, planned, seen as the twin sees them,
// proven on the twin without release, released as numbered versions, compared
// and rolled back. The same engine the web HMI's Parts page runs
// (include/hullgauge/workbench/workspace.h); the HMI's jobs run this command.
//
// Exit status: 0 done, 1 commissioned but not releasable, 2 bad input (a
// refused model or landmark, a stale revision, a release refused: each named),
// 3 a fault or a commissioning cancelled by SIGTERM or SIGINT.
#include "command.h"
#include "hullgauge/commission/verification.h"
#include "hullgauge/common/durable_file.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"
#include "hullgauge/workbench/commissioning.h"
#include "hullgauge/workbench/workspace.h"

#include <csignal>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace hg::cli {
namespace {

namespace fs = std::filesystem;

/// The installed package's workspace and station (docs/workbench.md, docs/daemon.md).
constexpr const char* kDefaultWorkspace = "/var/lib/hullgauge/parts";
constexpr const char* kInstalledStation = "/etc/hullgauge/station.yaml";

struct PartArgs {
    std::string workspace = kDefaultWorkspace;
    std::string station;
    std::string by;
    std::string part;
    std::string id;
    bool json = false;
    int revision = 0;
    // add
    std::string cad, name, solid;
    double toleranceMm = 0.1;
    int depth = 8, adjacencyDepth = 4;
    // landmark add / set
    std::vector<double> at, normal, limits;
    std::string newId;
    bool normalFromMesh = false;
    // suggest, view, commission
    std::size_t count = 8, twinSeats = 8, seats = 20;
    int view = 0;
    std::string out;
    bool progress = false;
    std::uint64_t seed = 1;
    std::vector<double> defectMultiples{1.0, 2.0, 3.0};
    double seatShiftMm = -1.0, seatRotationDeg = -1.0;
    // release, diff, rollback
    int plcProgram = 0;
    std::vector<int> takenPrograms;
    std::string from, to;
    int version = 0;
};

void say(const std::string& line)
{
    std::cerr << "hullgauge part: " << line << '\n';
}

workbench::Actor actor(const PartArgs& args)
{
    return {args.by.empty() ? workbench::currentUser() : args.by};
}

std::string stationFile(const PartArgs& args)
{
    if (!args.station.empty()) return args.station;
    if (!fs::exists(kInstalledStation))
        throw InputError("", "--station",
                         std::string("no --station given and the installed station ") + kInstalledStation +
                             " does not exist; name one, e.g. --station config/sim/station.yaml");
    return kInstalledStation;
}

Eigen::Vector3d vec3(const std::vector<double>& v, const std::string& option)
{
    if (v.size() != 3) throw InputError("", option, "expected X,Y,Z (three numbers)");
    return {v[0], v[1], v[2]};
}

/// Whether the parsed subcommand `cmd` was given the option `name`.
bool given(const CLI::App& cmd, const std::string& name)
{
    const CLI::Option* option = cmd.get_option_no_throw(name);
    return option && option->count() > 0;
}

/// The landmark change the options describe.
workbench::LandmarkEdit landmarkEdit(const PartArgs& args, const CLI::App& options)
{
    workbench::LandmarkEdit edit;
    if (given(options, "--at")) edit.position = vec3(args.at, "--at");
    if (given(options, "--normal")) edit.normal = vec3(args.normal, "--normal");
    edit.normalFromMesh = args.normalFromMesh;
    if (given(options, "--tolerance")) edit.toleranceMm = args.toleranceMm;
    if (given(options, "--limits")) {
        if (args.limits.size() != 2) throw InputError("", "--limits", "expected LO,HI (two numbers, mm)");
        edit.limitsMm = std::make_pair(args.limits[0], args.limits[1]);
    }
    if (given(options, "--new-id")) edit.newId = args.newId;
    return edit;
}

void addCommon(CLI::App* cmd, PartArgs& args, bool changes)
{
    cmd->add_option("--workspace", args.workspace, "the workspace: one folder a part")
        ->envname("HULLGAUGE_WORKSPACE")
        ->capture_default_str();
    if (changes) cmd->add_option("--by", args.by, "who makes the change (default: the user)");
    cmd->add_flag("--json", args.json, "print the answer as JSON");
}

void addStation(CLI::App* cmd, PartArgs& args)
{
    cmd->add_option("--station", args.station,
                    std::string("the station the part is inspected at (default: ") + kInstalledStation + ")");
}

void printPart(const workbench::PartState& state, bool json)
{
    if (json) {
        std::cout << workbench::toJson(state).dump(2) << '\n';
        return;
    }
    std::cout << state.record.part << " at revision " << state.record.revision << ": " << state.record.cad << " ("
              << state.cadKind << ", " << state.triangles << " triangles), " << state.draft.landmarks.size()
              << " landmarks\n";
}

void printPlaced(const workbench::Placed& placed, bool json)
{
    if (json) {
        std::cout << workbench::toJson(placed).dump(2) << '\n';
        return;
    }
    const auto& l = placed.landmark;
    std::cout << l.id << " on " << enumName(l.on) << " at (" << formatNumber(l.position.x()) << ", "
              << formatNumber(l.position.y()) << ", " << formatNumber(l.position.z()) << "), normal ("
              << formatNumber(l.normal.x(), 4) << ", " << formatNumber(l.normal.y(), 4) << ", "
              << formatNumber(l.normal.z(), 4) << "), moved " << formatNumber(placed.movedMm, 4)
              << " mm; the draft is at revision " << placed.revision << '\n';
}

using Runner = std::function<int(const PartArgs&, const CLI::App&)>;

struct Sub {
    CLI::App* app;
    Runner run;
};

Sub addCommand(CLI::App* part, PartArgs& args)
{
    auto* cmd = part->add_subcommand("add", "add a part from its CAD model (checked as a part program's mesh)");
    addCommon(cmd, args, true);
    cmd->add_option("--cad", args.cad, "CAD model: STL, OBJ, PLY, OFF or STEP")->required();
    cmd->add_option("--name", args.name, "the part's name (default: the CAD file's stem)");
    cmd->add_option("--solid", args.solid, "the STEP file's solid that is the part (as mesh_solid)");
    cmd->add_option("--tolerance", args.toleranceMm, "the tolerance new landmarks get, mm")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    cmd->add_option("--depth", args.depth, "octree depth of the draft")
        ->check(CLI::Range(1, 15))
        ->capture_default_str();
    cmd->add_option("--adjacency-depth", args.adjacencyDepth, "octree adjacency_depth of the draft")
        ->check(CLI::Range(1, 64))
        ->capture_default_str();
    return {cmd, [](const PartArgs& a, const CLI::App&) {
                workbench::Workspace ws(a.workspace);
                workbench::AddOptions o{a.name, a.solid, a.toleranceMm, a.depth, a.adjacencyDepth};
                printPart(ws.add(a.cad, o, actor(a)), a.json);
                return 0;
            }};
}

std::vector<Sub> landmarkCommands(CLI::App* part, PartArgs& args)
{
    auto* lm = part->add_subcommand("landmark", "place, change or remove a landmark of the draft");
    lm->require_subcommand(1);
    auto* add = lm->add_subcommand("add", "place a landmark by a point near the part's surface");
    auto* set = lm->add_subcommand("set", "change a landmark");
    auto* remove = lm->add_subcommand("remove", "remove a landmark");
    for (CLI::App* cmd : {add, set, remove}) {
        addCommon(cmd, args, true);
        cmd->add_option("PART", args.part, "the part")->required();
        cmd->add_option("--revision", args.revision, "the draft's revision the change is made on")->required();
    }
    for (CLI::App* cmd : {set, remove}) cmd->add_option("ID", args.id, "the landmark")->required();
    for (CLI::App* cmd : {add, set}) {
        cmd->add_option("--at", args.at, "a point near the surface: X,Y,Z (mm)")->delimiter(',');
        cmd->add_option("--normal", args.normal, "the measuring direction: NX,NY,NZ")->delimiter(',');
        auto* tolerance = cmd->add_option("--tolerance", args.toleranceMm, "tolerance_mm")->check(CLI::PositiveNumber);
        tolerance->excludes(cmd->add_option("--limits", args.limits, "limits_mm: LO,HI")->delimiter(','));
    }
    add->add_option("--id", args.id, "the landmark's id (default: L<n>, the lowest n not taken)");
    add->get_option("--at")->required();
    set->add_option("--new-id", args.newId, "rename the landmark");
    set->add_flag("--normal-from-mesh", args.normalFromMesh, "drop the given normal: the loader's from the surface")
        ->excludes(set->get_option("--normal"));
    return {
        {add,
         [](const PartArgs& a, const CLI::App& o) {
             workbench::Workspace ws(a.workspace);
             const std::optional<std::string> id = a.id.empty() ? std::nullopt : std::optional<std::string>(a.id);
             printPlaced(ws.addLandmark(a.part, a.revision, id, landmarkEdit(a, o), actor(a)), a.json);
             return 0;
         }},
        {set,
         [](const PartArgs& a, const CLI::App& o) {
             workbench::Workspace ws(a.workspace);
             printPlaced(ws.changeLandmark(a.part, a.revision, a.id, landmarkEdit(a, o), actor(a)), a.json);
             return 0;
         }},
        {remove,
         [](const PartArgs& a, const CLI::App&) {
             workbench::Workspace ws(a.workspace);
             const int revision = ws.removeLandmark(a.part, a.revision, a.id, actor(a));
             std::cout << a.id << " removed; the draft is at revision " << revision << '\n';
             return 0;
         }},
    };
}

int runSuggest(const PartArgs& a)
{
    workbench::Workspace ws(a.workspace);
    const nlohmann::json s = ws.suggest(a.part, stationFile(a), {a.count, a.twinSeats});
    if (a.json) {
        std::cout << s.dump(2) << '\n';
        return 0;
    }
    std::size_t chosen = 0;
    for (const auto& c : s["candidates"]) chosen += c["refused"].is_null() ? 1 : 0;
    for (const auto& note : s["notes"]) say("note: " + note.get<std::string>());
    std::cout << chosen << " landmarks suggested for " << a.part
              << "; candidates refused: " << s["refused_by_rule"].get<std::string>() << " (suggestions.json)\n";
    return 0;
}

int runPlan(const PartArgs& a)
{
    workbench::Workspace ws(a.workspace);
    const workbench::PlanOutcome p = ws.plan(a.part, stationFile(a));
    if (a.json)
        std::cout << nlohmann::json{{"feasible", p.feasible}, {"views", p.views}, {"problems", p.problems}}.dump(2)
                  << '\n';
    else
        std::cout << (p.feasible ? std::to_string(p.views) + " views planned" : std::string("no plan")) << " for "
                  << a.part << " (plan.json, plan.md)\n";
    for (const std::string& problem : p.problems) say(problem);
    return p.feasible ? 0 : static_cast<int>(ExitStatus::BadInput);
}

int runView(const PartArgs& a)
{
    workbench::Workspace ws(a.workspace);
    replaceFileDurably(a.out, ws.viewImage(a.part, stationFile(a), a.view));
    std::cout << "view " << a.view << " of " << a.part << ": " << a.out << '\n';
    return 0;
}

std::vector<Sub> planCommands(CLI::App* part, PartArgs& args)
{
    auto* suggest = part->add_subcommand("suggest", "suggest landmarks on the part (suggestions.json)");
    auto* plan = part->add_subcommand("plan", "plan the draft's views (plan.json, plan.md)");
    auto* view = part->add_subcommand("view", "render a planned view as the twin sees it, with its landmarks");
    for (CLI::App* cmd : {suggest, plan, view}) {
        addCommon(cmd, args, false);
        addStation(cmd, args);
        cmd->add_option("PART", args.part, "the part")->required();
    }
    suggest->add_option("--count", args.count, "landmarks to suggest")
        ->check(CLI::Range(1, 10000))
        ->capture_default_str();
    suggest->add_option("--twin-seats", args.twinSeats, "seats each suggestion is proven at on the twin (0: none)")
        ->check(CLI::Range(0, 1000))
        ->capture_default_str();
    view->add_option("K", args.view, "the view, 1-based, in plan.json's order")->required();
    view->add_option("--out", args.out, "the PNG to write")->required();
    return {{suggest, [](const PartArgs& a, const CLI::App&) { return runSuggest(a); }},
            {plan, [](const PartArgs& a, const CLI::App&) { return runPlan(a); }},
            {view, [](const PartArgs& a, const CLI::App&) { return runView(a); }}};
}

/// Set by SIGTERM and SIGINT: the commissioning stops between two cycles.
volatile std::sig_atomic_t cancelSignal = 0;

extern "C" void onCancel(int signal)
{
    cancelSignal = signal;
}

int runCommission(const PartArgs& a)
{
    struct sigaction action {};
    action.sa_handler = onCancel;
    sigemptyset(&action.sa_mask);
    sigaction(SIGTERM, &action, nullptr);
    sigaction(SIGINT, &action, nullptr);
    workbench::CommissionSettings settings;
    settings.seats = a.seats;
    settings.seed = a.seed;
    settings.defectMultiples = a.defectMultiples;
    settings.seatShiftMm = a.seatShiftMm;
    settings.seatRotationDeg = a.seatRotationDeg;
    settings.progress = [&](const std::string& phase, std::size_t done, std::size_t total) {
        if (a.progress)
            std::cout << nlohmann::ordered_json{{"phase", phase}, {"done", done}, {"total", total}}.dump() << std::endl;
        return cancelSignal == 0;
    };
    workbench::Workspace ws(a.workspace);
    try {
        const workbench::CommissionOutcome o = ws.commission(a.part, stationFile(a), settings, actor(a));
        if (o.status == static_cast<int>(ExitStatus::BadInput)) say("no plan for " + a.part + ":");
        if (o.status == 0) say(a.part + " is verified and may be released (hullgauge part release)");
        if (o.status == static_cast<int>(ExitStatus::PartFails)) say(a.part + " is verified but not releasable:");
        for (const std::string& p : o.problems) std::cerr << "  " << p << '\n';
        return o.status;
    } catch (const commission::Cancelled&) {
        say(std::string("commissioning cancelled (") + (cancelSignal == SIGINT ? "SIGINT" : "SIGTERM") +
            "); the previous verification stays in place");
        return static_cast<int>(ExitStatus::Fault);
    }
}

int runRelease(const PartArgs& a, const CLI::App& o)
{
    workbench::Workspace ws(a.workspace);
    const std::optional<int> plc = given(o, "--plc-program") ? std::optional<int>(a.plcProgram) : std::nullopt;
    const workbench::Version v = ws.release(a.part, a.revision, stationFile(a), plc, a.takenPrograms, actor(a));
    if (a.json)
        std::cout << workbench::toJson(v).dump(2) << '\n';
    else
        std::cout << "released " << a.part << " version " << v.version << '\n';
    return 0;
}

std::vector<Sub> releaseCommands(CLI::App* part, PartArgs& args)
{
    auto* commission = part->add_subcommand("commission", "verify the draft on the station's twin (never releases)");
    auto* release = part->add_subcommand("release", "release the verified draft as the next version");
    for (CLI::App* cmd : {commission, release}) {
        addCommon(cmd, args, true);
        addStation(cmd, args);
        cmd->add_option("PART", args.part, "the part")->required();
    }
    commission->add_option("--seats", args.seats, "random seats of the nominal part on the twin")
        ->check(CLI::Range(1, 10000))
        ->capture_default_str();
    commission->add_option("--seed", args.seed, "seed of the seats and the twin's noise")->capture_default_str();
    commission->add_flag("--progress", args.progress, "one JSON line per step on stdout");
    commission
        ->add_option("--defects", args.defectMultiples,
                     "multiples of the tolerance seeded as defects (2, the release multiple, among them)")
        ->delimiter(',')
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    commission->add_option("--seat-shift", args.seatShiftMm, "the nest's play: shift, mm (as hullgauge commission)")
        ->check(CLI::NonNegativeNumber);
    commission
        ->add_option("--seat-rotation", args.seatRotationDeg,
                     "the nest's play: rotation, degrees (as hullgauge commission)")
        ->check(CLI::NonNegativeNumber);
    release->add_option("--plc-program", args.plcProgram, "the PLC's PART_PROGRAM number (given at the first release)")
        ->check(CLI::Range(1, 65535));
    release->add_option("--revision", args.revision, "the draft's revision")->required();
    release
        ->add_option("--taken-programs", args.takenPrograms,
                     "PLC program numbers the daemon's programs: table already uses")
        ->delimiter(',');
    return {{commission, [](const PartArgs& a, const CLI::App&) { return runCommission(a); }}, {release, runRelease}};
}

int runVersions(const PartArgs& a)
{
    workbench::Workspace ws(a.workspace);
    const std::vector<workbench::Version> versions = ws.versions(a.part);
    if (a.json) {
        nlohmann::json list = nlohmann::json::array();
        for (const auto& v : versions) list.push_back(workbench::toJson(v));
        std::cout << nlohmann::json{{"versions", list}}.dump(2) << '\n';
        return 0;
    }
    for (const auto& v : versions)
        std::cout << "v" << v.version << (v.inForce ? " (in force)" : "") << "  " << v.releasedAt << "  "
                  << v.releasedBy
                  << (v.rolledBackFrom ? "  rolled back from v" + std::to_string(*v.rolledBackFrom) : std::string())
                  << "  verification " << v.verificationSha256.substr(0, 12) << '\n';
    if (versions.empty()) std::cout << a.part << " has no released version\n";
    return 0;
}

std::vector<Sub> versionCommands(CLI::App* part, PartArgs& args)
{
    auto* versions = part->add_subcommand("versions", "list the released versions");
    auto* diff = part->add_subcommand("diff", "compare two versions, or a version and the draft");
    auto* rollback = part->add_subcommand("rollback", "make an earlier version the one in force, as a new version");
    addCommon(versions, args, false);
    addCommon(diff, args, false);
    addCommon(rollback, args, true);
    for (CLI::App* cmd : {versions, diff, rollback}) cmd->add_option("PART", args.part, "the part")->required();
    diff->add_option("A", args.from, "a version number, or draft")->required();
    diff->add_option("B", args.to, "a version number, or draft")->required();
    rollback->add_option("VERSION", args.version, "the version to put in force again")->required();
    return {{versions, [](const PartArgs& a, const CLI::App&) { return runVersions(a); }},
            {diff,
             [](const PartArgs& a, const CLI::App&) {
                 const nlohmann::json d = workbench::Workspace(a.workspace).diff(a.part, a.from, a.to);
                 std::cout << (a.json ? d.dump(2) + "\n" : workbench::diffText(d));
                 return 0;
             }},
            {rollback, [](const PartArgs& a, const CLI::App&) {
                 const workbench::Version v = workbench::Workspace(a.workspace).rollback(a.part, a.version, actor(a));
                 if (a.json)
                     std::cout << workbench::toJson(v).dump(2) << '\n';
                 else
                     std::cout << a.part << " version " << v.version << ": version " << a.version
                               << " in force again\n";
                 return 0;
             }}};
}

std::function<int()> factory(CLI::App& app)
{
    auto args = std::make_shared<PartArgs>();
    auto* part = app.add_subcommand("part", "the part workbench: parts, their drafts, landmarks and released versions");
    part->require_subcommand(1);
    std::vector<Sub> subs{addCommand(part, *args)};
    for (auto&& group : {landmarkCommands(part, *args), planCommands(part, *args), releaseCommands(part, *args),
                         versionCommands(part, *args)})
        subs.insert(subs.end(), group.begin(), group.end());
    return [args, subs] {
        for (const Sub& s : subs)
            if (s.app->parsed()) return s.run(*args, *s.app);
        return static_cast<int>(ExitStatus::BadInput);
    };
}

HG_REGISTER_COMMAND("part", factory);

} // namespace
} // namespace hg::cli
