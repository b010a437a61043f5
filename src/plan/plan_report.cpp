#include "hullgauge/plan/plan_report.h"
#include "hullgauge/common/format.h"
#include "hullgauge/geometry/json.h"

#include <algorithm>
#include <cmath>
#include <ostream>
#include <sstream>

namespace hg::plan {

namespace {

using nlohmann::json;

std::string num(double v, int precision = 4)
{
    return std::isfinite(v) ? formatNumber(v, precision) : "∞";
}

std::string poseText(const FixturePose& p, FixtureType type)
{
    if (type == FixtureType::Rail) return "rail " + num(p.railMm, 6) + " mm";
    return "rot " + num(p.rotationDeg, 6) + "°, decl " + num(p.declinationDeg, 6) + "°";
}

// Views (ids) observing landmark l, and the smallest predicted MED among them.
std::pair<std::vector<std::string>, double> observers(const ViewPlan& plan, std::size_t l)
{
    std::vector<std::string> ids;
    double med = std::numeric_limits<double>::infinity();
    for (const auto& v : plan.views)
        for (std::size_t k = 0; k < v.landmarks.size(); ++k)
            if (v.landmarks[k] == l) {
                ids.push_back(v.id);
                med = std::min(med, v.predictedMedMm[k]);
            }
    return {ids, med};
}

/// `fixture.motion`'s key names for an axis' speed and acceleration.
std::pair<std::string, std::string> motionKeys(FixtureType type)
{
    const std::string unit = type == FixtureType::Rail ? "mm" : "deg";
    return {"speed_" + unit + "_s", "acceleration_" + unit + "_s2"};
}

/// plan.json's `cycle_time` (docs/planning.md, "Cycle time").
json cycleTimeJson(const ViewPlan& plan, FixtureType type)
{
    const auto& ct = plan.cycleTime;
    const auto& c = ct.predicted;
    json out;
    out["predicted_s"] = c.totalS;
    out["unordered_s"] = ct.unorderedS;
    out["least_distance_s"] = ct.leastDistanceS;
    out["repeat_s"] = ct.repeatS;
    out["moves_s"] = c.movesS;
    out["settles_s"] = c.settlesS;
    out["grabs_s"] = c.grabsS;
    out["inspection_s"] = c.inspectionS;
    out["start"] = geometry::toJson(c.start, type);
    const auto names = geometry::axisNames(type);
    json moves = json::array();
    for (const auto& m : c.moves) {
        json j;
        j["from"] = m.view == 0 ? std::string("start") : plan.views[m.view - 1].id;
        j["to"] = plan.views[m.view].id;
        j["distance"] = m.distance;
        j["move_s"] = m.seconds;
        for (std::size_t a = 0; a < m.axisSeconds.size() && a < names.size(); ++a)
            j["axes_s"][names[a]] = m.axisSeconds[a];
        moves.push_back(j);
    }
    out["moves"] = moves;
    const auto [speedKey, accelerationKey] = motionKeys(type);
    json model;
    model["source"] = ct.motion.source;
    for (const auto& a : ct.motion.axes)
        model[a.name] = {{speedKey, a.speed}, {accelerationKey, a.acceleration}, {"settle_s", a.settleS}};
    model["settle_s"] = ct.motion.settleS;
    model["grab_s"] = ct.motion.grabS;
    out["model"] = model;
    return out;
}

/// The report's cycle-time section: the summary, the comparison and every move.
void cycleTimeMarkdown(std::ostream& s, const ViewPlan& plan, FixtureType type)
{
    const auto& ct = plan.cycleTime;
    const auto& c = ct.predicted;
    const auto n = plan.views.size();
    s << "\n## Cycle time (predicted)\n\n**" << num(c.totalS, 3) << " s**: moves " << num(c.movesS, 3) << " s, settle "
      << num(c.settlesS, 3) << " s (" << n << " × " << num(ct.motion.settleS, 3) << "), grabs " << num(c.grabsS, 3)
      << " s (" << n << " × " << num(ct.motion.grabS, 3) << "), inspection " << num(c.inspectionS, 3) << " s, from "
      << poseText(c.start, type) << ". The views in the order chosen: " << num(ct.unorderedS, 3)
      << " s; in the order of least travel distance: " << num(ct.leastDistanceS, 3)
      << " s; the next part, from the last view: " << num(ct.repeatS, 3) << " s.\n\nMotion model (" << ct.motion.source
      << "):";
    const auto [speedKey, accelerationKey] = motionKeys(type);
    const std::string unit = type == FixtureType::Rail ? "mm" : "°";
    for (std::size_t a = 0; a < ct.motion.axes.size(); ++a) {
        const auto& ax = ct.motion.axes[a];
        s << (a ? ";" : "") << " " << ax.name << " " << num(ax.speed) << " " << unit << "/s, " << num(ax.acceleration)
          << " " << unit << "/s², settle " << num(ax.settleS, 3) << " s";
    }
    s << ".\n\n| move | distance | ";
    const auto names = geometry::axisNames(type);
    for (const auto& name : names) s << name << " s | ";
    s << "move s |\n|---|---|";
    for (std::size_t a = 0; a < names.size(); ++a) s << "---|";
    s << "---|\n";
    for (const auto& m : c.moves) {
        s << "| " << (m.view == 0 ? std::string("start") : plan.views[m.view - 1].id) << " → " << plan.views[m.view].id
          << " | " << num(m.distance, 4) << " " << unit << " | ";
        for (double t : m.axisSeconds) s << num(t, 3) << " | ";
        s << num(m.seconds, 3) << " |\n";
    }
}

} // namespace

json planToJson(const ViewPlan& plan, const PlanProblem& problem)
{
    const auto type = problem.station->fixture.type;
    json out;
    out["part"] = problem.part;
    out["feasible"] = plan.feasible;
    out["fixture_type"] = enumName(type);
    out["voxel_size_mm"] = problem.frame.voxelSize();
    out["voxel_level"] = problem.frame.depth;
    out["problems"] = plan.problems;

    json views = json::array();
    for (const auto& v : plan.views) {
        const auto& cam = v.camera;
        json j;
        j["id"] = v.id;
        j["pose"] = geometry::toJson(v.pose, type);
        if (cam.isTelecentric()) j["model"] = "telecentric";
        j["K"] = geometry::toJson(cam.intrinsics().K);
        j["dist"] = cam.intrinsics().dist.empty() ? std::vector<double>(5, 0.0) : cam.intrinsics().dist;
        j["R"] = geometry::toJson(cam.cameraFromPart().R);
        j["t"] = geometry::toJson(cam.cameraFromPart().t);
        j["image_size"] = {cam.imageSize().width, cam.imageSize().height};
        json ids = json::array();
        json med = json::object();
        for (std::size_t k = 0; k < v.landmarks.size(); ++k) {
            const auto& id = plan.landmarks[v.landmarks[k]].id;
            ids.push_back(id);
            med[id] = v.predictedMedMm[k];
        }
        j["landmarks"] = ids;
        j["predicted_med_mm"] = med;
        views.push_back(j);
    }
    out["views"] = views;

    json landmarks = json::array();
    for (std::size_t l = 0; l < plan.landmarks.size(); ++l) {
        const auto& a = plan.landmarks[l];
        auto [ids, med] = observers(plan, l);
        json j;
        j["id"] = a.id;
        j["status"] = enumName(a.verdict);
        j["inspectable"] = a.inspectable();
        // The drawing's tolerance; where it is decided to U (finer than ΔV)
        // the planner judged the views against the voxel size instead.
        const auto& drawn = l < problem.landmarks.size() ? problem.landmarks[l].drawingToleranceMm : std::nullopt;
        j["tolerance_mm"] = drawn.value_or(a.toleranceMm);
        if (drawn) j["resolved_voxel_mm"] = a.toleranceMm;
        j["normal"] = geometry::toJson(a.normal);
        j["best_views"] = a.designerBestViews ? "designer" : "derived";
        j["observed_by"] = ids;
        if (std::isfinite(med)) j["predicted_med_mm"] = med;
        if (std::isfinite(a.bestMedMm) && !a.witnessPoses.empty()) j["best_med_mm"] = a.bestMedMm;
        json witnesses = json::array();
        for (std::size_t k = 0; k < a.witnessPoses.size(); ++k) {
            auto w = geometry::toJson(a.witnessPoses[k], type);
            w["direction"] = geometry::toJson(a.witnessDirections[k]);
            witnesses.push_back(w);
        }
        j["witnesses"] = witnesses;
        if (!a.reason.empty()) j["reason"] = a.reason;
        if (!a.unreachableWitnesses.empty()) {
            json u = json::array();
            for (const auto& p : a.unreachableWitnesses) u.push_back(geometry::toJson(p, type));
            j["unreachable_witnesses"] = u;
        }
        if (a.blockingTriangle) j["blocking_triangle"] = *a.blockingTriangle;
        if (a.blockingPoint) j["blocking_point"] = geometry::toJson(*a.blockingPoint);
        if (a.nearestInspectablePoint) j["nearest_inspectable_point"] = geometry::toJson(*a.nearestInspectablePoint);
        json voids = json::array();
        for (auto key : a.unseenVoids) {
            const auto idx = inspect::keyIndex(key);
            voids.push_back({idx.x(), idx.y(), idx.z()});
        }
        j["unseen_voids"] = voids;
        if (!a.warnings.empty()) j["warnings"] = a.warnings;
        landmarks.push_back(j);
    }
    out["landmarks"] = landmarks;

    json stats;
    stats["candidate_poses"] = plan.candidatePoses;
    stats["views"] = plan.views.size();
    stats["views_greedy"] = plan.greedyViews;
    if (plan.exactViews) {
        stats["views_exact"] = *plan.exactViews;
        stats["exact_optimal"] = plan.exactOptimal;
    }
    stats["seconds"] = plan.seconds;
    out["statistics"] = stats;
    out["cycle_time"] = cycleTimeJson(plan, type);
    return out;
}

std::string posesYaml(const ViewPlan& plan, FixtureType type)
{
    std::ostringstream s;
    s.precision(12);
    s << "# Planned views in travel order (hullgauge plan).\n";
    for (const auto& v : plan.views) {
        if (type == FixtureType::Rail)
            s << "- {rail_mm: " << v.pose.railMm << "}\n";
        else
            s << "- {rotation_deg: " << v.pose.rotationDeg << ", declination_deg: " << v.pose.declinationDeg << "}\n";
    }
    return s.str();
}

std::string planMarkdown(const ViewPlan& plan, const PlanProblem& problem)
{
    const auto type = problem.station->fixture.type;
    std::ostringstream s;
    s << "# View plan: " << problem.part << "\n\n";
    std::size_t inspectable = 0;
    for (const auto& a : plan.landmarks) inspectable += a.inspectable() ? 1 : 0;
    s << (plan.feasible ? "**Feasible.** " : "**Not feasible.** ") << plan.views.size() << " views observe "
      << inspectable << " of " << plan.landmarks.size() << " landmarks (voxel " << num(problem.frame.voxelSize())
      << " mm; " << plan.candidatePoses << " candidate poses; " << num(plan.seconds, 3) << " s).";
    if (plan.exactViews)
        s << " Integer-program optimum: " << *plan.exactViews << " views" << (plan.exactOptimal ? "" : " (not proven)")
          << ".";
    s << "\n\n";
    if (!plan.problems.empty()) {
        s << "## Problems\n\n";
        for (const auto& p : plan.problems) s << "- " << p << "\n";
        s << "\n";
    }
    s << "## Views (travel order)\n\n| view | pose | landmarks (predicted MED, mm) |\n|---|---|---|\n";
    for (const auto& v : plan.views) {
        s << "| " << v.id << " | " << poseText(v.pose, type) << " | ";
        for (std::size_t k = 0; k < v.landmarks.size(); ++k)
            s << (k ? ", " : "") << plan.landmarks[v.landmarks[k]].id << " (" << num(v.predictedMedMm[k], 3) << ")";
        s << " |\n";
    }
    cycleTimeMarkdown(s, plan, type);
    s << "\n## Landmarks\n\nThe views must resolve the tolerance, or the voxel size ΔV where the tolerance is finer "
         "(it is then decided to U by the sub-voxel deviation).\n\n"
         "| landmark | verdict | tolerance mm | views resolve mm | best MED mm | views | witnesses | unseen voids |\n"
         "|---|---|---|---|---|---|---|---|\n";
    for (std::size_t l = 0; l < plan.landmarks.size(); ++l) {
        const auto& a = plan.landmarks[l];
        auto [ids, med] = observers(plan, l);
        std::string viewList;
        for (const auto& id : ids) viewList += (viewList.empty() ? "" : " ") + id;
        const auto& drawn = l < problem.landmarks.size() ? problem.landmarks[l].drawingToleranceMm : std::nullopt;
        s << "| " << a.id << " | " << enumName(a.verdict) << " | " << num(drawn.value_or(a.toleranceMm)) << " | "
          << num(a.toleranceMm) << (drawn ? " (ΔV)" : "") << " | "
          << (a.witnessPoses.empty() ? "-" : num(a.bestMedMm, 3)) << " | " << (viewList.empty() ? "-" : viewList)
          << " | " << a.witnessPoses.size() << " | " << a.unseenVoids.size() << " |\n";
    }
    bool anyWarning = false;
    for (const auto& a : plan.landmarks)
        for (const auto& w : a.warnings) {
            if (!anyWarning) s << "\n## Warnings\n\n";
            anyWarning = true;
            s << "- " << a.id << ": " << w << "\n";
        }
    return s.str();
}

} // namespace hg::plan
