// Landmarks of the draft (docs/workbench.md, "Landmarks"): placed on the
// surface as the part program loader places them, snapped onto sharp edges
// and corners, and every change loaded as the daemon would load the draft
// before it replaces the old one.
#include "hullgauge/common/digest.h"
#include "hullgauge/common/durable_file.h"
#include "hullgauge/common/format.h"
#include "hullgauge/model/part_program.h"
#include "hullgauge/model/step_io.h"
#include "hullgauge/workbench/placement.h"
#include "hullgauge/workbench/workspace.h"

#include "draft.h"
#include "part_files.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <functional>

namespace hg::workbench {
namespace {

/// Where a point given near the part lands: the nearest point of the
/// surface (of a STEP part: of its exact B-rep), moved onto a corner or a
/// sharp edge within the snap distance; refused farther than max(1 mm,
/// snap) from the surface.
Snapped land(const Eigen::Vector3d& point, const model::CadModel& cad)
{
    if (!point.allFinite() || point.cwiseAbs().maxCoeff() > 1e5)
        throw InputError("", "position",
                         "landmark position " + files::pointText(point) + " is not a point near a part");
    const Eigen::AlignedBox3d bounds = cad.brep ? cad.brep->summary().bounds : cad.solid->mesh().bounds();
    const double snap = snapDistanceMm(bounds);
    const double surfaceTolerance = std::max(0.01, cad.octree.voxelSize() / 4.0);
    Eigen::Vector3d surface;
    double distance = 0.0;
    if (cad.brep) {
        const model::BRepPoint exact = cad.brep->closestPoint(point, surfaceTolerance);
        surface = exact.point;
        distance = exact.distance;
    } else {
        const model::SurfacePoint nearest = cad.solid->closestPoint(point);
        surface = nearest.point;
        distance = nearest.distance;
    }
    if (distance > std::max(1.0, snap))
        throw InputError("", "position",
                         "landmark position " + files::pointText(point) + " is " + files::mmText(distance) +
                             " mm from the part's surface; click on the part");
    return snapToFeature(surface, sharpFeatures(cad.solid->mesh()), snap);
}

/// What a change did: the record's words, the landmark it placed or changed,
/// and the point given for it (the distance moved is measured from it).
struct Edited {
    std::string change;
    std::string id;
    std::optional<Eigen::Vector3d> given;
};

using Mutation = std::function<Edited(YAML::Node& draft, const PartRecord& record)>;

/// A draft without landmarks is not loaded (the loader needs one); what
/// would name a landmark in it is refused here.
void checkWithoutLandmarks(const YAML::Node& draft, const std::string& shownAs)
{
    if (draft["parameters"] && draft["parameters"].size() > 0)
        throw InputError(shownAs, "parameters",
                         "the draft's parameters are built on landmarks: remove them before its last landmark");
    if (draft["alignment"] && draft["alignment"]["datums"])
        throw InputError(shownAs, "alignment.datums",
                         "the draft's datums are landmarks: remove them before its last landmark");
}

/// The draft as it would be, loaded as the daemon loads it: its landmark cache.
nlohmann::json checkedDraft(const fs::path& temp, const fs::path& draftPath, const YAML::Node& draft,
                            const std::string& sha)
{
    const std::string shownAs = draftPath.filename().string();
    if (files::landmarksOf(draft).size() == 0) {
        checkWithoutLandmarks(draft, shownAs);
        return {{"draft_sha256", sha}, {"landmarks", nlohmann::json::array()}};
    }
    return draft::cacheOf(files::loadProgramAs(temp, shownAs), sha);
}

DraftLandmark shown(const YAML::Node& draftNode, const nlohmann::json& cache, const fs::path& file,
                    const std::string& id)
{
    Draft d = draft::parse(draftNode, file, 0.0);
    draft::applyCache(d, cache, cache.at("draft_sha256").get<std::string>());
    for (const DraftLandmark& l : d.landmarks)
        if (l.id == id) return l;
    return {};
}

/// One change of the draft under the part's lock: the revision checked, the
/// draft changed, written to a temporary name, loaded, and only then renamed
/// into place, its cache and the record after it.
Placed applyChange(const fs::path& folder, int revision, const Actor& by, const Mutation& mutate)
{
    files::PartLock lock(folder, true);
    PartRecord record = files::readRecord(folder);
    files::checkRevision(record, revision);
    const fs::path draftPath = files::draftFile(folder, record.part);
    YAML::Node node = files::loadDraftNode(draftPath);
    const Edited edited = mutate(node, record);
    const std::string text = files::emitDraft(node);
    const std::string sha = sha256Hex(text);
    const fs::path temp = folder / ("." + draftPath.filename().string() + ".new-" + std::to_string(::getpid()));
    nlohmann::json cache;
    try {
        writeFileDurably(temp, text);
        cache = checkedDraft(temp, draftPath, node, sha);
    } catch (...) {
        std::error_code ec;
        fs::remove(temp, ec);
        throw;
    }
    files::renameInto(temp, draftPath);
    replaceFileDurably(folder / files::kLandmarkCache, cache.dump(2) + "\n");
    files::recordChange(record, by, edited.change);
    files::writeRecord(folder, record);
    Placed placed;
    placed.revision = record.revision;
    if (!edited.id.empty()) placed.landmark = shown(node, cache, draftPath, edited.id);
    if (edited.given) placed.movedMm = (*edited.given - placed.landmark.position).norm();
    return placed;
}

YAML::Node flowPair(double a, double b)
{
    YAML::Node n(YAML::NodeType::Sequence);
    n.SetStyle(YAML::EmitterStyle::Flow);
    n.push_back(draft::number(a));
    n.push_back(draft::number(b));
    return n;
}

std::string limitsText(const std::pair<double, double>& l)
{
    return "[" + formatNumber(l.first) + ", " + formatNumber(l.second) + "] mm";
}

/// The tolerance of an edit: `tolerance_mm` or `limits_mm`, the other removed.
void setTolerance(YAML::Node& lm, const LandmarkEdit& edit, std::vector<std::string>& said)
{
    if (edit.toleranceMm) {
        lm.remove("limits_mm");
        lm["tolerance_mm"] = draft::number(*edit.toleranceMm);
        said.push_back("tolerance " + formatNumber(*edit.toleranceMm) + " mm");
    }
    if (edit.limitsMm) {
        lm.remove("tolerance_mm");
        lm["limits_mm"] = flowPair(edit.limitsMm->first, edit.limitsMm->second);
        said.push_back("limits " + limitsText(*edit.limitsMm));
    }
}

/// Renames a landmark where the draft names it: its entry, its parameters, its datums.
void rename(YAML::Node& draft, YAML::Node& lm, const std::string& from, const std::string& to)
{
    lm["id"] = to;
    const auto replaceIn = [&](YAML::Node list) {
        if (!list || !list.IsSequence()) return;
        for (std::size_t i = 0; i < list.size(); ++i)
            if (list[i].IsScalar() && list[i].as<std::string>() == from) list[i] = to;
    };
    if (draft["parameters"] && draft["parameters"].IsSequence())
        for (YAML::Node p : draft["parameters"]) replaceIn(p["landmarks"]);
    if (draft["alignment"] && draft["alignment"].IsMap()) replaceIn(draft["alignment"]["datums"]);
}

std::string joined(const std::vector<std::string>& parts)
{
    std::string s;
    for (const std::string& p : parts) s += (s.empty() ? "" : ", ") + p;
    return s;
}

Eigen::Vector3d positionOf(const YAML::Node& lm)
{
    const YAML::Node p = lm["position"];
    return {p[0].as<double>(), p[1].as<double>(), p[2].as<double>()};
}

} // namespace

Placed Workspace::addLandmark(std::string_view part, int revision, const std::optional<std::string>& id,
                              const LandmarkEdit& edit, const Actor& by)
{
    if (!edit.position) throw InputError("", "position", "a new landmark needs a position");
    const fs::path folder = partFolder(part);
    return applyChange(folder, revision, by, [&](YAML::Node& node, const PartRecord& record) {
        YAML::Node landmarks = files::landmarksOf(node);
        const std::string newId = id ? *id : edit.newId ? *edit.newId : draft::freshId(landmarks);
        if (newId.empty()) throw InputError("", "id", "the landmark's id is empty");
        const Snapped at = land(*edit.position, files::loadDraftCad(folder, record, node));
        YAML::Node lm(YAML::NodeType::Map);
        lm.SetStyle(YAML::EmitterStyle::Flow);
        lm["id"] = newId;
        lm["position"] = draft::vector3(at.position);
        if (edit.normal) lm["normal"] = draft::vector3(*edit.normal);
        if (edit.limitsMm)
            lm["limits_mm"] = flowPair(edit.limitsMm->first, edit.limitsMm->second);
        else
            lm["tolerance_mm"] = draft::number(edit.toleranceMm.value_or(record.toleranceMm));
        landmarks.push_back(lm);
        node["landmarks"] = landmarks;
        return Edited{"landmark " + newId + " added on " + std::string(enumName(at.on)), newId, *edit.position};
    });
}

Placed Workspace::changeLandmark(std::string_view part, int revision, const std::string& id, const LandmarkEdit& edit,
                                 const Actor& by)
{
    const fs::path folder = partFolder(part);
    return applyChange(folder, revision, by, [&](YAML::Node& node, const PartRecord& record) {
        YAML::Node landmarks = files::landmarksOf(node);
        const auto index = draft::indexOf(landmarks, id);
        if (!index) throw InputError("", "id", "no landmark '" + id + "' in the draft of " + record.part);
        YAML::Node lm = landmarks[*index];
        std::vector<std::string> said;
        if (edit.position) {
            const Snapped at = land(*edit.position, files::loadDraftCad(folder, record, node));
            const Eigen::Vector3d before = positionOf(lm);
            lm["position"] = draft::vector3(at.position);
            said.push_back("moved " + files::mmText((positionOf(lm) - before).norm()) + " mm onto a " +
                           std::string(enumName(at.on)));
        }
        if (edit.normal) {
            lm["normal"] = draft::vector3(*edit.normal);
            said.push_back("normal " + files::pointText(*edit.normal));
        } else if (edit.normalFromMesh && lm["normal"]) {
            lm.remove("normal");
            said.push_back("normal from the surface");
        }
        setTolerance(lm, edit, said);
        std::string current = id;
        if (edit.newId && *edit.newId != id) {
            if (edit.newId->empty()) throw InputError("", "new_id", "the landmark's new id is empty");
            rename(node, lm, id, *edit.newId);
            said.push_back("renamed " + *edit.newId);
            current = *edit.newId;
        }
        if (said.empty()) throw InputError("", "", "the change of landmark " + id + " changes nothing");
        return Edited{"landmark " + id + " " + joined(said), current,
                      edit.position ? std::optional<Eigen::Vector3d>(*edit.position) : std::nullopt};
    });
}

int Workspace::removeLandmark(std::string_view part, int revision, const std::string& id, const Actor& by)
{
    const fs::path folder = partFolder(part);
    const Placed done = applyChange(folder, revision, by, [&](YAML::Node& node, const PartRecord& record) {
        const YAML::Node landmarks = files::landmarksOf(node);
        if (!draft::indexOf(landmarks, id))
            throw InputError("", "id", "no landmark '" + id + "' in the draft of " + record.part);
        YAML::Node kept(YAML::NodeType::Sequence);
        for (const YAML::Node& lm : landmarks)
            if (lm["id"].as<std::string>() != id) kept.push_back(lm);
        node["landmarks"] = kept;
        return Edited{"landmark " + id + " removed", "", std::nullopt};
    });
    return done.revision;
}

} // namespace hg::workbench
