// Signed sub-voxel deviation (docs/inspection.md, "Sub-voxel deviation"):
// what the 50 % rule of 4.4.2 discards — the grey level across the outline —
// measured where the landmark's surface forms the outline.
#include "hullgauge/inspect/deviation.h"

#include <cmath>

#include "hullgauge/vision/edge.h"

namespace hg::inspect {
namespace {

using geometry::Vec2;
using geometry::Vec3;

// The CAD outline is bisected to 2 px / 2^10 ≈ 0.002 px (0.0001 mm at
// 0.05 mm per pixel, a thirtieth of the edge noise).
constexpr int kBisections = 10;
// The observed edge is searched this far (px) about the CAD outline: a
// deviation up to a few voxels at the stations this is for.
constexpr double kEdgeBandPx = 5.0;
// The CAD outline must pass this close (px) to the landmark's own image: only
// then is it formed by the surface at the landmark, not by a far edge of a
// face seen slightly from the front or by another feature.
constexpr double kOutlineReachPx = 1.0;
// A local feature (a burr, a dent) of half-length ℓ along the line of sight
// is seen ℓ·tan(tilt) short by a view whose line of sight leaves the
// landmark's tangent plane by `tilt`: a type B term per view with this ℓ
// (mm), so the most nearly grazing views weigh most (docs/inspection.md).
constexpr double kFeatureHalfLengthMm = 0.5;
// Step (mm) of the numeric derivative of the projection along the normal.
constexpr double kNormalStepMm = 0.01;
// The edge location's own limit (px, standard, a type B estimate): the
// profile integral is exact for a straight edge; where the outline is formed
// by a faceted concave wall (a 64-facet hole seen along its axis) the
// validation measured biases up to 0.05 px (docs/inspection.md).
constexpr double kMethodPx = 0.05;

bool hitsSolid(const model::Solid& solid, const geometry::CameraModel& camera, const Vec2& pixel)
{
    const geometry::Ray ray = camera.backProject(pixel);
    return solid.firstHit(ray.origin, ray.direction).has_value();
}

/// Outline motion (px) per millimetre of `point` along `normal`, along `u`.
std::optional<double> pixelsPerMm(const geometry::CameraModel& camera, const Vec3& point, const Vec3& normal,
                                  const Vec2& u)
{
    const auto a = camera.project(point + kNormalStepMm * normal), b = camera.project(point - kNormalStepMm * normal);
    if (!a || !b) return std::nullopt;
    return (*a - *b).dot(u) / (2.0 * kNormalStepMm);
}

/// The CAD outline along pixel + t·u within |t| ≤ kOutlineReachPx: the line
/// of sight hits the solid just inside and misses it just outside (two ray
/// casts decide most views at once), then bisection. One crossing is taken;
/// two within a reach of 1 px would be features narrower than the blur.
std::optional<double> cadOutline(const model::Solid& solid, const geometry::CameraModel& camera, const Vec2& pixel,
                                 const Vec2& u)
{
    double in = -kOutlineReachPx, out = kOutlineReachPx;
    if (!hitsSolid(solid, camera, pixel + in * u) || hitsSolid(solid, camera, pixel + out * u)) return std::nullopt;
    for (int k = 0; k < kBisections; ++k) {
        const double mid = 0.5 * (in + out);
        (hitsSolid(solid, camera, pixel + mid * u) ? in : out) = mid;
    }
    return 0.5 * (in + out);
}

/// The seat's uncertainty at `point` along `normal` (mm, standard): the
/// covariance of (rotation vector, shift of the reference point) carried to
/// the point's displacement δX = ω × (X − X_ref) + v.
double alignmentSigma(const align::AlignmentResult& a, const Vec3& point, const Vec3& normal)
{
    if (!a.measured) return 0.0;
    const Vec3 r = point - a.referencePoint;
    Eigen::Matrix<double, 1, 6> J;
    J.head<3>() = r.cross(normal).transpose(); // n · (ω × r) = ω · (r × n)
    J.tail<3>() = normal.transpose();
    return std::sqrt(std::max(0.0, (J * a.covariance * J.transpose())(0, 0)));
}

/// A view's type B term — the method's limit and its tilt — in mm (standard).
double methodSigma(const ViewDeviation& v)
{
    return std::hypot(kMethodPx / v.pxPerMm, v.tiltMm);
}

/// A view's variance: its noise with its type B term beside it.
double viewVariance(const ViewDeviation& v)
{
    return v.sigmaMm * v.sigmaMm + methodSigma(v) * methodSigma(v);
}

} // namespace

const char* toString(DecisionRule rule)
{
    return rule == DecisionRule::Guarded ? "guarded" : "simple";
}

const char* toString(Decision decision)
{
    switch (decision) {
    case Decision::Conforms:
        return "conforms";
    case Decision::Nonconforms:
        return "nonconforms";
    case Decision::Uncertain:
        return "uncertain";
    }
    return "uncertain";
}

// ISO 14253-1: the acceptance zone is the tolerance zone shrunk by U on both
// sides, the rejection zone the outside widened by U; between them nothing is
// proven. The simple rule (ILAC G8's "simple acceptance") takes the value as it is.
Decision decide(double d, double U, double lower, double upper, DecisionRule rule)
{
    if (rule == DecisionRule::Simple) return d >= lower && d <= upper ? Decision::Conforms : Decision::Nonconforms;
    if (d >= lower + U && d <= upper - U) return Decision::Conforms;
    if (d < lower - U || d > upper + U) return Decision::Nonconforms;
    return Decision::Uncertain;
}

DeviationGauge::DeviationGauge(std::shared_ptr<const model::Solid> solid) : solid_(std::move(solid))
{
}

std::optional<ViewDeviation> DeviationGauge::measureInView(const MapLandmark& lm, const SilhouetteView& view) const
{
    const geometry::CameraModel& camera = view.camera;
    if (view.grey.empty()) return std::nullopt;
    const auto pixel = camera.project(lm.position);
    if (!pixel) return std::nullopt;
    const auto a = camera.project(lm.position + kNormalStepMm * lm.normal);
    const auto b = camera.project(lm.position - kNormalStepMm * lm.normal);
    if (!a || !b) return std::nullopt;
    const Vec2 g = (*a - *b) / (2.0 * kNormalStepMm);
    // The surface must move the outline: the normal at most 60° out of the image plane.
    const double depth = (camera.cameraFromPart().apply(lm.position)).z();
    if (!(depth > 0.0) || g.norm() < 0.5 / camera.millimetresPerPixelAt(depth).x()) return std::nullopt;
    const Vec2 u = g.normalized();
    const auto outline = cadOutline(*solid_, camera, *pixel, u);
    if (!outline) return std::nullopt;
    // The surface point that forms the outline there: just inside it, the
    // line of sight's first contact. It must lie on the landmark's surface
    // (within a pixel's worth of its plane), else another feature forms it.
    const geometry::Ray ray = camera.backProject(*pixel + (*outline - 0.05) * u);
    const auto touch = solid_->firstHit(ray.origin, ray.direction);
    if (!touch || std::abs(lm.normal.dot(touch->point - lm.position)) > 1.0 / g.norm()) return std::nullopt;
    const auto scale = pixelsPerMm(camera, touch->point, lm.normal, u);
    if (!scale || *scale < 0.5 * g.norm()) return std::nullopt;
    const vision::EdgeImage image{view.grey, view.threshold, view.objectIsDark};
    const auto edge = vision::findEdge(image, *pixel + *outline * u, u, kEdgeBandPx);
    if (!edge) return std::nullopt;
    // A surface moved inward is seen from its outer side: its outline runs
    // along the boundary farthest along the line of sight — where the line
    // just inside the nominal outline leaves the solid — deeper than where it
    // enters, and a millimetre makes fewer pixels there (docs/inspection.md).
    double pxPerMm = *scale;
    if (edge->offset < 0.0) {
        const auto exit = solid_->firstHit(touch->point + 1e-6 * ray.direction, ray.direction);
        if (exit && std::abs(lm.normal.dot(exit->point - lm.position)) <= 1.0 / g.norm())
            if (const auto far = pixelsPerMm(camera, exit->point, lm.normal, u); far && *far >= 0.5 * g.norm())
                pxPerMm = *far;
    }
    const double sinTilt = std::abs(lm.normal.dot((lm.position - camera.centre()).normalized()));
    const double tilt = kFeatureHalfLengthMm * sinTilt / std::sqrt(std::max(1e-12, 1.0 - sinTilt * sinTilt));
    return ViewDeviation{{}, edge->offset / pxPerMm, edge->sigmaPx / pxPerMm, pxPerMm, tilt};
}

Deviation DeviationGauge::measure(const MapLandmark& lm, const std::vector<SilhouetteView>& views,
                                  const std::vector<std::string>& viewIds,
                                  const align::AlignmentResult* alignment) const
{
    Deviation out;
    double sumW = 0.0, sumWx = 0.0, methodW = 0.0;
    for (std::size_t k = 0; k < views.size(); ++k) {
        auto v = measureInView(lm, views[k]);
        if (!v) continue;
        v->viewId = k < viewIds.size() ? viewIds[k] : "v" + std::to_string(k);
        // Each view weighs by its noise with the method's limit and its tilt beside it.
        const double w = 1.0 / viewVariance(*v);
        sumW += w;
        sumWx += w * v->deviationMm;
        methodW += w * methodSigma(*v);
        out.views.push_back(*v);
    }
    if (out.views.empty()) {
        out.reason = "no view sees the landmark on its outline with a clean edge";
        return out;
    }
    out.measured = true;
    out.deviationMm = sumWx / sumW;
    double noiseVar = 0.0, chi2 = 0.0;
    for (const ViewDeviation& v : out.views) {
        const double w = 1.0 / viewVariance(v) / sumW;
        noiseVar += w * w * v.sigmaMm * v.sigmaMm;
        const double d = v.deviationMm - out.deviationMm;
        chi2 += d * d / viewVariance(v);
    }
    out.budget.edgeNoise = std::sqrt(noiseVar);
    // The method's limit is systematic per view geometry: not reduced by averaging views.
    out.budget.method = methodW / sumW;
    // Views that disagree beyond their noise (Birge ratio > 1) widen the combined value's uncertainty.
    const std::size_t n = out.views.size();
    if (n > 1) {
        const double birge2 = chi2 / static_cast<double>(n - 1);
        if (birge2 > 1.0) out.budget.views = std::sqrt((birge2 - 1.0) / sumW);
    }
    if (alignment) out.budget.alignment = alignmentSigma(*alignment, lm.position, lm.normal);
    const auto& u = out.budget;
    out.uncertaintyMm = 2.0 * std::sqrt(u.edgeNoise * u.edgeNoise + u.method * u.method + u.views * u.views +
                                        u.alignment * u.alignment);
    return out;
}

nlohmann::json toJson(const Deviation& d)
{
    nlohmann::json views = nlohmann::json::array();
    for (const ViewDeviation& v : d.views)
        views.push_back({{"view", v.viewId},
                         {"deviation_mm", v.deviationMm},
                         {"sigma_mm", v.sigmaMm},
                         {"px_per_mm", v.pxPerMm},
                         {"tilt_mm", v.tiltMm}});
    return {{"measured", d.measured},
            {"deviation_mm", d.measured ? nlohmann::json(d.deviationMm) : nlohmann::json(nullptr)},
            {"uncertainty_mm", d.measured ? nlohmann::json(d.uncertaintyMm) : nlohmann::json(nullptr)},
            {"budget_mm",
             {{"edge_noise", d.budget.edgeNoise},
              {"method", d.budget.method},
              {"views", d.budget.views},
              {"alignment", d.budget.alignment}}},
            {"views", views},
            {"reason", d.reason}};
}

} // namespace hg::inspect
