// Comparing two versions, or a version and the draft (docs/workbench.md,
// "Proving and releasing"): the landmarks added, removed and changed (moved
// by how much, normal turned by how many degrees, tolerance or limits, best
// views), every other setting of the program as written, and the views.
#include "hullgauge/common/format.h"
#include "hullgauge/geometry/json.h"
#include "hullgauge/geometry/station.h"
#include "hullgauge/model/part_program.h"
#include "hullgauge/workbench/workspace.h"

#include "part_files.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>

namespace hg::workbench {
namespace {

/// One side of a diff: the program as written, its landmarks as loaded
/// (none for a draft without landmarks), its views when known.
struct Side {
    std::string name;
    YAML::Node node;
    std::vector<model::Landmark> landmarks;
    std::optional<std::vector<geometry::FixturePose>> views;
    geometry::FixtureType type = geometry::FixtureType::RotationDeclination;
};

std::optional<std::vector<geometry::FixturePose>> draftViews(const fs::path& folder, geometry::FixtureType& type)
{
    const fs::path file = folder / files::kPlanJson;
    if (!files::exists(file)) return std::nullopt;
    const nlohmann::json plan = nlohmann::json::parse(files::readText(file), nullptr, false);
    if (!plan.is_object() || !plan.contains("views")) return std::nullopt;
    if (plan.value("fixture_type", std::string()) == "rail") type = geometry::FixtureType::Rail;
    std::vector<geometry::FixturePose> poses;
    for (const nlohmann::json& v : plan["views"]) {
        geometry::FixturePose p;
        p.rotationDeg = v["pose"].value("rotation_deg", 0.0);
        p.declinationDeg = v["pose"].value("declination_deg", 0.0);
        p.railMm = v["pose"].value("rail_mm", 0.0);
        poses.push_back(p);
    }
    return poses;
}

Side sideOf(const fs::path& folder, const std::string& part, const std::string& which)
{
    Side s;
    s.name = which;
    fs::path program;
    if (which == "draft") {
        program = files::draftFile(folder, part);
        s.views = draftViews(folder, s.type);
    } else {
        const bool number =
            !which.empty() && which.size() <= 7 && which.find_first_not_of("0123456789") == std::string::npos;
        if (!number) throw InputError("", "version", "'" + which + "' is neither a version number nor draft");
        const fs::path kept = files::keptFolder(folder, part, std::stoi(which));
        program = kept / (part + ".yaml");
        if (!files::exists(program)) throw InputError("", "version", "part " + part + " has no version " + which);
        const fs::path views = kept / (part + "-views.yaml");
        s.views = geometry::loadPoses(views);
        if (files::readText(views).find("rail_mm") != std::string::npos) s.type = geometry::FixtureType::Rail;
    }
    s.node = files::loadDraftNode(program);
    if (files::landmarksOf(s.node).size() > 0)
        s.landmarks = files::loadProgramAs(program, program.filename().string()).landmarks;
    return s;
}

/// A scalar as the diff shows it: a number with 12 significant digits (0.1,
/// not 0.10000000000000001), any other text as written.
std::string scalarText(const std::string& text)
{
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (!text.empty() && end == text.c_str() + text.size() && std::isfinite(v)) return formatNumber(v, 12);
    return text;
}

std::string flowText(const YAML::Node& node)
{
    if (node.IsScalar()) return scalarText(node.Scalar());
    std::string s;
    if (node.IsSequence()) {
        for (const YAML::Node& item : node) s += (s.empty() ? "" : ", ") + flowText(item);
        return "[" + s + "]";
    }
    if (node.IsMap()) {
        for (const auto& kv : node)
            s += (s.empty() ? "" : ", ") + kv.first.as<std::string>() + ": " + flowText(kv.second);
        return "{" + s + "}";
    }
    return "null";
}

/// Every setting of the program as written, by its key path; maps opened,
/// lists whole. The landmarks and the release record are compared apart.
void flatten(const YAML::Node& node, const std::string& path, std::map<std::string, std::string>& out)
{
    if (!node.IsMap()) {
        out[path] = flowText(node);
        return;
    }
    for (const auto& kv : node) {
        const std::string key = kv.first.as<std::string>();
        if (path.empty() && (key == "landmarks" || key == "release")) continue;
        flatten(kv.second, path.empty() ? key : path + "." + key, out);
    }
}

nlohmann::json settingsDiff(const Side& a, const Side& b)
{
    std::map<std::string, std::string> from, to;
    flatten(a.node, "", from);
    flatten(b.node, "", to);
    std::map<std::string, bool> keys;
    for (const auto& [k, v] : from) keys[k] = true;
    for (const auto& [k, v] : to) keys[k] = true;
    nlohmann::json out = nlohmann::json::array();
    for (const auto& [key, unused] : keys) {
        const auto f = from.find(key);
        const auto t = to.find(key);
        const nlohmann::json fv = f == from.end() ? nlohmann::json(nullptr) : nlohmann::json(f->second);
        const nlohmann::json tv = t == to.end() ? nlohmann::json(nullptr) : nlohmann::json(t->second);
        if (fv != tv) out.push_back({{"key", key}, {"from", fv}, {"to", tv}});
    }
    return out;
}

std::string toleranceText(const model::Landmark& l)
{
    if (l.limitsMm) return "[" + formatNumber(l.limitsMm->first) + ", " + formatNumber(l.limitsMm->second) + "]";
    return "±" + formatNumber(l.toleranceMm);
}

/// A landmark's change, or null when it did not change.
nlohmann::json landmarkChange(const model::Landmark& a, const model::Landmark& b)
{
    const double moved = (b.position - a.position).norm();
    const double turned = std::acos(std::clamp(a.normal.dot(b.normal), -1.0, 1.0)) * 180.0 / std::numbers::pi;
    const bool tolerance = toleranceText(a) != toleranceText(b);
    const bool views = a.bestViews != b.bestViews;
    if (moved <= 1e-9 && turned <= 1e-6 && !tolerance && !views) return nullptr;
    nlohmann::json j = {{"id", a.id}, {"moved_mm", moved}, {"normal_turned_deg", turned}};
    if (tolerance) j["tolerance"] = {{"from", toleranceText(a)}, {"to", toleranceText(b)}};
    if (views) j["best_views_changed"] = true;
    return j;
}

nlohmann::json landmarksDiff(const Side& a, const Side& b)
{
    nlohmann::json added = nlohmann::json::array(), removed = nlohmann::json::array(),
                   changed = nlohmann::json::array();
    const auto find = [](const Side& s, const std::string& id) -> const model::Landmark* {
        for (const model::Landmark& l : s.landmarks)
            if (l.id == id) return &l;
        return nullptr;
    };
    for (const model::Landmark& l : a.landmarks) {
        const model::Landmark* other = find(b, l.id);
        if (!other)
            removed.push_back(l.id);
        else if (nlohmann::json c = landmarkChange(l, *other); !c.is_null())
            changed.push_back(c);
    }
    for (const model::Landmark& l : b.landmarks)
        if (!find(a, l.id)) added.push_back(l.id);
    return {{"added", added}, {"removed", removed}, {"changed", changed}};
}

bool samePose(const geometry::FixturePose& p, const geometry::FixturePose& q)
{
    return std::abs(p.rotationDeg - q.rotationDeg) < 1e-9 && std::abs(p.declinationDeg - q.declinationDeg) < 1e-9 &&
           std::abs(p.railMm - q.railMm) < 1e-9;
}

nlohmann::json viewsDiff(const Side& a, const Side& b)
{
    if (!a.views || !b.views) return nullptr; // a draft not planned: its views are not known
    const auto missing = [](const std::vector<geometry::FixturePose>& from,
                            const std::vector<geometry::FixturePose>& in, geometry::FixtureType type) {
        nlohmann::json out = nlohmann::json::array();
        for (const auto& p : from)
            if (std::none_of(in.begin(), in.end(), [&](const auto& q) { return samePose(p, q); }))
                out.push_back(geometry::toJson(p, type));
        return out;
    };
    return {{"added", missing(*b.views, *a.views, b.type)}, {"removed", missing(*a.views, *b.views, a.type)}};
}

} // namespace

nlohmann::json Workspace::diff(std::string_view part, const std::string& from, const std::string& to) const
{
    const fs::path folder = partFolder(part);
    const std::string name(part);
    const Side a = sideOf(folder, name, from);
    const Side b = sideOf(folder, name, to);
    return {{"part", name},
            {"from", from},
            {"to", to},
            {"landmarks", landmarksDiff(a, b)},
            {"settings", settingsDiff(a, b)},
            {"views", viewsDiff(a, b)}};
}

namespace {

std::string poseText(const nlohmann::json& pose)
{
    if (pose.contains("rail_mm")) return "rail " + formatNumber(pose["rail_mm"].get<double>()) + " mm";
    return "rotation " + formatNumber(pose.value("rotation_deg", 0.0)) + "°, declination " +
           formatNumber(pose.value("declination_deg", 0.0)) + "°";
}

std::string valueText(const nlohmann::json& v)
{
    return v.is_null() ? "(not given)" : v.get<std::string>();
}

std::string landmarkLine(const nlohmann::json& c)
{
    std::string line = "landmark " + c["id"].get<std::string>() + ":";
    std::string sep = " ";
    if (c["moved_mm"].get<double>() > 1e-9) {
        line += sep + "moved " + files::mmText(c["moved_mm"].get<double>()) + " mm";
        sep = ", ";
    }
    if (c["normal_turned_deg"].get<double>() > 1e-6) {
        line += sep + "normal turned " + formatNumber(c["normal_turned_deg"].get<double>(), 4) + "°";
        sep = ", ";
    }
    if (c.contains("tolerance")) {
        line += sep + "tolerance " + c["tolerance"]["from"].get<std::string>() + " → " +
                c["tolerance"]["to"].get<std::string>() + " mm";
        sep = ", ";
    }
    if (c.contains("best_views_changed")) line += sep + "best views changed";
    return line;
}

} // namespace

std::string diffText(const nlohmann::json& diff)
{
    std::string out = "diff of " + diff.value("part", std::string()) + ": " + diff.value("from", std::string()) +
                      " → " + diff.value("to", std::string()) + "\n";
    const nlohmann::json& l = diff["landmarks"];
    for (const auto& id : l["added"]) out += "landmark " + id.get<std::string>() + ": added\n";
    for (const auto& id : l["removed"]) out += "landmark " + id.get<std::string>() + ": removed\n";
    for (const auto& c : l["changed"]) out += landmarkLine(c) + "\n";
    for (const auto& s : diff["settings"])
        out += s["key"].get<std::string>() + ": " + valueText(s["from"]) + " → " + valueText(s["to"]) + "\n";
    if (diff["views"].is_null()) {
        out += "views: not compared (the draft has no plan; hullgauge part plan)\n";
    } else {
        for (const auto& p : diff["views"]["added"]) out += "view added: " + poseText(p) + "\n";
        for (const auto& p : diff["views"]["removed"]) out += "view removed: " + poseText(p) + "\n";
    }
    return out;
}

} // namespace hg::workbench
