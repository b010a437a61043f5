// hullgauge commission --cad M --station S --out DIR (--tolerance T | --program P.yaml) [--fix] ...
// From a CAD model to a released part program the station has proven on its
// own digital twin (docs/commissioning.md): landmarks suggested (or the
// engineer's), the program checked and planned, then verified on the twin —
// the nominal part at N random seats within the nest's play, seeded defects
// at every landmark — and released with a version only when it passes. A
// program that fails names each landmark's failing test and its fix; --fix
// makes the fixes that can be made here (a second view, a finer octree depth,
// dropping the landmark) and verifies again. With --no-release the
// verification is written and nothing released (what `hullgauge part
// commission` does on the workbench's draft, docs/workbench.md); the release
// itself is the workbench library's (workbench/commissioning.h), shared with
// `hullgauge part release`.
//
// Exit status: 0 released (with --no-release: it would be), 1 verified but
// not released (the report says why), 2 bad input or no plan, 3 a fault (a
// file that cannot be written).
#include "command.h"
#include "hullgauge/commission/screen.h" // verificationProblem
#include "hullgauge/commission/seat_views.h"
#include "hullgauge/commission/verification.h"
#include "hullgauge/common/clock.h"
#include "hullgauge/common/durable_file.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"
#include "hullgauge/plan/landmark_suggest.h"
#include "hullgauge/plan/plan_report.h"
#include "hullgauge/plan/program_plan.h"
#include "hullgauge/workbench/commissioning.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <set>

namespace hg::cli {
namespace {

namespace fs = std::filesystem;

struct CommissionArgs {
    std::string cad;
    std::string solid;
    std::string station;
    std::string program;
    std::string out;
    std::string part;
    std::string releasedBy;
    std::size_t count = 8;
    double toleranceMm = 0.0;
    int depth = 0; ///< 0: the finest the station resolves (plan::finestResolvedDepth)
    int adjacencyDepth = 4;
    std::size_t seats = 20;
    std::vector<double> defectMultiples{1.0, 2.0, 3.0};
    std::uint64_t seed = 1;
    double seatShiftMm = -1.0;
    double seatRotationDeg = -1.0;
    bool fix = false;
    int rounds = 4;
    bool noRelease = false;
};

void say(const std::string& line)
{
    std::cerr << "hullgauge commission: " << line << '\n';
}

using workbench::PhaseClock;

std::string whoAmI(const CommissionArgs& args)
{
    return args.releasedBy.empty() ? workbench::currentUser() : args.releasedBy;
}

/// The part's name: --part, else the CAD file's stem.
std::string partName(const CommissionArgs& args)
{
    return args.part.empty() ? fs::path(args.cad).stem().string() : args.part;
}

/// The alignment settings of a suggested program: the defaults, the limits
/// beyond the nest's play given by the margin the seat's measurement needs
/// (plan::kPlayOfLimits, docs/commissioning.md).
model::AlignmentSettings suggestedAlignment(const CommissionArgs& args)
{
    model::AlignmentSettings alignment;
    if (args.seatShiftMm > 0.0) alignment.maxShiftMm = args.seatShiftMm / plan::kPlayOfLimits;
    if (args.seatRotationDeg > 0.0) alignment.maxRotationDeg = args.seatRotationDeg / plan::kPlayOfLimits;
    return alignment;
}

/// The suggestion (capable over the nest's play), and the candidates it
/// refused in suggestion.md. Its landmarks are not screened on the twin here
/// (as `landmarks suggest` screens them): the verification that follows is
/// the twin's judgement, and --fix acts on it.
plan::Suggestion suggest(const CommissionArgs& args, const geometry::Station& station, const model::CadModel& cad,
                         const fs::path& out)
{
    plan::SuggestOptions options;
    options.count = args.count;
    options.toleranceMm = args.toleranceMm;
    options.alignment = suggestedAlignment(args);
    options.plan.pareLayers = cad.octree.adjacencyDepth; // as the draft is planned (planOptions)
    const plan::Suggestion s = plan::suggestLandmarks(plan::suggestProblem(cad, station), options);
    replaceFileDurably(out / "suggestion.md", "# Candidates refused for " + partName(args) + "\n\n" +
                                                  plan::refusedSummary(s) + ".\n\n" + plan::refusedMarkdown(s));
    return s;
}

/// The draft from suggested landmarks (docs/part-program.md, "Suggesting landmarks").
YAML::Node suggestDraft(const CommissionArgs& args, const geometry::Station& station, const std::string& meshName,
                        const fs::path& out, PhaseClock& clock)
{
    clock.start("suggest");
    model::CadModel cad = model::loadCadModel(args.cad, std::max(args.depth, 8), args.adjacencyDepth, args.solid);
    if (args.depth == 0) {
        const int depth = plan::finestResolvedDepth(cad.solid->mesh(), station, args.adjacencyDepth);
        say("octree depth " + std::to_string(depth) + ": the finest whose voxels the views resolve at the part");
        cad = model::loadCadModel(args.cad, depth, args.adjacencyDepth, args.solid);
    }
    const plan::Suggestion s = suggest(args, station, cad, out);
    clock.stop("suggest");
    for (const std::string& note : s.notes) say("note: " + note);
    if (s.landmarks.empty())
        throw InputError(args.cad, "landmarks",
                         "no point of the part is inspectable at the station " + args.station + " with tolerance_mm " +
                             formatNumber(args.toleranceMm) + (s.notes.empty() ? "" : ": " + s.notes.front()));
    say(std::to_string(s.landmarks.size()) + " landmarks suggested; candidates refused: " + plan::refusedSummary(s) +
        " (" + (out / "suggestion.md").string() + ")");
    YAML::Node draft = YAML::Load(plan::landmarksYaml(s, args.toleranceMm, {}));
    YAML::Node program;
    program["part"] = partName(args);
    program["mesh"] = meshName;
    if (!args.solid.empty()) program["mesh_solid"] = args.solid;
    program["octree"]["depth"] = cad.octree.depth;
    program["octree"]["adjacency_depth"] = args.adjacencyDepth;
    const model::AlignmentSettings alignment = suggestedAlignment(args);
    if (args.seatShiftMm > 0.0) program["alignment"]["max_shift_mm"] = alignment.maxShiftMm;
    if (args.seatRotationDeg > 0.0) program["alignment"]["max_rotation_deg"] = alignment.maxRotationDeg;
    program["landmarks"] = draft["landmarks"];
    return program;
}

/// The engineer's program as the draft, its mesh named as copied into the output folder.
YAML::Node engineerDraft(const CommissionArgs& args, const std::string& meshName)
{
    YAML::Node program = YAML::LoadFile(args.program);
    program["mesh"] = meshName;
    program.remove("release");
    if (!args.part.empty()) program["part"] = args.part;
    return program;
}

std::string emit(const YAML::Node& node, const std::string& header)
{
    YAML::Emitter out;
    out << node;
    return header + out.c_str() + "\n";
}

/// Drops the landmarks in `ids` from the draft, and the parameters built on them.
void dropLandmarks(YAML::Node& draft, const std::set<std::string>& ids)
{
    YAML::Node kept(YAML::NodeType::Sequence);
    for (const auto& lm : draft["landmarks"])
        if (!ids.count(lm["id"].as<std::string>())) kept.push_back(lm);
    draft["landmarks"] = kept;
    if (!draft["parameters"]) return;
    YAML::Node params(YAML::NodeType::Sequence);
    for (const auto& p : draft["parameters"]) {
        bool uses = false;
        for (const auto& id : p["landmarks"]) uses = uses || ids.count(id.as<std::string>()) > 0;
        if (!uses) params.push_back(p);
    }
    if (params.size() == 0)
        draft.remove("parameters");
    else
        draft["parameters"] = params;
}

using Round = workbench::CommissionRound;

/// One round: the draft loaded as the daemon loads it, planned, verified.
Round verifyDraft(const CommissionArgs& args, const geometry::Station& station, const fs::path& draftFile,
                  PhaseClock& clock)
{
    commission::VerificationOptions options;
    options.seats = args.seats;
    options.defectMultiples = args.defectMultiples;
    options.seed = args.seed;
    options.seatShiftMm = args.seatShiftMm;
    options.seatRotationDeg = args.seatRotationDeg;
    const auto progress = [&](const std::string& phase, std::size_t done, std::size_t total) {
        if (done == total) say(phase + ": " + std::to_string(total) + " cycles on the twin");
        return true;
    };
    return workbench::commissionRound(draftFile, station, options, progress, clock);
}

/// The fixes --fix applies, in the order a finding names them; the others
/// (a lens, a tolerance, a landmark moved) are the engineer's to make.
bool automatic(commission::Fix fix)
{
    return fix == commission::Fix::AddView || fix == commission::Fix::ChangeDepth ||
           fix == commission::Fix::DropLandmark;
}

/// A pose as a part program's best view writes it (docs/part-program.md).
YAML::Node poseNode(const geometry::FixturePose& pose, geometry::FixtureType type)
{
    YAML::Node n(YAML::NodeType::Map);
    n.SetStyle(YAML::EmitterStyle::Flow);
    if (type == geometry::FixtureType::Rail) {
        n["rail_mm"] = pose.railMm;
    } else {
        n["rotation_deg"] = pose.rotationDeg;
        n["declination_deg"] = pose.declinationDeg;
    }
    return n;
}

/// The poses of the planned views that observe a landmark.
YAML::Node observingPoses(const Round& r, std::size_t landmark, geometry::FixtureType type)
{
    YAML::Node poses(YAML::NodeType::Sequence);
    for (const plan::PlannedView& v : r.planned.plan.views)
        if (std::find(v.landmarks.begin(), v.landmarks.end(), landmark) != v.landmarks.end())
            poses.push_back(poseNode(v.pose, type));
    return poses;
}

/// A second view for a landmark: one of its witness poses that no planned
/// view observing it has (as a best views entry, 5.3.1); empty when there is none.
YAML::Node otherWitnesses(const Round& r, std::size_t landmark, geometry::FixtureType type)
{
    std::vector<geometry::FixturePose> seen;
    for (const plan::PlannedView& v : r.planned.plan.views)
        if (std::find(v.landmarks.begin(), v.landmarks.end(), landmark) != v.landmarks.end()) seen.push_back(v.pose);
    YAML::Node others(YAML::NodeType::Sequence);
    for (const geometry::FixturePose& p : r.planned.plan.landmarks[landmark].witnessPoses)
        if (std::find(seen.begin(), seen.end(), p) == seen.end()) others.push_back(poseNode(p, type));
    return others;
}

/// What --fix does to the draft after a round that was not released: per
/// failing landmark the first fix its findings name that can be made and was
/// not made to it before (docs/commissioning.md, "--fix").
struct FixRound {
    std::map<std::string, YAML::Node> addViews; ///< landmark → the poses its second view is one of
    std::set<std::string> drop;
    bool finerDepth = false;
    /// Views for the seat chosen on the twin (alignment.seat_views); none when not.
    std::vector<geometry::FixturePose> seatViews;
    std::vector<std::string> said;
};

/// What --fix has done so far: per landmark the fixes made, and the
/// landmarks whose best views are the engineer's (never replaced).
struct FixHistory {
    std::map<std::string, std::set<commission::Fix>> made;
    std::optional<std::set<std::string>> engineerViews;
    bool seatViewsChosen = false; ///< once only: a second choice would try the same candidates
};

/// Nominal seats each candidate view for the seat is tried at.
constexpr std::size_t kSeatViewSeats = 8;

std::string poseWords(const geometry::FixturePose& p, geometry::FixtureType type)
{
    if (type == geometry::FixtureType::Rail) return "rail " + formatNumber(p.railMm) + " mm";
    return "rotation " + formatNumber(p.rotationDeg) + "°, declination " + formatNumber(p.declinationDeg) + "°";
}

/// The seat test failed: views for the seat chosen on the twin (docs/commissioning.md,
/// "--fix"), unless the program names its own — the engineer's stay.
void seatFix(const CommissionArgs& args, const Round& r, const geometry::Station& station, FixHistory& history,
             FixRound& out)
{
    const bool seat = std::any_of(r.report->findings.begin(), r.report->findings.end(),
                                  [&](const auto& f) { return f.subject == r.program.part && f.test == "seat"; });
    if (!seat || history.seatViewsChosen || !r.program.alignment.seatViews.empty() || !r.planned.capability) return;
    history.seatViewsChosen = true;
    commission::VerificationOptions options;
    options.seed = args.seed;
    options.seatShiftMm = args.seatShiftMm;
    options.seatRotationDeg = args.seatRotationDeg;
    const commission::SeatViewChoice choice = commission::chooseSeatViews(
        commission::verificationProblem(r.program, station, r.planned.plan, *r.planned.capability), options,
        commission::twinFrames(station, args.seed), kSeatViewSeats);
    if (choice.seatViews.empty()) return;
    out.seatViews = choice.seatViews;
    const auto chosen = std::find_if(choice.trials.begin(), choice.trials.end(),
                                     [&](const auto& t) { return t.pose == choice.seatViews.front(); });
    const geometry::FixtureType type = station.fixture.type;
    out.said.push_back("views for the seat: " + poseWords(choice.seatViews[0], type) + ", then " +
                       poseWords(choice.seatViews[1], type) + " (the best of " + std::to_string(choice.trials.size()) +
                       " tried on the twin at " + std::to_string(kSeatViewSeats) + " seats: the seat within " +
                       formatNumber(1000.0 * chosen->shiftMm, 3) + " µm and " + formatNumber(chosen->rotationDeg, 3) +
                       "°, a landmark beyond its U " + std::to_string(chosen->beyondU) + " times)");
}

FixRound chooseFixes(const CommissionArgs& args, const Round& r, const geometry::Station& station, FixHistory& history)
{
    if (!history.engineerViews) {
        history.engineerViews.emplace();
        for (const model::Landmark& l : r.program.landmarks)
            if (!l.bestViews.empty()) history.engineerViews->insert(l.id);
    }
    auto& made = history.made;
    FixRound out;
    seatFix(args, r, station, history, out);
    const int finest = plan::finestResolvedDepth(r.program.solid->mesh(), station, r.program.octree.adjacencyDepth);
    std::set<std::string> handled;
    for (const commission::Finding& f : r.report->findings) {
        const auto at = std::find_if(r.program.landmarks.begin(), r.program.landmarks.end(),
                                     [&](const model::Landmark& l) { return l.id == f.subject; });
        if (at == r.program.landmarks.end() || handled.count(f.subject)) continue;
        const auto index = static_cast<std::size_t>(at - r.program.landmarks.begin());
        for (commission::Fix fix : f.fixes) {
            if (!automatic(fix) || made[f.subject].count(fix)) continue;
            if (fix == commission::Fix::AddView) {
                // A second view brings back a landmark lost at some seats; the
                // view square on that a prediction asks for is the engineer's to choose.
                if (f.test != "observable") continue;
                if (history.engineerViews->count(f.subject)) continue; // the engineer's best views stay
                YAML::Node others = otherWitnesses(r, index, station.fixture.type);
                if (others.size() == 0) continue;
                out.addViews[f.subject] = others;
                out.said.push_back(f.subject + ": a second view (one of the " + std::to_string(others.size()) +
                                   " other poses that see it)");
            } else if (fix == commission::Fix::ChangeDepth) {
                if (r.program.octree.depth >= finest || args.depth > 0) continue; // the engineer's --depth stays
                out.finerDepth = true;
                out.said.push_back(f.subject + ": octree depth " + std::to_string(r.program.octree.depth + 1));
            } else {
                out.drop.insert(f.subject);
                out.said.push_back(f.subject + ": dropped");
            }
            made[f.subject].insert(fix);
            handled.insert(f.subject);
            break;
        }
    }
    return out;
}

/// Applies the round's fixes to the draft; false when there is none to make
/// or they would leave no landmark. A view is added without moving the
/// others: every landmark without the engineer's best views is given each
/// view that observes it now as a best view (5.3.1, eq. 5.3.2-1: AND over
/// them), and a landmark given a second view also one of its other witnesses.
bool applyFixes(YAML::Node& draft, const FixRound& fixes, const Round& r, const FixHistory& history,
                geometry::FixtureType type)
{
    if (fixes.said.empty() || fixes.drop.size() >= r.program.landmarks.size()) return false;
    for (std::size_t i = 0; i < r.program.landmarks.size() && !fixes.addViews.empty(); ++i) {
        const model::Landmark& l = r.program.landmarks[i];
        if (history.engineerViews->count(l.id)) continue;
        YAML::Node views = observingPoses(r, i, type);
        if (views.size() == 0) continue;
        if (const auto it = fixes.addViews.find(l.id); it != fixes.addViews.end()) {
            YAML::Node other(YAML::NodeType::Map);
            other["any_of"] = it->second;
            views.push_back(other);
        }
        for (auto lm : draft["landmarks"])
            if (lm["id"].as<std::string>() == l.id) lm["best_views"] = views;
    }
    if (!fixes.seatViews.empty()) {
        YAML::Node seatViews(YAML::NodeType::Sequence);
        for (const geometry::FixturePose& p : fixes.seatViews) seatViews.push_back(poseNode(p, type));
        draft["alignment"]["seat_views"] = seatViews;
    }
    if (fixes.finerDepth) draft["octree"]["depth"] = draft["octree"]["depth"].as<int>() + 1;
    if (!fixes.drop.empty()) dropLandmarks(draft, fixes.drop);
    return true;
}

/// The release (docs/commissioning.md, "Release"): the program with its
/// record and its views; every version kept under releases/.
int release(const CommissionArgs& args, const fs::path& out, const YAML::Node& draft, const Round& r,
            const geometry::Station& station, const std::string& reportJson)
{
    const std::string part = r.program.part;
    const std::string views = part + "-views.yaml";
    workbench::ReleaseInput input;
    input.folder = out;
    input.part = part;
    input.program = draft;
    input.meshFile = r.program.meshFile;
    input.viewsYaml = plan::posesYaml(r.planned.plan, station.fixture.type);
    input.verificationJson = reportJson;
    input.evidenceFolder = out;
    input.releasedBy = whoAmI(args);
    input.header = "# Part program released by hullgauge commission (docs/commissioning.md).\n"
                   "# Its views: " +
                   views + "; its verification: verification.json.\n";
    const workbench::Released released = workbench::releaseVersion(input);
    say("released " + part + " version " + std::to_string(released.version) + ": " + released.programFile.string() +
        " (views " + released.viewsFile.string() + ")");
    return 0;
}

int run(const CommissionArgs& args)
{
    const geometry::Station station = geometry::loadStation(args.station);
    const fs::path out = args.out;
    fs::create_directories(out);
    const std::string meshName = fs::path(args.cad).filename().string();
    if (fs::absolute(args.cad) != fs::absolute(out / meshName))
        fs::copy_file(args.cad, out / meshName, fs::copy_options::overwrite_existing);
    PhaseClock clock;
    YAML::Node draft =
        args.program.empty() ? suggestDraft(args, station, meshName, out, clock) : engineerDraft(args, meshName);
    const fs::path draftFile = out / (partName(args) + ".draft.yaml");
    FixHistory history;
    for (int round = 1;; ++round) {
        replaceFileDurably(draftFile, emit(draft, "# Draft part program of hullgauge commission (round " +
                                                      std::to_string(round) + ").\n"));
        Round r = verifyDraft(args, station, draftFile, clock);
        workbench::writePlanFiles(out, r.planned);
        if (!r.report) {
            say("no plan for " + r.program.part + ":");
            for (const std::string& p : r.planned.plan.problems) std::cerr << "  " << p << '\n';
            return static_cast<int>(ExitStatus::BadInput);
        }
        r.report->phaseMs = clock.ms();
        const std::string reportJson = workbench::writeVerificationFiles(out, *r.report);
        if (r.report->released && args.noRelease) {
            say(r.program.part +
                " is verified and may be released; not released (--no-release): " + (out / "verification.md").string());
            return 0;
        }
        if (r.report->released) return release(args, out, draft, r, station, reportJson);
        say(r.program.part + " is not released (" + (out / "verification.md").string() + "):");
        for (const commission::Finding& f : r.report->findings)
            std::cerr << "  " << f.subject << " (" << f.test << "): " << f.what << "; fix: " << f.fixText << '\n';
        if (!args.fix || round >= args.rounds) return static_cast<int>(ExitStatus::PartFails);
        const FixRound fixes = chooseFixes(args, r, station, history);
        if (!applyFixes(draft, fixes, r, history, station.fixture.type)) {
            say("--fix: nothing left that it can fix (a lens, a tolerance or a landmark's place is the engineer's)");
            return static_cast<int>(ExitStatus::PartFails);
        }
        for (const std::string& line : fixes.said) say("--fix: " + line);
        say("--fix: verifying again");
    }
}

std::function<int()> factory(CLI::App& app)
{
    auto args = std::make_shared<CommissionArgs>();
    auto* cmd = app.add_subcommand("commission", "from a CAD model to a part program released after the station "
                                                 "proved it on its digital twin");
    cmd->add_option("--cad", args->cad, "CAD model: STL, OBJ, PLY, OFF or STEP")->required()->check(CLI::ExistingFile);
    cmd->add_option("--solid", args->solid, "the STEP file's solid that is the part (as mesh_solid)");
    cmd->add_option("--station", args->station, "station description (YAML)")->required()->check(CLI::ExistingFile);
    cmd->add_option("--out", args->out, "folder for the program, its views, plan and verification report")->required();
    auto* program = cmd->add_option("--program", args->program,
                                    "the engineer's part program (its landmarks) "
                                    "instead of suggested ones")
                        ->check(CLI::ExistingFile);
    auto* tolerance = cmd->add_option("--tolerance", args->toleranceMm,
                                      "the drawing's tolerance for the suggested "
                                      "landmarks, mm")
                          ->check(CLI::PositiveNumber);
    program->excludes(tolerance);
    tolerance->excludes(program);
    cmd->add_option("--part", args->part, "the part's name (default: the CAD file's name)");
    cmd->add_option("--count", args->count, "landmarks to suggest")->check(CLI::Range(1, 1000))->capture_default_str();
    cmd->add_option("--depth", args->depth,
                    "octree depth of a suggested program (default: the finest whose voxels the station resolves)")
        ->check(CLI::Range(1, model::kMaxOctreeDepth));
    cmd->add_option("--adjacency-depth", args->adjacencyDepth, "octree adjacency_depth of a suggested program")
        ->check(CLI::Range(1, 64))
        ->capture_default_str();
    cmd->add_option("--seats", args->seats, "random seats of the nominal part on the twin")
        ->check(CLI::Range(1, 10000))
        ->capture_default_str();
    cmd->add_option("--defects", args->defectMultiples,
                    "multiples of the tolerance at which defects are seeded (added and removed) at every landmark; "
                    "2 must be among them for a release")
        ->delimiter(',')
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    cmd->add_option("--seed", args->seed, "seed of the seats and the twin's noise")->capture_default_str();
    cmd->add_option("--seat-shift", args->seatShiftMm,
                    "the nest's play: shift, mm (default: 80 % of alignment.max_shift_mm; a suggested program's "
                    "limit is set to play / 0.8)")
        ->check(CLI::NonNegativeNumber);
    cmd->add_option("--seat-rotation", args->seatRotationDeg,
                    "the nest's play: rotation, degrees (default: 80 % of alignment.max_rotation_deg; a suggested "
                    "program's limit is set to play / 0.8)")
        ->check(CLI::NonNegativeNumber);
    cmd->add_flag("--fix", args->fix,
                  "apply the fix each failure names where it can be made here (a second view, a finer octree "
                  "depth, dropping the landmark) and verify again");
    cmd->add_option("--rounds", args->rounds, "verification rounds with --fix")
        ->check(CLI::Range(1, 20))
        ->capture_default_str();
    cmd->add_option("--released-by", args->releasedBy, "who releases the program (default: the user)");
    cmd->add_flag("--no-release", args->noRelease,
                  "verify only: write the plan and the verification, never release (exit 0 when it would be "
                  "released)");
    return [args] {
        if (args->program.empty() && args->toleranceMm <= 0.0)
            throw InputError("", "--tolerance", "give the drawing's tolerance (--tolerance) or a --program");
        if (std::find(args->defectMultiples.begin(), args->defectMultiples.end(), 2.0) == args->defectMultiples.end())
            throw InputError("", "--defects",
                             "the release multiple 2 must be among the defect multiples: a program is released only "
                             "when a defect of 2 × tolerance is caught at every landmark");
        return run(*args);
    };
}

HG_REGISTER_COMMAND("commission", factory);

} // namespace
} // namespace hg::cli
