// The rail procedure of dissertation 4.3 for a telecentric camera
// (include/hullgauge/calib/telecentric.h, docs/telecentric-calibration.md).
// Through a telecentric lens a point moved along the rail keeps its size and
// no image point stays fixed: every point's image moves by the same
// (fx·a_x, fy·a_y) per mm of rail, so the tracks are parallel and their
// common motion is the rail's direction relative to the optical axis.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "hullgauge/calib/telecentric.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"
#include "least_squares.h"

namespace hg::calib {
namespace {

using geometry::Vec2;
using geometry::Vec3;

constexpr double kDeg = 180.0 / 3.14159265358979323846;

/// The tracks that move the rail: at least two different readings each.
std::vector<const std::vector<RailSample>*> usableTracks(const std::vector<std::vector<RailSample>>& tracks)
{
    std::vector<const std::vector<RailSample>*> usable;
    for (const auto& t : tracks) {
        if (t.size() < 2) continue;
        const auto [lo, hi] = std::minmax_element(
            t.begin(), t.end(), [](const RailSample& a, const RailSample& b) { return a.rangeMm < b.rangeMm; });
        if (hi->rangeMm > lo->rangeMm) usable.push_back(&t);
    }
    return usable;
}

} // namespace

TelecentricRailAxis calibrateTelecentricRail(const std::vector<std::vector<RailSample>>& tracks,
                                             const geometry::Intrinsics& camera, const std::string& field)
{
    const auto usable = usableTracks(tracks);
    if (usable.empty())
        throw InputError("", field,
                         "no point was seen at two different rail readings: the rail's direction needs "
                         "the target moved along the rail");
    const double fx = camera.K(0, 0), fy = camera.K(1, 1);
    if (!(fx > 0.0) || !(fy > 0.0)) throw InputError("", field, "the camera's fx and fy must be positive (px/mm)");

    // Readings relative to their mean, so each track's point P_j is the one
    // at the mean reading and the direction's start is independent of it.
    double sum = 0.0, lo = usable.front()->front().rangeMm, hi = lo;
    int count = 0;
    for (const auto* t : usable)
        for (const auto& s : *t) {
            sum += s.rangeMm;
            lo = std::min(lo, s.rangeMm);
            hi = std::max(hi, s.rangeMm);
            ++count;
        }
    const double mean = sum / count, travel = hi - lo;

    // Parameters scaled so that a unit step moves the image by about a pixel:
    // a_x, a_y by 1/(f·travel), each P_j by 1/f.
    const double f = std::max(fx, fy);
    const double scaleA = 1.0 / (f * travel), scaleP = 1.0 / f;
    Eigen::VectorXd x0(2 + 2 * static_cast<Eigen::Index>(usable.size()));
    x0.head<2>().setZero();
    for (std::size_t j = 0; j < usable.size(); ++j) {
        const Vec2 first = usable[j]->front().pixel;
        x0[2 + 2 * static_cast<Eigen::Index>(j)] = (first.x() - camera.K(0, 2)) / fx / scaleP;
        x0[3 + 2 * static_cast<Eigen::Index>(j)] = (first.y() - camera.K(1, 2)) / fy / scaleP;
    }
    auto residuals = [&](const Eigen::VectorXd& x, Eigen::VectorXd& r) {
        r.resize(2 * count);
        const double ax = x[0] * scaleA, ay = x[1] * scaleA;
        Eigen::Index k = 0;
        for (std::size_t j = 0; j < usable.size(); ++j) {
            const auto base = 2 + 2 * static_cast<Eigen::Index>(j);
            for (const auto& s : *usable[j]) {
                const double d = s.rangeMm - mean;
                const Vec3 p(x[base] * scaleP + d * ax, x[base + 1] * scaleP + d * ay, 0.0);
                const Vec2 px = projectTelecentric(camera, p);
                r[k++] = px.x() - s.pixel.x();
                r[k++] = px.y() - s.pixel.y();
            }
        }
    };
    const auto fit = detail::levenbergMarquardt(residuals, x0, Eigen::VectorXd::Constant(x0.size(), 1e-4));

    TelecentricRailAxis axis;
    const double ax = fit.x[0] * scaleA, ay = fit.x[1] * scaleA, lateral = std::hypot(ax, ay);
    if (!(lateral < 1.0))
        throw InputError("", field, "the tracks move faster than the rail: check the readings' unit (mm)");
    axis.direction = Vec3(ax, ay, std::sqrt(1.0 - lateral * lateral));
    axis.angleToAxisDeg = std::asin(lateral) * kDeg;
    axis.azimuthDeg = std::atan2(ay, ax) * kDeg;
    axis.shiftPxPerMm = Vec2(fx * ax, fy * ay); // at the image centre; distortion changes it off-centre
    if (fit.covariance.allFinite()) {
        const Eigen::Matrix2d cov = fit.covariance.topLeftCorner<2, 2>() * scaleA * scaleA;
        axis.stdDevAx = std::sqrt(cov(0, 0));
        axis.stdDevAy = std::sqrt(cov(1, 1));
        // d(angle)/d(a_x, a_y) = (a_x, a_y) / (|a_xy| cos angle); along the
        // direction of the larger variance where the rail is on the axis.
        Eigen::Vector2d g =
            lateral > 1e-12 ? Eigen::Vector2d(ax, ay) / (lateral * axis.direction.z())
                            : Eigen::Vector2d(cov(0, 0) >= cov(1, 1) ? 1.0 : 0.0, cov(0, 0) >= cov(1, 1) ? 0.0 : 1.0);
        axis.stdDevAngleDeg = std::sqrt(g.dot(cov * g)) * kDeg;
    }
    axis.rmsPx = std::sqrt(fit.residuals.squaredNorm() / count);
    axis.tracks = static_cast<int>(usable.size());
    axis.observations = count;
    hg::log::category("calib")->info("telecentric rail: {:.4f} deg from the optical axis, azimuth {:.2f} deg, RMS "
                                     "{:.4f} px",
                                     axis.angleToAxisDeg, axis.azimuthDeg, axis.rmsPx);
    return axis;
}

std::vector<std::vector<RailSample>> loadTelecentricRailTracks(const std::filesystem::path& file)
{
    const auto root = ConfigNode::loadFile(file);
    if (!root.isMap()) root.fail("expected a map with tracks");
    root.allowOnlyKeys({"tracks", "units", "note"});
    if (auto u = root.optional("units"); u && u->asString() != "mm")
        u->fail("only 'mm' is supported (rail readings in millimetres)");
    const auto list = root["tracks"];
    if (!list.isSequence()) list.fail("expected a list of tracks, each a list of {range_mm, pixel}");
    std::vector<std::vector<RailSample>> tracks;
    for (const auto& track : list.items()) tracks.push_back(RailObservations::parseTrack(track));
    return tracks;
}

std::string formatTelecentricRailReport(const TelecentricRailAxis& a)
{
    std::ostringstream s;
    char line[256];
    s << "telecentric rail (" << a.tracks << " tracks, " << a.observations << " observations)\n";
    std::snprintf(line, sizeof line, "  rail direction (camera frame)  [%.6f, %.6f, %.6f]\n", a.direction.x(),
                  a.direction.y(), a.direction.z());
    s << line;
    std::snprintf(line, sizeof line, "  angle to the optical axis      %.4f deg (std dev %.4f)\n", a.angleToAxisDeg,
                  a.stdDevAngleDeg);
    s << line;
    std::snprintf(line, sizeof line, "  azimuth in the image           %.2f deg (from +x towards +y)\n", a.azimuthDeg);
    s << line;
    std::snprintf(line, sizeof line, "  a_x, a_y                       %.6f, %.6f (std dev %.2g, %.2g)\n",
                  a.direction.x(), a.direction.y(), a.stdDevAx, a.stdDevAy);
    s << line;
    std::snprintf(line, sizeof line, "  image shift per mm of rail     %.4f, %.4f px\n", a.shiftPxPerMm.x(),
                  a.shiftPxPerMm.y());
    s << line;
    std::snprintf(line, sizeof line, "  RMS residual                   %.4f px\n", a.rmsPx);
    s << line;
    return s.str();
}

} // namespace hg::calib
