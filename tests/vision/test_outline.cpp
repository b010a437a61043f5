// The nominal outline against the analytic one: a box seen through a
// pinhole camera has the convex hull of its projected corners as its outline
// (projected here with cv::projectPoints, independent of the camera model and
// the renderer); every traced vertex must lie within a pixel of the hull's
// boundary, and every point of the hull's boundary within a pixel of the traced
// polyline (docs/hmi.md, "Reject views").
#include "hullgauge/common/error.h"
#include "hullgauge/geometry/camera.h"
#include "hullgauge/model/primitives.h"
#include "hullgauge/vision/outline.h"

#include <Eigen/Core> // before opencv2/core/eigen.hpp
#include <algorithm>
#include <array>
#include <gtest/gtest.h>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>

namespace hg::vision {
namespace {

using geometry::CameraModel;
using geometry::Intrinsics;
using geometry::RigidTransform;
using geometry::Vec3;

const Vec3 kLo(-20, -15, -10), kHi(25, 15, 12);

/// A 640×480 camera 200 mm from the part, looking at it obliquely (three faces seen: a hexagonal outline).
CameraModel obliqueCamera()
{
    Intrinsics in;
    in.K << 900, 0, 319.5, 0, 900, 239.5, 0, 0, 1;
    in.imageSize = {640, 480};
    const RigidTransform turn =
        RigidTransform::rotation(Vec3(1, 0, 0), 35.0) * RigidTransform::rotation(Vec3(0, 1, 0), -28.0);
    return CameraModel(in, RigidTransform::translation(Vec3(3, -2, 200)) * turn);
}

/// The analytic outline: the convex hull of the box's corners projected by OpenCV.
std::vector<cv::Point2f> analyticOutline(const CameraModel& cam, cv::Point2f shift = {})
{
    cv::Mat K, R, rvec;
    cv::eigen2cv(cam.intrinsics().K, K);
    cv::eigen2cv(cam.cameraFromPart().R, R);
    cv::Rodrigues(R, rvec);
    const Vec3& t = cam.cameraFromPart().t;
    const cv::Mat tvec = (cv::Mat_<double>(3, 1) << t.x(), t.y(), t.z());
    std::vector<cv::Point3d> corners;
    for (int i = 0; i < 8; ++i)
        corners.emplace_back(i & 1 ? kHi.x() : kLo.x(), i & 2 ? kHi.y() : kLo.y(), i & 4 ? kHi.z() : kLo.z());
    std::vector<cv::Point2d> projected;
    cv::projectPoints(corners, rvec, tvec, K, cv::noArray(), projected);
    std::vector<cv::Point2f> points, hull;
    for (const auto& p : projected) points.emplace_back(float(p.x) - shift.x, float(p.y) - shift.y);
    cv::convexHull(points, hull);
    return hull;
}

double distanceToSegment(cv::Point2d p, cv::Point2d a, cv::Point2d b)
{
    const cv::Point2d ab = b - a;
    const double t = std::clamp((p - a).dot(ab) / ab.dot(ab), 0.0, 1.0);
    return cv::norm(p - (a + t * ab));
}

double distanceToPolyline(cv::Point2d p, const std::vector<cv::Point2d>& line, bool closed)
{
    double best = std::numeric_limits<double>::infinity();
    const std::size_t n = line.size();
    for (std::size_t i = 0; i + (closed ? 0 : 1) < n; ++i)
        best = std::min(best, distanceToSegment(p, line[i], line[(i + 1) % n]));
    return best;
}

/// Both ways within `tolerance` pixels: the outline's vertices from the hull, the hull's boundary from the outline.
void expectOutlineMatches(const std::vector<OutlinePolyline>& outline, const std::vector<cv::Point2f>& hull,
                          double tolerance)
{
    ASSERT_EQ(outline.size(), 1u);
    ASSERT_TRUE(outline[0].closed);
    const std::vector<cv::Point2d> corners(hull.begin(), hull.end());
    for (const auto& p : outline[0].points) EXPECT_LE(distanceToPolyline(p, corners, true), tolerance) << p;
    for (std::size_t i = 0; i < corners.size(); ++i)
        for (double s = 0.0; s < 1.0; s += 0.05) {
            const cv::Point2d q = corners[i] + s * (corners[(i + 1) % corners.size()] - corners[i]);
            EXPECT_LE(distanceToPolyline(q, outline[0].points, true), tolerance) << q;
        }
}

TEST(ProjectedOutline, BoxMatchesTheHullOfItsProjectedCorners)
{
    const CameraModel cam = obliqueCamera();
    const auto hull = analyticOutline(cam);
    ASSERT_EQ(hull.size(), 6u); // three faces seen
    expectOutlineMatches(projectedOutline(model::makeBox(kLo, kHi), cam), hull, 0.5);
}

TEST(ProjectedOutline, RegionOfTheSensorIsInItsOwnPixels)
{
    const CameraModel cam = obliqueCamera();
    OutlineOptions options;
    options.window = cv::Rect(100, 60, 440, 360);
    expectOutlineMatches(projectedOutline(model::makeBox(kLo, kHi), cam, options), analyticOutline(cam, {100, 60}),
                         0.5);
}

TEST(ProjectedOutline, PartLeavingTheFrameIsCutAtItsBorder)
{
    const CameraModel cam = obliqueCamera();
    OutlineOptions options;
    options.window = cv::Rect(0, 0, 320, 480); // the left half: the part goes on beyond the right border
    const auto outline = projectedOutline(model::makeBox(kLo, kHi), cam, options);
    ASSERT_EQ(outline.size(), 1u);
    EXPECT_FALSE(outline[0].closed);
    const auto hull = analyticOutline(cam);
    const std::vector<cv::Point2d> corners(hull.begin(), hull.end());
    for (const auto& p : outline[0].points) {
        EXPECT_LT(p.x, 319.0);
        EXPECT_LE(distanceToPolyline(p, corners, true), 0.5) << p;
    }
}

TEST(ProjectedOutline, NothingWhenThePartIsOutOfView)
{
    const CameraModel cam = obliqueCamera();
    const auto far = model::makeBox(Vec3(1000, 1000, 0), Vec3(1010, 1010, 10));
    EXPECT_TRUE(projectedOutline(far, cam).empty());
}

TEST(ProjectedOutline, RefusesAWindowOffTheSensor)
{
    OutlineOptions options;
    options.window = cv::Rect(600, 0, 100, 100);
    EXPECT_THROW(projectedOutline(model::makeBox(kLo, kHi), obliqueCamera(), options), ArgumentError);
}

} // namespace
} // namespace hg::vision
