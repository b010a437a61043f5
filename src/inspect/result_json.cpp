// The inspection result as JSON (docs/contracts.md §4 and the extensions of
// docs/inspection.md, "Result JSON extensions"): written here alone, apart
// from the traversal that computes it.
#include "hullgauge/inspect/inspector.h"

#include <cmath>

namespace hg::inspect {

nlohmann::json toJson(const Deviation& d)
{
    nlohmann::json views = nlohmann::json::array();
    for (const ViewDeviation& v : d.views)
        views.push_back({{"view", v.viewId},
                         {"deviation_mm", v.deviationMm},
                         {"sigma_mm", v.sigmaMm},
                         {"px_per_mm", v.pxPerMm},
                         {"tilt_mm", v.tiltMm},
                         {"calibration_mm", v.calibrationMm}});
    return {{"measured", d.measured},
            {"deviation_mm", d.measured ? nlohmann::json(d.deviationMm) : nlohmann::json(nullptr)},
            {"uncertainty_mm", d.measured ? nlohmann::json(d.uncertaintyMm) : nlohmann::json(nullptr)},
            {"budget_mm",
             {{"edge_noise", d.budget.edgeNoise},
              {"method", d.budget.method},
              {"views", d.budget.views},
              {"alignment", d.budget.alignment},
              {"calibration", d.budget.calibration}}},
            {"views", views},
            {"reason", d.reason}};
}

nlohmann::json toJson(const InspectionResult& r)
{
    using nlohmann::json;
    json j;
    j["part"] = r.part;
    j["verdict"] = r.pass ? "pass" : "fail";
    j["voxel_size_mm"] = r.voxelSizeMm;
    j["views_used"] = r.viewsUsed;
    j["voxels_reconstructed"] = r.voxelsReconstructed;
    j["level"] = r.level;
    j["adjacency"] = r.adjacency;
    json lms = json::array();
    for (const LandmarkResult& lr : r.landmarks) {
        json l;
        l["id"] = lr.id;
        l["status"] = enumName(lr.status);
        l["error_number"] = lr.errorNumber;
        auto measured = [&](double v) { return lr.measured ? json(v) : json(nullptr); };
        l["error_min_mm"] = measured(lr.errorMinMm);
        l["error_max_mm"] = measured(lr.errorMaxMm);
        l["error_mm"] = measured(lr.errorMm);
        if (lr.measured) {
            l["offset_low_mm"] = lr.offsetLowMm;
            l["offset_high_mm"] = lr.offsetHighMm;
        }
        l["tolerance_mm"] = lr.toleranceMm;
        if (lr.limitsMm) l["limits_mm"] = {lr.limitsMm->first, lr.limitsMm->second};
        if (!lr.reason.empty()) l["reason"] = lr.reason;
        l["voxels_reconstructed"] = lr.voxelsReconstructed;
        if (lr.medMm) l["med_mm"] = *lr.medMm;
        if (lr.deviation) {
            // docs/inspection.md, "Sub-voxel deviation": signed, outward positive; U with k = 2.
            l["deviation_mm"] = lr.deviation->measured ? json(lr.deviation->deviationMm) : json(nullptr);
            l["uncertainty_mm"] = lr.deviation->measured ? json(lr.deviation->uncertaintyMm) : json(nullptr);
            l["deviation"] = toJson(*lr.deviation);
            if (lr.referral) addReferral(l, *lr.referral);
            if (lr.decision) l["decision"] = enumName(*lr.decision);
        }
        if (!lr.views.empty()) {
            json vs = json::array();
            for (const ViewReport& v : lr.views) {
                json jv{{"view", v.viewId},
                        {"observes", v.discrimination.observes},
                        {"distance_mm", v.discrimination.distanceMm},
                        {"theta_deg", v.discrimination.thetaDeg},
                        {"med_range_mm", v.discrimination.medRangeMm}};
                const double angle = v.discrimination.medAngleMm;
                jv["med_angle_mm"] = std::isfinite(angle) ? json(angle) : json(nullptr);
                vs.push_back(std::move(jv));
            }
            l["views"] = std::move(vs);
        }
        lms.push_back(std::move(l));
    }
    j["landmarks"] = std::move(lms);
    const Statistics& s = r.statistics;
    j["statistics"] = {{"ave_error_min_mm", s.aveErrorMin},
                       {"ave_error_max_mm", s.aveErrorMax},
                       {"ave_error_mm", s.aveError},
                       {"std_error_min_mm", s.stdErrorMin},
                       {"std_error_max_mm", s.stdErrorMax},
                       {"std_error_mm", s.stdError},
                       {"max_error_mm", s.maxError},
                       {"min_error_mm", s.minError},
                       {"total_volume_error_mm3", s.totalVolumeError},
                       {"landmarks_measured", s.landmarksMeasured}};
    json ps = json::array();
    for (const ParameterResult& p : r.parameters) {
        json jp{{"id", p.id},
                {"kind", enumName(p.kind)},
                {"nominal_mm", p.nominal},
                {"tolerance_mm", p.tolerance},
                {"status", enumName(p.status)}};
        jp["min_mm"] = p.measured ? json(p.value.min) : json(nullptr);
        jp["max_mm"] = p.measured ? json(p.value.max) : json(nullptr);
        ps.push_back(std::move(jp));
    }
    j["parameters"] = std::move(ps);
    j["timing_ms"] = {{"segmentation", r.segmentationTime.count()},
                      {"reconstruction", r.reconstructionTime.count()},
                      {"total", r.totalTime.count()}};
    if (r.alignment) {
        j["alignment"] = align::toJson(*r.alignment);
        j["seating_fault"] = r.seatingFault;
    }
    return j;
}

} // namespace hg::inspect
