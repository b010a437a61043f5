// The workspace and what reading a part shows (docs/workbench.md, "The
// workspace"). Adding parts: add.cpp; landmarks: landmarks.cpp; the work at
// the station (suggest, plan, views, commission): station_work.cpp; versions:
// versions.cpp.
#include "hullgauge/workbench/workspace.h"

#include "hullgauge/common/config_node.h"
#include "hullgauge/common/digest.h"
#include "hullgauge/common/log.h"
#include "hullgauge/geometry/json.h"
#include "hullgauge/model/part_program.h"

#include "draft.h"
#include "part_files.h"

#include <algorithm>

namespace hg::workbench {

bool validPartName(std::string_view name)
{
    if (name.empty() || name.size() > 64) return false;
    const auto alnum = [](char c) {
        return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9');
    };
    if (!alnum(name.front())) return false;
    return std::all_of(name.begin(), name.end(), [&](char c) { return alnum(c) || c == '.' || c == '_' || c == '-'; });
}

Workspace::Workspace(fs::path folder) : folder_(std::move(folder))
{
}

fs::path Workspace::partFolder(std::string_view part) const
{
    if (!validPartName(part))
        throw PartNotFound("", "part",
                           "'" + std::string(part) +
                               "' is no part name (1–64 letters, digits, '.', '_' or '-', starting with a letter or "
                               "digit)");
    const fs::path folder = folder_ / std::string(part);
    if (!files::exists(folder / files::kRecord))
        throw PartNotFound("", "part", "no part '" + std::string(part) + "' in the workspace " + folder_.string());
    return folder;
}

std::vector<PartState> Workspace::list() const
{
    std::vector<std::string> names;
    std::error_code ec;
    for (auto it = fs::directory_iterator(folder_, ec); !ec && it != fs::directory_iterator(); it.increment(ec)) {
        const std::string name = it->path().filename().string();
        if (validPartName(name) && files::exists(it->path() / files::kRecord)) names.push_back(name);
    }
    std::sort(names.begin(), names.end());
    std::vector<PartState> parts;
    for (const std::string& name : names) {
        try {
            parts.push_back(read(name));
        } catch (const InputError& e) {
            // One part's broken record does not hide the others.
            log::category("workbench")->warn("{}: {}", name, e.what());
        }
    }
    return parts;
}

namespace {

/// The CAD model's facts written at add (display/model.json).
void readFacts(const fs::path& folder, PartState& state)
{
    const fs::path file = folder / files::kModelFacts;
    try {
        const nlohmann::json facts = nlohmann::json::parse(files::readText(file));
        state.cadKind = facts.at("kind").get<std::string>();
        state.triangles = facts.at("triangles").get<std::size_t>();
        state.cadSha256 = facts.at("sha256").get<std::string>();
        for (int k = 0; k < 3; ++k) {
            state.boundsMin[k] = facts.at("bounds_mm").at(0).at(k).get<double>();
            state.boundsMax[k] = facts.at("bounds_mm").at(1).at(k).get<double>();
        }
    } catch (const nlohmann::json::exception& e) {
        throw InputError(file.string(), "", std::string("not the model's facts: ") + e.what());
    }
}

/// The draft's landmarks as loaded: from the cache of the last change, else
/// (a draft edited by hand) by loading it as the daemon would.
void loadLandmarks(const fs::path& folder, const fs::path& draftPath, const std::string& sha, Draft& draft)
{
    if (draft.landmarks.empty()) return;
    const fs::path cacheFile = folder / files::kLandmarkCache;
    if (files::exists(cacheFile)) {
        const nlohmann::json cache = nlohmann::json::parse(files::readText(cacheFile), nullptr, false);
        if (draft::applyCache(draft, cache, sha)) return;
    }
    try {
        const model::PartProgram program = model::loadPartProgram(draftPath);
        draft::applyCache(draft, draft::cacheOf(program, sha), sha);
    } catch (const InputError& e) {
        // Shown as written; the next change is refused in the loader's words.
        log::category("workbench")->warn("{}", e.what());
    }
}

} // namespace

PartState Workspace::read(std::string_view part) const
{
    const fs::path folder = partFolder(part);
    files::PartLock lock(folder, false);
    PartState state;
    state.record = files::readRecord(folder);
    const fs::path draftPath = files::draftFile(folder, state.record.part);
    const std::string text = files::readText(draftPath);
    const std::string sha = sha256Hex(text);
    state.draft = draft::parse(files::loadDraftNode(draftPath), draftPath, state.record.toleranceMm);
    loadLandmarks(folder, draftPath, sha, state.draft);
    for (DraftLandmark& l : state.draft.landmarks)
        if (!l.toleranceMm && !l.limitsMm) l.toleranceMm = state.record.toleranceMm;
    readFacts(folder, state);
    state.released = files::releaseRecordOf(files::releasedFile(folder, state.record.part));
    if (state.released) {
        state.released->inForce = true;
        state.releasedVersion = state.released->version;
    }
    return state;
}

fs::path Workspace::displayMeshFile(std::string_view part, bool lod) const
{
    return partFolder(part) / (lod ? files::kLodStl : files::kModelStl);
}

namespace {

nlohmann::json landmarkJson(const DraftLandmark& l)
{
    return {{"id", l.id},
            {"position", geometry::toJson(l.position)},
            {"normal", geometry::toJson(l.normal)},
            {"normal_given", l.normalGiven},
            {"tolerance_mm", l.toleranceMm ? nlohmann::json(*l.toleranceMm) : nlohmann::json(nullptr)},
            {"limits_mm", l.limitsMm ? nlohmann::json{l.limitsMm->first, l.limitsMm->second} : nlohmann::json(nullptr)},
            {"on", enumName(l.on)}};
}

nlohmann::json releasedJson(const PartState& state)
{
    if (!state.released) return nullptr;
    const Version& v = *state.released;
    return {
        {"version", v.version},
        {"plc_program", state.record.plcProgram ? nlohmann::json(*state.record.plcProgram) : nlohmann::json(nullptr)},
        {"released_by", v.releasedBy},
        {"released_at", v.releasedAt},
        {"rolled_back_from", v.rolledBackFrom ? nlohmann::json(*v.rolledBackFrom) : nlohmann::json(nullptr)}};
}

} // namespace

nlohmann::json toJson(const PartState& state)
{
    nlohmann::json landmarks = nlohmann::json::array();
    for (const DraftLandmark& l : state.draft.landmarks) landmarks.push_back(landmarkJson(l));
    nlohmann::json verified = nullptr;
    if (const auto& v = state.record.verified)
        verified = {{"revision", v->revision},
                    {"draft_sha256", v->draftSha256},
                    {"station_sha256", v->stationSha256},
                    {"verification_sha256", v->verificationSha256},
                    {"released", v->released}};
    return {
        {"name", state.record.part},
        {"revision", state.record.revision},
        {"changed_by", state.record.changedBy},
        {"changed_at", state.record.changedAt},
        {"change", state.record.change},
        {"cad",
         {{"file", state.record.cad},
          {"kind", state.cadKind},
          {"triangles", state.triangles},
          {"bounds_mm", {geometry::toJson(state.boundsMin), geometry::toJson(state.boundsMax)}},
          {"sha256", state.cadSha256}}},
        {"draft",
         {{"octree", {{"depth", state.draft.depth}, {"adjacency_depth", state.draft.adjacencyDepth}}},
          {"alignment", {{"max_shift_mm", state.draft.maxShiftMm}, {"max_rotation_deg", state.draft.maxRotationDeg}}},
          {"tolerance_mm", state.draft.defaultToleranceMm},
          {"landmarks", landmarks}}},
        {"plc_program", state.record.plcProgram ? nlohmann::json(*state.record.plcProgram) : nlohmann::json(nullptr)},
        {"verified", verified},
        {"released", releasedJson(state)}};
}

nlohmann::json toJson(const Version& v)
{
    return {{"version", v.version},
            {"released_by", v.releasedBy},
            {"released_at", v.releasedAt},
            {"verification_sha256", v.verificationSha256},
            {"rolled_back_from", v.rolledBackFrom ? nlohmann::json(*v.rolledBackFrom) : nlohmann::json(nullptr)},
            {"in_force", v.inForce}};
}

nlohmann::json toJson(const Placed& placed)
{
    return {{"id", placed.landmark.id},
            {"on", enumName(placed.landmark.on)},
            {"moved_mm", placed.movedMm},
            {"position", geometry::toJson(placed.landmark.position)},
            {"normal", geometry::toJson(placed.landmark.normal)},
            {"revision", placed.revision}};
}

} // namespace hg::workbench
