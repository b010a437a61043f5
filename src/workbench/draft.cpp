#include "draft.h"

#include "hullgauge/common/format.h"
#include "hullgauge/geometry/json.h"
#include "hullgauge/model/part_program.h"
#include "hullgauge/workbench/placement.h"

#include <cmath>
#include <set>

namespace hg::workbench::draft {

YAML::Node number(double v)
{
    return YAML::Node(formatNumber(v == 0.0 ? 0.0 : v, 12));
}

YAML::Node vector3(const Eigen::Vector3d& v)
{
    YAML::Node n(YAML::NodeType::Sequence);
    n.SetStyle(YAML::EmitterStyle::Flow);
    for (int i = 0; i < 3; ++i) n.push_back(number(std::round(v[i] * 1e6) / 1e6));
    return n;
}

namespace {

Eigen::Vector3d asVector3(const YAML::Node& n)
{
    if (!n.IsSequence() || n.size() != 3) throw YAML::Exception(n.Mark(), "expected [x, y, z]");
    return {n[0].as<double>(), n[1].as<double>(), n[2].as<double>()};
}

DraftLandmark parseLandmark(const YAML::Node& n)
{
    DraftLandmark l;
    l.id = n["id"].as<std::string>();
    l.position = asVector3(n["position"]);
    if (n["normal"]) {
        l.normal = asVector3(n["normal"]);
        if (l.normal.norm() > 0.0) l.normal.normalize();
        l.normalGiven = true;
    }
    if (n["tolerance_mm"]) l.toleranceMm = n["tolerance_mm"].as<double>();
    if (n["limits_mm"]) {
        const YAML::Node lim = n["limits_mm"];
        if (!lim.IsSequence() || lim.size() != 2) throw YAML::Exception(lim.Mark(), "expected [lower, upper]");
        l.limitsMm = std::make_pair(lim[0].as<double>(), lim[1].as<double>());
    }
    return l;
}

} // namespace

Draft parse(const YAML::Node& node, const fs::path& file, double defaultToleranceMm)
{
    Draft d;
    d.defaultToleranceMm = defaultToleranceMm;
    try {
        if (node["octree"] && node["octree"]["depth"]) d.depth = node["octree"]["depth"].as<int>();
        if (node["octree"] && node["octree"]["adjacency_depth"])
            d.adjacencyDepth = node["octree"]["adjacency_depth"].as<int>();
        if (const auto a = node["alignment"]; a && a.IsMap()) {
            if (a["max_shift_mm"]) d.maxShiftMm = a["max_shift_mm"].as<double>();
            if (a["max_rotation_deg"]) d.maxRotationDeg = a["max_rotation_deg"].as<double>();
        }
        if (node["landmarks"] && node["landmarks"].IsSequence())
            for (const YAML::Node& n : node["landmarks"]) d.landmarks.push_back(parseLandmark(n));
    } catch (const YAML::Exception& e) {
        throw InputError(file.string(), "landmarks", e.what());
    }
    return d;
}

nlohmann::json cacheOf(const model::PartProgram& program, const std::string& draftSha256)
{
    const SharpFeatures features = sharpFeatures(program.solid->mesh());
    nlohmann::json landmarks = nlohmann::json::array();
    for (const model::Landmark& l : program.landmarks)
        landmarks.push_back({{"id", l.id},
                             {"position", geometry::toJson(l.position)},
                             {"normal", geometry::toJson(l.normal)},
                             {"on", enumName(classify(l.position, features, program.surfaceToleranceMm()))}});
    return {{"draft_sha256", draftSha256}, {"landmarks", landmarks}};
}

bool applyCache(Draft& draft, const nlohmann::json& cache, const std::string& draftSha256)
{
    try {
        if (!cache.is_object() || cache.value("draft_sha256", std::string()) != draftSha256) return false;
        const nlohmann::json& list = cache.at("landmarks");
        if (!list.is_array() || list.size() != draft.landmarks.size()) return false;
        Draft loaded = draft;
        for (std::size_t i = 0; i < list.size(); ++i) {
            DraftLandmark& l = loaded.landmarks[i];
            const nlohmann::json& c = list[i];
            if (c.at("id").get<std::string>() != l.id) return false;
            for (int k = 0; k < 3; ++k) {
                l.position[k] = c.at("position").at(k).get<double>();
                l.normal[k] = c.at("normal").at(k).get<double>();
            }
            l.on = parseEnum<Placement>(c.at("on").get<std::string>()).value_or(Placement::Face);
        }
        draft = std::move(loaded);
        return true;
    } catch (const nlohmann::json::exception&) {
        return false; // a cache written by hand or cut short: the draft is loaded instead
    }
}

std::optional<std::size_t> indexOf(const YAML::Node& landmarks, const std::string& id)
{
    for (std::size_t i = 0; i < landmarks.size(); ++i)
        if (landmarks[i]["id"] && landmarks[i]["id"].as<std::string>() == id) return i;
    return std::nullopt;
}

std::string freshId(const YAML::Node& landmarks)
{
    std::set<std::string> taken;
    for (const YAML::Node& n : landmarks)
        if (n["id"]) taken.insert(n["id"].as<std::string>());
    for (int n = 1;; ++n)
        if (!taken.count("L" + std::to_string(n))) return "L" + std::to_string(n);
}

} // namespace hg::workbench::draft
