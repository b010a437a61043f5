#include "hullgauge/commission/report.h"

#include "hullgauge/common/format.h"

#include <cmath>
#include <sstream>

namespace hg::commission {
namespace {

using nlohmann::json;

std::string num(double v, int precision = 4)
{
    return std::isfinite(v) ? formatNumber(v, precision) : "∞";
}

std::string num(const std::optional<double>& v, int precision = 4)
{
    return v ? num(*v, precision) : "—";
}

json optionalNumber(const std::optional<double>& v)
{
    return v ? json(*v) : json(nullptr);
}

json trialJson(const DefectTrial& t)
{
    return {{"kind", enumName(t.defect.kind)},
            {"multiple", t.multiple},
            {"depth_mm", t.defect.depthMm},
            {"true_deviation_mm", t.defect.trueDeviationMm()},
            {"status", enumName(t.status)},
            {"deviation_mm", optionalNumber(t.deviationMm)},
            {"uncertainty_mm", optionalNumber(t.uncertaintyMm)},
            {"caught", t.caught()},
            {"error", t.error.empty() ? nlohmann::json(nullptr) : nlohmann::json(t.error)}};
}

/// {"ok": 40, "uncertain": 2}: the nominal seats per status, under the statuses' names.
json statusesJson(const std::map<inspect::LandmarkStatus, std::size_t>& statuses)
{
    json j = json::object();
    for (const auto& [status, seats] : statuses) j[std::string(enumName(status))] = seats;
    return j;
}

json landmarkJson(const LandmarkVerification& v)
{
    json trials = json::array();
    for (const DefectTrial& t : v.defects) trials.push_back(trialJson(t));
    return {{"id", v.id},
            {"tolerance_mm", v.toleranceMm},
            {"seats", v.seats},
            {"observable_seats", v.observableSeats},
            {"accepted_seats", v.acceptedSeats},
            {"false_rejects", v.observableSeats - v.acceptedSeats + (v.seats - v.observableSeats)},
            {"statuses", statusesJson(v.statuses)},
            {"predicted_u_mm", v.predictedUMm},
            {"measured_u_max_mm", optionalNumber(v.measuredUMaxMm)},
            {"measured_u_median_mm", optionalNumber(v.measuredUMedianMm)},
            {"u_ratio",
             v.measuredUMaxMm && v.predictedUMm > 0.0 ? json(*v.measuredUMaxMm / v.predictedUMm) : json(nullptr)},
            {"deviation_max_abs_mm", optionalNumber(v.deviationMaxAbsMm)},
            {"seat_error_max_mm", optionalNumber(v.seatErrorMaxMm)},
            {"seat_error_judged", v.seatErrorJudged},
            {"seat_error_beyond_u", v.seatErrorBeyondU},
            {"worst_u_budget", v.worstBudget ? json{{"edge_noise_mm", v.worstBudget->edgeNoise},
                                                    {"method_mm", v.worstBudget->method},
                                                    {"views_mm", v.worstBudget->views},
                                                    {"alignment_mm", v.worstBudget->alignment},
                                                    {"calibration_mm", v.worstBudget->calibration}}
                                             : json(nullptr)},
            {"smallest_caught_multiple", optionalNumber(v.smallestCaughtMultiple)},
            {"defects", trials},
            {"passed", v.passed}};
}

json viewJson(const ViewVerification& v)
{
    return {{"id", v.id},
            {"pose",
             {{"rotation_deg", v.pose.rotationDeg},
              {"declination_deg", v.pose.declinationDeg},
              {"rail_mm", v.pose.railMm}}},
            {"landmarks", v.landmarks},
            {"observed_at_seats", v.observes},
            {"min_frame_margin_px", std::isfinite(v.minFrameMarginPx) ? json(v.minFrameMarginPx) : json(nullptr)}};
}

json findingJson(const Finding& f)
{
    json fixes = json::array();
    for (Fix x : f.fixes) fixes.push_back(enumName(x));
    return {{"subject", f.subject}, {"test", f.test}, {"what", f.what}, {"fixes", fixes}, {"fix", f.fixText}};
}

void landmarkTable(std::ostringstream& md, const VerificationReport& r)
{
    md << "| landmark | tolerance mm | observable | accepted | U predicted mm | U measured (max) mm | ratio | "
          "smallest defect caught | verdict |\n|---|---|---|---|---|---|---|---|---|\n";
    for (const LandmarkVerification& v : r.landmarks) {
        const std::string ratio =
            v.measuredUMaxMm && v.predictedUMm > 0.0 ? num(*v.measuredUMaxMm / v.predictedUMm, 3) : "—";
        md << "| " << v.id << " | " << num(v.toleranceMm) << " | " << v.observableSeats << "/" << v.seats << " | "
           << v.acceptedSeats << "/" << v.seats << " | " << num(v.predictedUMm) << " | " << num(v.measuredUMaxMm)
           << " | " << ratio << " | "
           << (v.smallestCaughtMultiple ? num(*v.smallestCaughtMultiple) + " × tolerance" : "none") << " | "
           << (v.passed ? "passes" : "**fails**") << " |\n";
    }
}

void defectTable(std::ostringstream& md, const VerificationReport& r)
{
    md << "\n## Seeded defects\n\nEach defect moves the surface along the landmark's normal by the depth given "
          "(a patch of ±"
       << num(r.defectHalfWidthMm) << " mm), inspected at a seat of its own. Caught: the landmark is not accepted.\n\n"
       << "| landmark | defect | depth mm | status | deviation mm | U mm | caught |\n|---|---|---|---|---|---|---|\n";
    for (const LandmarkVerification& v : r.landmarks)
        for (const DefectTrial& t : v.defects)
            md << "| " << v.id << " | " << enumName(t.defect.kind) << " " << num(t.multiple) << " × tol | "
               << num(t.defect.depthMm) << " | " << enumName(t.status) << " | " << num(t.deviationMm) << " | "
               << num(t.uncertaintyMm) << " | "
               << (t.caught()        ? "yes"
                   : t.error.empty() ? "**no**"
                                     : "**not seeded**")
               << " |\n";
}

void viewTable(std::ostringstream& md, const VerificationReport& r)
{
    md << "\n## Views\n\n| view | pose | planned landmarks | observed (nominal seats) | frame margin px |\n"
          "|---|---|---|---|---|\n";
    for (const ViewVerification& v : r.views) {
        std::string planned, observed;
        for (const std::string& id : v.landmarks) planned += (planned.empty() ? "" : ", ") + id;
        for (const auto& [id, n] : v.observes)
            observed += (observed.empty() ? "" : ", ") + id + " " + std::to_string(n);
        md << "| " << v.id << " | rot " << num(v.pose.rotationDeg, 6) << "°, decl " << num(v.pose.declinationDeg, 6)
           << "°" << (v.pose.railMm != 0.0 ? ", rail " + num(v.pose.railMm, 6) + " mm" : "") << " | " << planned
           << " | " << observed << " | " << num(v.minFrameMarginPx, 3) << " |\n";
    }
}

} // namespace

json toJson(const VerificationReport& r)
{
    json landmarks = json::array(), views = json::array(), findings = json::array();
    for (const auto& v : r.landmarks) landmarks.push_back(landmarkJson(v));
    for (const auto& v : r.views) views.push_back(viewJson(v));
    for (const auto& f : r.findings) findings.push_back(findingJson(f));
    return {{"part", r.part},
            {"released", r.released},
            {"seats", r.options.seats},
            {"seat_play", {{"shift_mm", r.seatShiftMm}, {"rotation_deg", r.seatRotationDeg}}},
            {"defect_multiples", r.options.defectMultiples},
            {"release_multiple", r.options.releaseMultiple},
            {"uncertainty_ratio_limit", r.options.uncertaintyRatio},
            {"defect_half_width_mm", r.defectHalfWidthMm},
            {"seed", r.options.seed},
            {"nominal_cycles", r.nominalCycles},
            {"nominal_passed", r.nominalPassed},
            {"false_reject_rate", r.falseRejectRate()},
            {"seating_faults", r.seatingFaults},
            {"seat_error_max", {{"shift_mm", r.seatErrorMaxShiftMm}, {"rotation_deg", r.seatErrorMaxRotationDeg}}},
            {"landmarks", landmarks},
            {"views", views},
            {"findings", findings},
            {"phase_ms", r.phaseMs},
            {"inspection_median_ms", r.inspectionMedianMs},
            {"cycle_time_s",
             {{"planned", r.plannedCycleS}, {"twin_median", r.twinCycleMedianS}, {"twin_max", r.twinCycleMaxS}}}};
}

std::string toMarkdown(const VerificationReport& r)
{
    std::ostringstream md;
    md << "# Verification of " << r.part << " on the station's digital twin\n\n"
       << (r.released ? "**Released**: " : "**Not released**: ") << "the nominal part passed at " << r.nominalPassed
       << " of " << r.nominalCycles << " seats (false-reject rate " << num(100.0 * r.falseRejectRate(), 3)
       << " %), seated at random within a shift of " << num(r.seatShiftMm) << " mm and a rotation of "
       << num(r.seatRotationDeg) << "°; defects of " << num(r.options.releaseMultiple)
       << " × tolerance must be caught at every landmark, and U measured must stay within "
       << num(r.options.uncertaintyRatio) << " × the predicted U.\n\n";
    landmarkTable(md, r);
    if (!r.findings.empty()) {
        md << "\n## What fails, and what would fix it\n\n";
        for (const Finding& f : r.findings)
            md << "- **" << f.subject << "** (" << f.test << "): " << f.what << ". Fix: " << f.fixText << ".\n";
    }
    defectTable(md, r);
    viewTable(md, r);
    md << "\n## Time\n\n| phase | s |\n|---|---|\n";
    for (const auto& [phase, ms] : r.phaseMs) md << "| " << phase << " | " << num(ms / 1000.0, 3) << " |\n";
    md << "| inspection per part (median, after the last frame) | " << num(r.inspectionMedianMs / 1000.0, 3) << " |\n";
    return md.str();
}

} // namespace hg::commission
