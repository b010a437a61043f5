#include "hullgauge/vision/outline.h"

#include "hullgauge/common/error.h"
#include "hullgauge/sim/renderer.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <spdlog/fmt/fmt.h>

namespace hg::vision {
namespace {

/// The camera whose sensor is `window` of `camera`'s: a crop moves the principal point by its corner (as the
/// renderer's own windowed render does; the distortion acts on normalised coordinates, before K).
geometry::CameraModel croppedCamera(const geometry::CameraModel& camera, const cv::Rect& window)
{
    geometry::Intrinsics cropped = camera.intrinsics();
    cropped.K(0, 2) -= window.x;
    cropped.K(1, 2) -= window.y;
    cropped.imageSize = window.size();
    return {cropped, camera.cameraFromPart()};
}

/// A traced pixel centre moved onto the coverage's ½ crossing: along the outward normal (down the coverage
/// gradient) by coverage − ½, exact for a straight edge through the pixel.
cv::Point2d refined(const cv::Point& p, const cv::Mat& coverage, const cv::Mat& gx, const cv::Mat& gy)
{
    const double dx = gx.at<float>(p), dy = gy.at<float>(p);
    const double norm = std::hypot(dx, dy);
    if (norm < 1e-9) return {double(p.x), double(p.y)};
    const double along = std::clamp(coverage.at<float>(p) - 0.5, 0.0, 0.5);
    return {p.x - along * dx / norm, p.y - along * dy / norm};
}

/// `points` simplified by Douglas–Peucker within `tolerance` pixels.
std::vector<cv::Point2d> simplified(const std::vector<cv::Point2d>& points, bool closed, double tolerance)
{
    if (tolerance <= 0.0 || points.size() < 3) return points;
    std::vector<cv::Point2f> in(points.begin(), points.end()), out;
    cv::approxPolyDP(in, out, tolerance, closed);
    return {out.begin(), out.end()};
}

/// One traced contour as polylines: whole, or cut where it runs along the frame's border (the part goes on
/// beyond the frame there: no outline).
void addContour(const std::vector<cv::Point>& contour, const cv::Mat& coverage, const cv::Mat& gx, const cv::Mat& gy,
                double tolerance, std::vector<OutlinePolyline>& out)
{
    const cv::Size size = coverage.size();
    const auto onBorder = [&](const cv::Point& p) {
        return p.x == 0 || p.y == 0 || p.x == size.width - 1 || p.y == size.height - 1;
    };
    const auto cut = std::find_if(contour.begin(), contour.end(), onBorder);
    if (cut == contour.end()) {
        std::vector<cv::Point2d> points;
        for (const cv::Point& p : contour) points.push_back(refined(p, coverage, gx, gy));
        if (points.size() >= 3) out.push_back({simplified(points, true, tolerance), true});
        return;
    }
    // Walked from a border pixel round to it: every run between border pixels is an open polyline.
    const std::size_t start = static_cast<std::size_t>(cut - contour.begin());
    std::vector<cv::Point2d> run;
    for (std::size_t i = 1; i <= contour.size(); ++i) {
        const cv::Point& p = contour[(start + i) % contour.size()];
        if (!onBorder(p)) {
            run.push_back(refined(p, coverage, gx, gy));
            continue;
        }
        if (run.size() >= 2) out.push_back({simplified(run, false, tolerance), false});
        run.clear();
    }
}

} // namespace

std::vector<OutlinePolyline> projectedOutline(const model::TriangleMesh& mesh, const geometry::CameraModel& camera,
                                              const OutlineOptions& options)
{
    const cv::Rect sensor(cv::Point(0, 0), camera.imageSize());
    const cv::Rect window = options.window.empty() ? sensor : options.window;
    if ((window & sensor) != window)
        throw ArgumentError(fmt::format("outline window {}x{}+{}+{} is not within the {}x{} sensor", window.width,
                                        window.height, window.x, window.y, sensor.width, sensor.height));
    std::vector<OutlinePolyline> out;
    if (mesh.empty() || window.empty()) return out;
    const sim::SilhouetteRenderer renderer({mesh});
    const cv::Mat coverage = renderer.coverage(croppedCamera(camera, window));
    cv::Mat gx, gy;
    cv::Sobel(coverage, gx, CV_32F, 1, 0, 3, 1.0, 0.0, cv::BORDER_REPLICATE);
    cv::Sobel(coverage, gy, CV_32F, 0, 1, 3, 1.0, 0.0, cv::BORDER_REPLICATE);
    cv::Mat mask = coverage >= 0.5f;
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(mask, contours, cv::RETR_LIST, cv::CHAIN_APPROX_NONE);
    for (const auto& contour : contours) addContour(contour, coverage, gx, gy, options.simplifyPx, out);
    return out;
}

} // namespace hg::vision
