// The capability check (docs/inspection.md, "Capability").
#include "hullgauge/inspect/capability.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "hullgauge/common/format.h"
#include "hullgauge/inspect/inspector.h"

namespace hg::inspect {

std::vector<LandmarkCapability> assessCapability(const std::vector<MapLandmark>& landmarks, double voxelMm,
                                                 const DeviationGauge* gauge,
                                                 const std::vector<geometry::CameraModel>& cameras,
                                                 const geometry::ImageQuality& quality)
{
    std::vector<LandmarkCapability> out;
    out.reserve(landmarks.size());
    for (const MapLandmark& lm : landmarks) {
        LandmarkCapability c;
        c.id = lm.id;
        c.zoneMm = lm.upperMm() - lm.lowerMm();
        if (gauge) c.prediction = gauge->expected(lm, cameras, quality);
        c.bracket = !c.prediction.measured;
        c.views = static_cast<int>(c.prediction.views.size());
        // The bracket: one voxel wide, its half-width holds the offset.
        c.expectedMm = c.bracket ? 0.5 * voxelMm : c.prediction.uncertaintyMm;
        c.capable = c.zoneMm >= kTestUncertaintyRatio * c.expectedMm;
        out.push_back(std::move(c));
    }
    return out;
}

double capabilityUsed(const std::vector<LandmarkCapability>& assessment, double plannedSigmaPx, double sigmaPx)
{
    constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
    if (!(plannedSigmaPx > 0.0) || !(sigmaPx > 0.0) || !std::isfinite(plannedSigmaPx) || !std::isfinite(sigmaPx))
        return kNone;
    const double scale = sigmaPx / plannedSigmaPx;
    double worst = kNone;
    for (const LandmarkCapability& c : assessment) {
        if (!c.capable || !(c.zoneMm > 0.0)) continue;
        double u = c.expectedMm;
        if (!c.bracket) {
            // Each view's noise term scaled, combined again as the gauge combines them (its
            // weights follow the views' variances: docs/inspection.md "Uncertainty budget").
            std::vector<ViewDeviation> views = c.prediction.views;
            for (ViewDeviation& v : views) v.sigmaMm *= scale;
            u = combine(std::move(views), c.prediction.budget.alignment).uncertaintyMm;
        }
        const double used = kTestUncertaintyRatio * u / c.zoneMm;
        worst = std::isnan(worst) ? used : std::max(worst, used);
    }
    return worst;
}

std::string describe(const LandmarkCapability& c)
{
    const std::string basis =
        c.bracket ? "the voxel bracket"
                  : "sub-voxel deviation, " + std::to_string(c.views) + (c.views == 1 ? " view" : " views");
    const std::string figures = "4 U = 4 × " + formatNumber(c.expectedMm, 3) + " mm (" + basis + ")";
    if (c.capable) return "landmark " + c.id + ": tolerance zone " + formatNumber(c.zoneMm, 4) + " mm ≥ " + figures;
    return "landmark " + c.id + ": tolerance zone " + formatNumber(c.zoneMm, 4) + " mm is narrower than " + figures +
           ": this station cannot prove it (test uncertainty ratio 4:1)";
}

std::string describe(const std::vector<LandmarkCapability>& capabilities)
{
    std::string text;
    for (const LandmarkCapability& c : capabilities) text += (text.empty() ? "" : "; ") + describe(c);
    return text;
}

nlohmann::json toJson(const LandmarkCapability& c)
{
    return {{"id", c.id},
            {"zone_mm", c.zoneMm},
            {"expected_uncertainty_mm", c.expectedMm},
            {"basis", c.bracket ? "bracket" : "deviation"},
            {"views", c.views},
            {"ratio", c.expectedMm > 0.0 ? nlohmann::json(c.zoneMm / c.expectedMm) : nlohmann::json(nullptr)},
            {"capable", c.capable},
            {"budget_mm", c.bracket ? nlohmann::json(nullptr) : toJson(c.prediction)["budget_mm"]}};
}

} // namespace hg::inspect
