// The work done at the station on a part's draft (docs/workbench.md):
// suggesting landmarks, planning the views, showing them as the camera sees
// them, and proving the draft on the station's digital twin. Each reads the
// part under its lock, works without it (seconds, the engineer may go on
// editing), and writes its results under it.
#include "hullgauge/commission/screen.h"
#include "hullgauge/common/digest.h"
#include "hullgauge/common/durable_file.h"
#include "hullgauge/geometry/json.h"
#include "hullgauge/inspect/capability.h"
#include "hullgauge/model/part_program.h"
#include "hullgauge/plan/landmark_suggest.h"
#include "hullgauge/workbench/commissioning.h"
#include "hullgauge/workbench/display.h"
#include "hullgauge/workbench/workspace.h"

#include "draft.h"
#include "part_files.h"

#include <opencv2/imgcodecs.hpp>

#include <unistd.h>

#include <algorithm>

namespace hg::workbench {
namespace {

/// The record and the draft as one change left them.
struct Snapshot {
    PartRecord record;
    std::string draftText;
    YAML::Node draft;
};

Snapshot snapshot(const fs::path& folder)
{
    files::PartLock lock(folder, false);
    Snapshot s;
    s.record = files::readRecord(folder);
    const fs::path draftPath = files::draftFile(folder, s.record.part);
    s.draftText = files::readText(draftPath);
    s.draft = files::loadDraftNode(draftPath);
    return s;
}

void requireLandmarks(const Snapshot& s, const std::string& toDo)
{
    if (files::landmarksOf(s.draft).size() == 0)
        throw InputError(s.record.part + ".draft.yaml", "landmarks",
                         "the draft of " + s.record.part +
                             " has no landmark yet: place one (landmark add, suggest) "
                             "before " +
                             toDo);
}

nlohmann::json candidateJson(const plan::LandmarkCandidate& c)
{
    return {{"kind", enumName(c.kind)},
            {"name", c.feature},
            {"position", geometry::toJson(c.position)},
            {"normal", geometry::toJson(c.normal)}};
}

nlohmann::json suggestionsJson(const PartRecord& record, const model::CadModel& cad, const plan::Suggestion& s,
                               const SuggestSettings& settings)
{
    nlohmann::json candidates = nlohmann::json::array();
    for (const plan::SuggestedLandmark& l : s.landmarks) {
        nlohmann::json j = candidateJson(plan::asWritten(l.candidate));
        j["id"] = l.id;
        j["comment"] = l.reason;
        j["refused"] = nullptr;
        candidates.push_back(j);
    }
    for (const plan::RefusedCandidate& r : s.refused) {
        nlohmann::json j = candidateJson(r.candidate);
        j["id"] = nullptr;
        j["comment"] = r.why;
        j["refused"] = r.rule;
        candidates.push_back(j);
    }
    return {{"part", record.part},
            {"count", settings.count},
            {"twin_seats", settings.twinSeats},
            {"tolerance_mm", record.toleranceMm},
            {"octree", {{"depth", cad.octree.depth}, {"adjacency_depth", cad.octree.adjacencyDepth}}},
            {"refused_by_rule", plan::refusedSummary(s)},
            {"notes", s.notes},
            {"candidates", candidates}};
}

geometry::FixturePose poseOf(const nlohmann::json& j)
{
    geometry::FixturePose pose;
    pose.rotationDeg = j.value("rotation_deg", 0.0);
    pose.declinationDeg = j.value("declination_deg", 0.0);
    pose.railMm = j.value("rail_mm", 0.0);
    return pose;
}

/// plan.json's views; InputError when the part has no plan.
nlohmann::json plannedViews(const fs::path& folder, const std::string& part)
{
    const fs::path file = folder / files::kPlanJson;
    if (!files::exists(file))
        throw InputError("", "views", "part " + part + " has no plan yet: plan its draft (hullgauge part plan)");
    const nlohmann::json plan = nlohmann::json::parse(files::readText(file), nullptr, false);
    if (!plan.is_object() || !plan.contains("views") || !plan["views"].is_array())
        throw InputError(file.string(), "views", "not a plan (no views)");
    return plan["views"];
}

Eigen::Vector3d centreOf(const PartState& state)
{
    return 0.5 * (state.boundsMin + state.boundsMax);
}

/// The loader's refusal of the staged copy, naming the draft.
[[noreturn]] void refuseAsDraft(const InputError& e, const fs::path& staged, const std::string& draftName)
{
    if (e.file() != staged.string()) throw;
    throw InputError(draftName, e.field(), e.problem(), e.line());
}

/// A copy of the draft beside it (its mesh is named relative to the folder),
/// removed when the object dies: what is verified is exactly these bytes.
class StagedDraft {
  public:
    StagedDraft(const fs::path& folder, const std::string& text)
        : path_(folder / (".verify-" + std::to_string(::getpid()) + ".draft.yaml"))
    {
        writeFileDurably(path_, text);
    }
    ~StagedDraft()
    {
        std::error_code ec;
        fs::remove(path_, ec);
    }
    StagedDraft(const StagedDraft&) = delete;
    StagedDraft& operator=(const StagedDraft&) = delete;
    const fs::path& path() const { return path_; }

  private:
    fs::path path_;
};

commission::VerificationOptions verificationOptions(const CommissionSettings& settings)
{
    commission::VerificationOptions o;
    o.seats = settings.seats;
    o.defectMultiples = settings.defectMultiples;
    o.seed = settings.seed;
    o.seatShiftMm = settings.seatShiftMm;
    o.seatRotationDeg = settings.seatRotationDeg;
    return o;
}

} // namespace

nlohmann::json Workspace::suggest(std::string_view part, const fs::path& stationFile, const SuggestSettings& settings)
{
    const fs::path folder = partFolder(part);
    const Snapshot s = snapshot(folder);
    const model::CadModel cad = files::loadDraftCad(folder, s.record, s.draft);
    const geometry::Station station = geometry::loadStation(stationFile);
    plan::SuggestOptions options;
    options.count = settings.count;
    options.toleranceMm = s.record.toleranceMm;
    options.plan.pareLayers = cad.octree.adjacencyDepth; // as the draft is planned
    if (settings.twinSeats > 0) {
        commission::ScreenOptions screen;
        screen.seats = settings.twinSeats;
        screen.toleranceMm = s.record.toleranceMm;
        options.screen =
            commission::twinScreen(commission::draftProgram(cad, s.record.part, options.alignment), station, screen);
    }
    const plan::Suggestion suggestion = plan::suggestLandmarks(plan::suggestProblem(cad, station), options);
    const nlohmann::json out = suggestionsJson(s.record, cad, suggestion, settings);
    files::PartLock lock(folder, true);
    replaceFileDurably(folder / files::kSuggestions, out.dump(2) + "\n");
    return out;
}

PlanOutcome Workspace::plan(std::string_view part, const fs::path& stationFile)
{
    const fs::path folder = partFolder(part);
    const Snapshot s = snapshot(folder);
    requireLandmarks(s, "planning");
    const StagedDraft staged(folder, s.draftText);
    model::PartProgram program;
    try {
        program = model::loadPartProgram(staged.path());
    } catch (const InputError& e) {
        refuseAsDraft(e, staged.path(), s.record.part + ".draft.yaml");
    }
    const geometry::Station station = geometry::loadStation(stationFile);
    if (program.bestViewFixture && *program.bestViewFixture != station.fixture.type)
        throw InputError(s.record.part + ".draft.yaml", "landmarks[].best_views",
                         "best views are written for a different fixture type than the station's");
    const plan::ProgramPlan planned = plan::planProgram(program, station, commissioningPlanOptions(program));
    {
        files::PartLock lock(folder, true);
        writePlanFiles(folder, planned);
    }
    PlanOutcome out;
    out.feasible = planned.plan.feasible;
    out.problems = planned.plan.problems;
    out.views = planned.plan.views.size();
    if (planned.capability)
        for (const inspect::LandmarkCapability& c : *planned.capability)
            if (!c.capable) out.problems.push_back(inspect::describe(c));
    return out;
}

nlohmann::json Workspace::views(std::string_view part, const fs::path& stationFile) const
{
    const PartState state = read(part);
    const nlohmann::json planned = plannedViews(partFolder(part), state.record.part);
    const geometry::Station station = geometry::loadStation(stationFile);
    nlohmann::json views = nlohmann::json::array();
    for (std::size_t i = 0; i < planned.size(); ++i) {
        const nlohmann::json& v = planned[i];
        const geometry::CameraModel camera = station.cameraAt(poseOf(v.at("pose")));
        views.push_back({{"index", i + 1},
                         {"id", v.value("id", std::string())},
                         {"pose", v.at("pose")},
                         {"landmarks", v.value("landmarks", nlohmann::json::array())},
                         {"camera", cameraJson(camera, centreOf(state))}});
    }
    return {{"views", views}};
}

std::string Workspace::viewImage(std::string_view part, const fs::path& stationFile, int view) const
{
    const fs::path folder = partFolder(part);
    const PartState state = read(part);
    const nlohmann::json planned = plannedViews(folder, state.record.part);
    if (view < 1 || static_cast<std::size_t>(view) > planned.size())
        throw InputError("", "view",
                         "view " + std::to_string(view) + " of " + state.record.part + ": the plan has " +
                             std::to_string(planned.size()) + " views (1.." + std::to_string(planned.size()) + ")");
    const nlohmann::json& v = planned[static_cast<std::size_t>(view - 1)];
    const geometry::Station station = geometry::loadStation(stationFile);
    const Snapshot s = snapshot(folder);
    const model::CadModel cad = files::loadDraftCad(folder, s.record, s.draft);
    std::vector<ViewLandmark> landmarks;
    for (const auto& id : v.value("landmarks", nlohmann::json::array()))
        for (const DraftLandmark& l : state.draft.landmarks)
            if (id.is_string() && l.id == id.get<std::string>()) landmarks.push_back({l.id, l.position, l.normal});
    const cv::Mat image =
        annotatedView(cad.solid->mesh(), station, station.cameraAt(poseOf(v.at("pose"))), landmarks, 1);
    std::vector<unsigned char> png;
    if (!cv::imencode(".png", image, png)) throw FaultError("view " + std::to_string(view) + ": cannot encode a PNG");
    return std::string(png.begin(), png.end());
}

CommissionOutcome Workspace::commission(std::string_view part, const fs::path& stationFile,
                                        const CommissionSettings& settings, const Actor& by)
{
    (void)by; // the verification records the draft, the station and the report; the release who released it
    const fs::path folder = partFolder(part);
    const Snapshot s = snapshot(folder);
    requireLandmarks(s, "commissioning");
    const commission::VerificationOptions options = verificationOptions(settings);
    if (std::find(options.defectMultiples.begin(), options.defectMultiples.end(), options.releaseMultiple) ==
        options.defectMultiples.end())
        throw InputError("", "defects",
                         "the release multiple 2 must be among the defect multiples: a draft may be released only "
                         "when a defect of 2 × tolerance is caught at every landmark");
    const std::string stationSha = sha256OfFile(stationFile);
    const geometry::Station station = geometry::loadStation(stationFile);
    const StagedDraft staged(folder, s.draftText);
    if (settings.progress && !settings.progress("plan", 0, 1)) throw commission::Cancelled();
    // The plan is done when the verification's first step comes.
    bool planned = false;
    const commission::Progress progress = [&](const std::string& phase, std::size_t done, std::size_t total) {
        if (!settings.progress) return true;
        if (!planned && !settings.progress("plan", 1, 1)) return false;
        planned = true;
        return settings.progress(phase, done, total);
    };
    PhaseClock clock;
    CommissionRound r;
    try {
        r = commissionRound(staged.path(), station, options, progress, clock);
    } catch (const InputError& e) {
        refuseAsDraft(e, staged.path(), s.record.part + ".draft.yaml");
    }
    CommissionOutcome out;
    files::PartLock lock(folder, true);
    writePlanFiles(folder, r.planned);
    if (!r.report) {
        out.status = static_cast<int>(ExitStatus::BadInput);
        out.problems = r.planned.plan.problems;
        return out;
    }
    r.report->phaseMs = clock.ms();
    const std::string json = writeVerificationFiles(folder, *r.report);
    Verified v{s.record.revision, sha256Hex(s.draftText), stationSha, sha256Hex(json), r.report->released};
    PartRecord record = files::readRecord(folder);
    record.verified = v;
    files::writeRecord(folder, record);
    out.verified = v;
    out.status = static_cast<int>(r.report->released ? ExitStatus::Ok : ExitStatus::PartFails);
    for (const commission::Finding& f : r.report->findings)
        out.problems.push_back(f.subject + " (" + f.test + "): " + f.what + "; fix: " + f.fixText);
    return out;
}

} // namespace hg::workbench
