// Signed sub-voxel deviation (docs/inspection.md, "Sub-voxel deviation"):
// what the 50 % rule of 4.4.2 discards — the grey level across the outline —
// measured where the landmark's surface forms the outline.
#include "hullgauge/inspect/deviation.h"

#include <cmath>
#include <utility>

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
// The stored outline is taken where lines of sight this far (px) either side
// of it hit and miss the solid: 0.001 mm at 0.05 mm per pixel, a fiftieth of
// the method's limit.
constexpr double kVerifyPx = 0.02;
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

/// The image of the landmark's normal (px per mm): nullopt when the surface
/// cannot move the outline — the normal more than 60° out of the image plane.
std::optional<Vec2> normalImage(const geometry::CameraModel& camera, const MapLandmark& lm)
{
    const auto a = camera.project(lm.position + kNormalStepMm * lm.normal);
    const auto b = camera.project(lm.position - kNormalStepMm * lm.normal);
    if (!a || !b) return std::nullopt;
    const Vec2 g = (*a - *b) / (2.0 * kNormalStepMm);
    const double depth = camera.depthOf(lm.position);
    if (!camera.depthInFront(depth) || g.norm() < 0.5 / camera.millimetresPerPixelAt(depth).x()) return std::nullopt;
    return g;
}

struct CadOutline {
    double at = 0.0; ///< along u from the landmark's pixel, px
    Vec3 graze;      ///< where the last line of sight inside it touches the solid
};

/// The CAD outline along pixel + t·u within |t| ≤ kOutlineReachPx: the line
/// of sight hits the solid just inside and misses it just outside (two ray
/// casts decide most views at once), then bisection. One crossing is taken;
/// two within a reach of 1 px would be features narrower than the blur.
std::optional<CadOutline> cadOutline(const model::Solid& solid, const geometry::CameraModel& camera, const Vec2& pixel,
                                     const Vec2& u)
{
    double in = -kOutlineReachPx, out = kOutlineReachPx;
    if (!hitsSolid(solid, camera, pixel + in * u) || hitsSolid(solid, camera, pixel + out * u)) return std::nullopt;
    for (int k = 0; k < kBisections; ++k) {
        const double mid = 0.5 * (in + out);
        (hitsSolid(solid, camera, pixel + mid * u) ? in : out) = mid;
    }
    const geometry::Ray ray = camera.backProject(pixel + in * u);
    const auto hit = solid.firstHit(ray.origin, ray.direction);
    if (!hit) return std::nullopt;
    return CadOutline{0.5 * (in + out), hit->point};
}

/// Where the outline runs in `camera`, from the stored points: the
/// outermost (along u) of the grazing chord's ends first, then the other,
/// each taken only where two lines of sight kVerifyPx either side of it hit
/// and miss the solid — the outline then lies within kVerifyPx of it.
/// nullopt when neither lies on this camera's outline.
std::optional<Vec2> verifiedStart(const model::Solid& solid, const geometry::CameraModel& camera,
                                  const OutlinePoint& outline, const Vec2& u)
{
    std::optional<Vec2> candidates[2] = {camera.project(outline.graze), std::nullopt};
    if (outline.grazeExit) candidates[1] = camera.project(*outline.grazeExit);
    if (candidates[0] && candidates[1] && (*candidates[1] - *candidates[0]).dot(u) > 0.0)
        std::swap(candidates[0], candidates[1]);
    for (const auto& c : candidates)
        if (c && hitsSolid(solid, camera, *c - kVerifyPx * u) && !hitsSolid(solid, camera, *c + kVerifyPx * u))
            return c;
    return std::nullopt;
}

} // namespace

std::optional<cv::Rect> edgeReadRect(const geometry::CameraModel& camera, const MapLandmark& lm, double marginPx)
{
    const auto pixel = camera.project(lm.position);
    const auto g = normalImage(camera, lm);
    if (!pixel || !g) return std::nullopt;
    const Vec2 u = g->normalized();
    // The outline starts within kOutlineReachPx of the landmark's image along u.
    const vision::EdgeReach reach = vision::findEdgeReach(kEdgeBandPx);
    const Vec2 a = *pixel - (kOutlineReachPx + reach.inside) * u;
    const Vec2 b = *pixel + (kOutlineReachPx + reach.outside) * u;
    const double pad = reach.lateral + marginPx;
    const int c0 = static_cast<int>(std::floor(std::min(a.x(), b.x()) - pad));
    const int r0 = static_cast<int>(std::floor(std::min(a.y(), b.y()) - pad));
    const int c1 = static_cast<int>(std::ceil(std::max(a.x(), b.x()) + pad));
    const int r1 = static_cast<int>(std::ceil(std::max(a.y(), b.y()) + pad));
    return cv::Rect(cv::Point(c0, r0), cv::Point(c1 + 1, r1 + 1));
}

namespace {

/// A local feature of half-length ℓ seen ℓ·tan(tilt) short (mm, standard).
double tiltMm(const geometry::CameraModel& camera, const MapLandmark& lm)
{
    const double sinTilt = std::abs(lm.normal.dot(camera.lineOfSight(lm.position)));
    return kFeatureHalfLengthMm * sinTilt / std::sqrt(std::max(1e-12, 1.0 - sinTilt * sinTilt));
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

/// A view's type B terms — the method's limit, its tilt and the calibration
/// — in mm (standard). They are systematic for a view's geometry.
double systematicSigma(const ViewDeviation& v)
{
    return std::sqrt(kMethodPx * kMethodPx / (v.pxPerMm * v.pxPerMm) + v.tiltMm * v.tiltMm +
                     v.calibrationMm * v.calibrationMm);
}

/// A view's variance: its noise with its type B terms beside it.
double viewVariance(const ViewDeviation& v)
{
    return v.sigmaMm * v.sigmaMm + systematicSigma(v) * systematicSigma(v);
}

} // namespace

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

// The views combined (docs/inspection.md, "Uncertainty budget"): a weighted
// mean by each view's noise and type B terms; the type B terms are
// systematic per view geometry, so their weighted mean — not a reduced one —
// enters the budget; views that disagree beyond their variances (Birge ratio
// over 1) widen it.
Deviation combine(std::vector<ViewDeviation> views, double alignmentSigmaMm)
{
    Deviation out;
    out.views = std::move(views);
    if (out.views.empty()) {
        out.reason = "no view sees the landmark on its outline with a clean edge";
        return out;
    }
    double sumW = 0.0, sumWx = 0.0, methodW = 0.0, calibrationW = 0.0;
    for (const ViewDeviation& v : out.views) {
        const double w = 1.0 / viewVariance(v);
        sumW += w;
        sumWx += w * v.deviationMm;
        methodW += w * std::hypot(kMethodPx / v.pxPerMm, v.tiltMm);
        calibrationW += w * v.calibrationMm;
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
    DeviationBudget& u = out.budget;
    u.edgeNoise = std::sqrt(noiseVar);
    u.method = methodW / sumW;
    u.calibration = calibrationW / sumW;
    if (const std::size_t n = out.views.size(); n > 1) {
        const double birge2 = chi2 / static_cast<double>(n - 1);
        if (birge2 > 1.0) u.views = std::sqrt((birge2 - 1.0) / sumW);
    }
    u.alignment = alignmentSigmaMm;
    out.uncertaintyMm = 2.0 * std::sqrt(u.edgeNoise * u.edgeNoise + u.method * u.method + u.views * u.views +
                                        u.alignment * u.alignment + u.calibration * u.calibration);
    return out;
}

DeviationGauge::DeviationGauge(std::shared_ptr<const model::Solid> solid, geometry::CalibrationUncertainty calibration)
    : solid_(std::move(solid)), calibration_(calibration)
{
}

// The calibration's own uncertainty where the outline is predicted: the
// intrinsics' standard deviations carried through the projection to the
// outline's image along u (independent parameters: the calibration reports
// no correlations), and the fixture model's residual, one image direction's
// share of it (docs/inspection.md, "Uncertainty budget").
double DeviationGauge::calibrationSigma(const geometry::CameraModel& camera, const Vec3& point, const Vec2& u,
                                        double pxPerMm) const
{
    if (!calibration_.recorded()) return 0.0;
    const auto J = camera.intrinsicsJacobian(point);
    double varPx = 0.0;
    for (int i = 0; J && i < 9; ++i) {
        const double along = u.dot(J->col(i)) * calibration_.intrinsicsStdDev[static_cast<std::size_t>(i)];
        varPx += along * along;
    }
    const double fixture = calibration_.fixtureRmsMm / std::sqrt(2.0);
    return std::sqrt(varPx / (pxPerMm * pxPerMm) + fixture * fixture);
}

std::optional<OutlinePoint> DeviationGauge::outlineAt(const MapLandmark& lm, const geometry::CameraModel& camera) const
{
    const auto pixel = camera.project(lm.position);
    const auto g = normalImage(camera, lm);
    if (!pixel || !g) return std::nullopt;
    const Vec2 u = g->normalized();
    const auto outline = cadOutline(*solid_, camera, *pixel, u);
    if (!outline) return std::nullopt;
    // The surface point that forms the outline there: just inside it, the
    // line of sight's first contact. It must lie on the landmark's surface
    // (within a pixel's worth of its plane), else another feature forms it.
    const double reach = 1.0 / g->norm();
    const geometry::Ray ray = camera.backProject(*pixel + (outline->at - 0.05) * u);
    const auto touch = solid_->firstHit(ray.origin, ray.direction);
    if (!touch || std::abs(lm.normal.dot(touch->point - lm.position)) > reach) return std::nullopt;
    const auto scale = pixelsPerMm(camera, touch->point, lm.normal, u);
    if (!scale || *scale < 0.5 * g->norm()) return std::nullopt;
    OutlinePoint point{outline->graze, std::nullopt, touch->point, std::nullopt};
    const Vec3 along = camera.lineOfSight(outline->graze);
    const auto grazeExit = solid_->firstHit(outline->graze + 1e-6 * along, along);
    if (grazeExit && std::abs(lm.normal.dot(grazeExit->point - lm.position)) <= reach)
        point.grazeExit = grazeExit->point;
    // Where that line of sight leaves the solid: the boundary a surface moved
    // inward is seen by (measureInView).
    const auto exit = solid_->firstHit(touch->point + 1e-6 * ray.direction, ray.direction);
    if (exit && std::abs(lm.normal.dot(exit->point - lm.position)) <= reach) point.exit = exit->point;
    return point;
}

ViewOutlines DeviationGauge::outlines(const std::vector<MapLandmark>& landmarks,
                                      const geometry::CameraModel& camera) const
{
    ViewOutlines out;
    out.landmarks.reserve(landmarks.size());
    for (const MapLandmark& lm : landmarks) out.landmarks.push_back(outlineAt(lm, camera));
    return out;
}

// The per-cycle half of the step: the stored outline points projected
// through the view's camera as inspected, the image's edge beside them.
std::optional<ViewDeviation> DeviationGauge::measureInView(const MapLandmark& lm, const SilhouetteView& view,
                                                           const OutlinePoint& stored) const
{
    const geometry::CameraModel& camera = view.camera;
    if (view.grey.empty()) return std::nullopt;
    const auto g = normalImage(camera, lm);
    if (!g) return std::nullopt;
    const Vec2 u = g->normalized();
    // The stored points, verified on this camera's own outline; where the
    // seat moved an outline they do not follow (a face or a ruled wall seen
    // edge-on), the outline is found again (docs/inspection.md).
    // The stored surface points still give the scale where it is formed.
    auto start = verifiedStart(*solid_, camera, stored, u);
    if (!start) {
        const auto pixel = camera.project(lm.position);
        const auto found = pixel ? cadOutline(*solid_, camera, *pixel, u) : std::nullopt;
        if (!found) return std::nullopt;
        start = camera.project(found->graze);
        if (!start) return std::nullopt;
    }
    const OutlinePoint& outline = stored;
    const auto scale = pixelsPerMm(camera, outline.touch, lm.normal, u);
    if (!scale || *scale < 0.5 * g->norm()) return std::nullopt;
    const vision::EdgeImage image{view.grey, view.threshold, view.objectIsDark, view.origin, camera.imageSize()};
    const auto edge = vision::findEdge(image, *start, u, kEdgeBandPx);
    if (!edge) return std::nullopt;
    // A surface moved inward is seen from its outer side: its outline runs
    // along the boundary farthest along the line of sight — where the line
    // just inside the nominal outline leaves the solid — deeper than where it
    // enters, and a millimetre makes fewer pixels there (docs/inspection.md).
    double pxPerMm = *scale;
    if (edge->offset < 0.0 && outline.exit)
        if (const auto far = pixelsPerMm(camera, *outline.exit, lm.normal, u); far && *far >= 0.5 * g->norm())
            pxPerMm = *far;
    ViewDeviation v{{}, edge->offset / pxPerMm, edge->sigmaPx / pxPerMm, pxPerMm, tiltMm(camera, lm), 0.0};
    v.calibrationMm = calibrationSigma(camera, outline.graze, u, pxPerMm);
    return v;
}

Deviation DeviationGauge::measure(std::size_t index, const MapLandmark& lm, const std::vector<SilhouetteView>& views,
                                  const std::vector<std::string>& viewIds,
                                  const align::AlignmentResult* alignment) const
{
    std::vector<ViewDeviation> measured;
    for (std::size_t k = 0; k < views.size(); ++k) {
        const SilhouetteView& view = views[k];
        // A view prepared without outline points (a caller's own) has them found now.
        std::optional<OutlinePoint> own;
        const std::optional<OutlinePoint>* outline = nullptr;
        if (view.outlines && index < view.outlines->landmarks.size()) {
            outline = &view.outlines->landmarks[index];
        } else {
            own = outlineAt(lm, view.camera);
            outline = &own;
        }
        if (!*outline) continue;
        auto v = measureInView(lm, view, **outline);
        if (!v) continue;
        v->viewId = k < viewIds.size() ? viewIds[k] : "v" + std::to_string(k);
        measured.push_back(*v);
    }
    const double seat = alignment ? alignmentSigma(*alignment, lm.position, lm.normal) : 0.0;
    return combine(std::move(measured), seat);
}

// The capability check's prediction (docs/inspection.md, "Capability"): each
// camera's share as measureInView would have it on a nominal part — the
// scale where the outline is formed (the smaller of entry and exit, for a
// surface that may have moved either way), the edge noise the image quality
// predicts for an edge centred in its window, the method, tilt and
// calibration terms.
Deviation DeviationGauge::expected(const MapLandmark& lm, const std::vector<geometry::CameraModel>& cameras,
                                   const geometry::ImageQuality& quality) const
{
    std::vector<ViewDeviation> views;
    const double edgePx = vision::edgeSigmaPx(quality.noiseGrey, quality.contrastGrey);
    for (std::size_t k = 0; k < cameras.size(); ++k) {
        const geometry::CameraModel& camera = cameras[k];
        const auto outline = outlineAt(lm, camera);
        const auto g = normalImage(camera, lm);
        if (!outline || !g) continue;
        const Vec2 u = g->normalized();
        double pxPerMm = pixelsPerMm(camera, outline->touch, lm.normal, u).value_or(0.0);
        if (outline->exit)
            if (const auto far = pixelsPerMm(camera, *outline->exit, lm.normal, u); far && *far >= 0.5 * g->norm())
                pxPerMm = std::min(pxPerMm, *far);
        if (!(pxPerMm > 0.0)) continue;
        ViewDeviation v{"v" + std::to_string(k), 0.0, edgePx / pxPerMm, pxPerMm, tiltMm(camera, lm), 0.0};
        v.calibrationMm = calibrationSigma(camera, outline->graze, u, pxPerMm);
        views.push_back(v);
    }
    return combine(std::move(views), 0.0);
}

} // namespace hg::inspect
