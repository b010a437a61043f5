// The silhouette renderer against independent expectations: pixel areas
// computed by hand, outlines from cv::projectPoints and cv::convexHull, the
// closed-form area of a sphere's perspective silhouette (an ellipse), and
// polygon areas from OpenCV's convex-polygon intersection.
#include "hullgauge/geometry/camera.h"
#include "hullgauge/model/primitives.h"
#include "hullgauge/sim/renderer.h"

#include <Eigen/Core> // before opencv2/core/eigen.hpp
#include <algorithm>
#include <cmath>
#include <gtest/gtest.h>
#include <numbers>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>

namespace hg::sim {
namespace {

using geometry::CameraModel;
using geometry::Intrinsics;
using geometry::Mat3;
using geometry::RigidTransform;
using geometry::Vec3;

CameraModel makeCamera(double f, cv::Size size, const RigidTransform& pose, std::vector<double> dist = {})
{
    Intrinsics in;
    in.K << f, 0, (size.width - 1) / 2.0, 0, f, (size.height - 1) / 2.0, 0, 0, 1;
    in.dist = std::move(dist);
    in.imageSize = size;
    return CameraModel(in, pose);
}

/// Pixel coordinates of part-frame points by OpenCV (the reference projection).
std::vector<cv::Point2d> projectWithOpenCV(const CameraModel& cam, const std::vector<Vec3>& points)
{
    cv::Mat K, R, rvec;
    cv::eigen2cv(cam.intrinsics().K, K);
    cv::eigen2cv(cam.cameraFromPart().R, R);
    cv::Rodrigues(R, rvec);
    const Vec3& t = cam.cameraFromPart().t;
    cv::Mat tvec = (cv::Mat_<double>(3, 1) << t.x(), t.y(), t.z());
    std::vector<cv::Point3d> obj;
    for (const auto& p : points) obj.emplace_back(p.x(), p.y(), p.z());
    std::vector<cv::Point2d> img;
    cv::projectPoints(obj, rvec, tvec, K, cam.intrinsics().dist, img);
    return img;
}

std::array<Vec3, 8> boxCorners(const Vec3& lo, const Vec3& hi)
{
    std::array<Vec3, 8> c;
    for (int i = 0; i < 8; ++i) c[i] = Vec3(i & 1 ? hi.x() : lo.x(), i & 2 ? hi.y() : lo.y(), i & 4 ? hi.z() : lo.z());
    return c;
}

/// The silhouette outline of a box: the convex hull of its projected corners
/// (pinhole, no distortion). Returned as corner indices in hull order; each
/// consecutive pair is a box edge (the contour generator), whatever the lens.
std::vector<int> outlineCorners(const CameraModel& cam, const std::array<Vec3, 8>& corners)
{
    Intrinsics undistorted;
    undistorted.K = cam.intrinsics().K;
    undistorted.imageSize = cam.imageSize();
    CameraModel pinhole(undistorted, cam.cameraFromPart());
    auto px = projectWithOpenCV(pinhole, {corners.begin(), corners.end()});
    std::vector<cv::Point2f> pts(px.begin(), px.end());
    std::vector<int> hull;
    cv::convexHull(pts, hull, false, false);
    return hull;
}

double polygonArea(const std::vector<cv::Point2f>& poly)
{
    return std::abs(cv::contourArea(poly));
}

std::vector<cv::Point2f> hullOf(const std::vector<cv::Point2d>& pts)
{
    std::vector<cv::Point2f> in(pts.begin(), pts.end()), out;
    cv::convexHull(in, out);
    return out;
}

/// Measures the position of the silhouette edge along pixel rows (or columns
/// when `alongColumns`) where the true outline `curve` (dense, in pixels)
/// crosses them: integrating coverage across the edge over a window gives the
/// crossing position exactly for a straight edge. Returns the largest
/// deviation and counts the measurements.
struct EdgeCheck {
    double maxDeviation = 0.0;
    int samples = 0;
};

EdgeCheck checkEdge(const cv::Mat& cov, std::vector<cv::Point2d> curve, bool alongColumns, double margin)
{
    cv::Mat img = cov;
    if (alongColumns) {
        cv::transpose(cov, img);
        for (auto& p : curve) std::swap(p.x, p.y);
    }
    EdgeCheck result;
    const cv::Point2d a = curve.front(), b = curve.back();
    for (std::size_t i = 0; i + 1 < curve.size(); ++i) {
        const cv::Point2d p = curve[i], q = curve[i + 1];
        const double ylo = std::min(p.y, q.y), yhi = std::max(p.y, q.y);
        for (double r = std::ceil(ylo); r < yhi; r += 1.0) {
            const double x = p.x + (r - p.y) * (q.x - p.x) / (q.y - p.y);
            const cv::Point2d at(x, r);
            if (cv::norm(at - a) < margin || cv::norm(at - b) < margin) continue;
            const int row = static_cast<int>(r);
            const int c0 = static_cast<int>(std::lround(x)) - 5, c1 = c0 + 10;
            if (row < 0 || row >= img.rows || c0 < 0 || c1 >= img.cols) continue;
            const float* line = img.ptr<float>(row);
            double sum = 0.0;
            for (int c = c0; c <= c1; ++c) sum += line[c];
            const bool insideLeft = line[c0] > line[c1];
            EXPECT_NEAR(std::abs(line[c0] - line[c1]), 1.0, 1e-6) << "window not across one clean edge";
            const double measured = insideLeft ? c0 - 0.5 + sum : c1 + 0.5 - sum;
            result.maxDeviation = std::max(result.maxDeviation, std::abs(measured - x));
            ++result.samples;
        }
    }
    return result;
}

/// Checks every outline edge of a box rendered by `cam`; `cov` is coverage
/// (or grey converted to coverage).
EdgeCheck checkBoxOutline(const cv::Mat& cov, const CameraModel& cam, const Vec3& lo, const Vec3& hi)
{
    auto corners = boxCorners(lo, hi);
    auto hull = outlineCorners(cam, corners);
    EXPECT_GE(hull.size(), 4u);
    EdgeCheck total;
    for (std::size_t i = 0; i < hull.size(); ++i) {
        const Vec3 A = corners[hull[i]], B = corners[hull[(i + 1) % hull.size()]];
        // Consecutive hull corners must be joined by a box edge (differ in one coordinate).
        EXPECT_EQ(((A - B).array().abs() > 1e-9).count(), 1)
            << "hull corners " << hull[i] << ", " << hull[(i + 1) % hull.size()];
        std::vector<Vec3> samples;
        const int n = 4000;
        for (int k = 0; k <= n; ++k) samples.push_back(A + (B - A) * (static_cast<double>(k) / n));
        auto curve = projectWithOpenCV(cam, samples);
        const cv::Point2d d = curve.back() - curve.front();
        EdgeCheck e = checkEdge(cov, curve, std::abs(d.x) > std::abs(d.y), 12.0);
        if (cv::norm(d) > 60.0) {
            EXPECT_GT(e.samples, 20) << "edge " << i << " not measured";
        }
        total.maxDeviation = std::max(total.maxDeviation, e.maxDeviation);
        total.samples += e.samples;
    }
    return total;
}

RigidTransform generalPose()
{
    RigidTransform T = RigidTransform::rotation(Vec3(1.0, 2.0, 3.0), 37.0);
    T.t = Vec3(5.0, -3.0, 320.0);
    return T;
}

const Vec3 kBoxLo(-30.0, -20.0, -15.0);
const Vec3 kBoxHi(30.0, 20.0, 15.0);

TEST(Renderer, FrontoParallelRectangleHasExactPixelAreas)
{
    // Camera at the part origin looking down +z, f = 1000 px, principal point
    // (20, 12). The box straddles the optical axis, so its silhouette is its
    // near face at z = 200: pixel x = 5 X + 20, y = 5 Y + 12. The near face
    // spans x in [10.2, 30.7] and y in [5.625, 20.0] (row bounds on
    // sub-scanline boundaries, so even the vertical coverage is exact).
    Intrinsics in;
    in.K << 1000, 0, 20, 0, 1000, 12, 0, 0, 1;
    in.imageSize = {40, 32};
    CameraModel cam(in, RigidTransform::identity());
    SilhouetteRenderer renderer({model::makeBox(Vec3(-1.96, -1.275, 200.0), Vec3(2.14, 1.6, 260.0))});
    cv::Mat cov = renderer.coverage(cam);
    ASSERT_EQ(cov.type(), CV_32FC1);
    ASSERT_EQ(cov.size(), cv::Size(40, 32));
    auto overlap = [](double lo, double hi, int c) {
        return std::max(0.0, std::min(hi, c + 0.5) - std::max(lo, c - 0.5));
    };
    for (int r = 0; r < 32; ++r)
        for (int c = 0; c < 40; ++c) {
            const double expected = overlap(10.2, 30.7, c) * overlap(5.625, 20.0, r);
            ASSERT_NEAR(cov.at<float>(r, c), expected, 2e-6) << "pixel (" << c << ", " << r << ")";
        }
    EXPECT_NEAR(cv::sum(cov)[0], 20.5 * 14.375, 1e-3);
}

TEST(Renderer, BoxOutlineMatchesAnalyticProjection)
{
    CameraModel cam = makeCamera(1500.0, {1280, 1024}, generalPose());
    SilhouetteRenderer renderer({model::makeBox(kBoxLo, kBoxHi)});
    cv::Mat cov = renderer.coverage(cam);
    EdgeCheck e = checkBoxOutline(cov, cam, kBoxLo, kBoxHi);
    EXPECT_GT(e.samples, 500);
    // Rows are integrated exactly; columns to within the sub-scanline step.
    EXPECT_LT(e.maxDeviation, 0.04);

    // Silhouette area against the convex hull of the projected corners.
    auto corners = boxCorners(kBoxLo, kBoxHi);
    const double expected = polygonArea(hullOf(projectWithOpenCV(cam, {corners.begin(), corners.end()})));
    EXPECT_NEAR(cv::sum(cov)[0], expected, 1e-4 * expected);
}

TEST(Renderer, GreyImageEdgesWithinQuarterPixel)
{
    CameraModel cam = makeCamera(1500.0, {1280, 1024}, generalPose());
    SilhouetteRenderer renderer({model::makeBox(kBoxLo, kBoxHi)});
    RenderOptions opt;
    opt.backgroundLevel = 0.9;
    opt.objectLevel = 0.1;
    cv::Mat grey = renderer.render(cam, opt);
    ASSERT_EQ(grey.type(), CV_8UC1);
    // Invert the backlit model on the 8-bit image to get coverage back.
    const double bg = 0.9 * 255, obj = 0.1 * 255;
    cv::Mat cov;
    grey.convertTo(cov, CV_32FC1, 1.0 / (obj - bg), -bg / (obj - bg));
    cv::Mat clamped = cv::max(cv::min(cov, 1.0), 0.0);
    // Quantised flat regions come back as exact 0 / 1 only after rounding.
    clamped.setTo(0.0f, clamped < 0.01f);
    clamped.setTo(1.0f, clamped > 0.99f);
    EdgeCheck e = checkBoxOutline(clamped, cam, kBoxLo, kBoxHi);
    EXPECT_GT(e.samples, 500);
    EXPECT_LT(e.maxDeviation, 0.25);
}

TEST(Renderer, DistortedBoxOutlineFollowsProjectPoints)
{
    // Strong barrel distortion bends the box edges by several pixels; the
    // outline must follow cv::projectPoints of points along the edges.
    const std::vector<double> dist{-0.25, 0.12, 0.001, -0.0008, -0.02};
    CameraModel cam = makeCamera(1500.0, {1280, 1024}, generalPose(), dist);
    RigidTransform shifted = generalPose();
    shifted.t += Vec3(60.0, 40.0, 0.0); // towards the image corner, where distortion is strongest
    CameraModel camCorner = makeCamera(1500.0, {1280, 1024}, shifted, dist);
    SilhouetteRenderer renderer({model::makeBox(kBoxLo, kBoxHi)});
    for (const CameraModel* c : {&cam, &camCorner}) {
        cv::Mat cov = renderer.coverage(*c);
        EdgeCheck e = checkBoxOutline(cov, *c, kBoxLo, kBoxHi);
        EXPECT_GT(e.samples, 400);
        EXPECT_LT(e.maxDeviation, 0.05);
    }
    // The bending is real: straight chords between the projected corners
    // would miss the outline by more than a pixel somewhere.
    auto corners = boxCorners(kBoxLo, kBoxHi);
    auto hull = outlineCorners(camCorner, corners);
    double largestSag = 0.0;
    for (std::size_t i = 0; i < hull.size(); ++i) {
        const Vec3 A = corners[hull[i]], B = corners[hull[(i + 1) % hull.size()]];
        auto ends = projectWithOpenCV(camCorner, {A, B, (A + B) / 2});
        largestSag = std::max(largestSag, cv::norm(ends[2] - (ends[0] + ends[1]) * 0.5));
    }
    EXPECT_GT(largestSag, 1.0);
}

/// Area of the ellipse a sphere (centre `c` in the camera frame, radius
/// `rho`) projects to: the tangent cone x^T (c c^T - (|c|^2 - rho^2) I) x = 0
/// mapped to pixels by K gives the conic Q = K^-T M K^-1, whose area is
/// pi |det Q| / det(Q_2x2)^(3/2).
double sphereSilhouetteArea(const Mat3& K, const Vec3& c, double rho)
{
    Mat3 M = c * c.transpose() - (c.squaredNorm() - rho * rho) * Mat3::Identity();
    const Mat3 Kinv = K.inverse();
    const Mat3 Q = Kinv.transpose() * M * Kinv;
    const double det2 = Q.topLeftCorner<2, 2>().determinant();
    return std::numbers::pi * std::abs(Q.determinant()) / std::pow(det2, 1.5);
}

TEST(Renderer, SphereAreaMatchesPerspectiveEllipse)
{
    const cv::Size size(1280, 1024);
    const double f = 1800.0;
    const Vec3 centre(4.0, -2.0, 1.0);
    const double rho = 40.0;
    RigidTransform pose = RigidTransform::rotation(Vec3(0.3, -1.0, 0.2), 25.0);
    pose.t = Vec3(70.0, -50.0, 330.0); // well off-axis: a clearly elongated ellipse
    CameraModel cam = makeCamera(f, size, pose);
    const Vec3 c = pose.apply(centre);

    // The closed form for a square-pixel camera agrees with the conic route:
    // area = pi f^2 sin^2(a) cos(a) / (cos^2(t) - sin^2(a))^(3/2), a the cone
    // half-angle, t the angle between the cone axis and the optical axis.
    const double sinA = rho / c.norm(), cosA = std::sqrt(1 - sinA * sinA), cosT = c.z() / c.norm();
    const double closedForm = std::numbers::pi * f * f * sinA * sinA * cosA / std::pow(cosT * cosT - sinA * sinA, 1.5);
    ASSERT_NEAR(sphereSilhouetteArea(cam.intrinsics().K, c, rho), closedForm, 1e-9 * closedForm);

    // The tessellated sphere lies between its inscribed ball (radius = least
    // distance from the centre to a face plane) and the true sphere.
    model::TriangleMesh mesh = model::makeSphere(centre, rho, 256, 128);
    double inner = rho;
    for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
        const Vec3 n = mesh.faceNormal(i);
        if (n.squaredNorm() == 0) continue;
        inner = std::min(inner, n.dot(mesh.vertices[static_cast<std::size_t>(mesh.triangles[i][0])] - centre));
    }
    const double lower = sphereSilhouetteArea(cam.intrinsics().K, c, inner);
    const double upper = sphereSilhouetteArea(cam.intrinsics().K, c, rho);
    ASSERT_LT(upper - lower, 1e-3 * upper); // the bracket is tight enough to mean something

    cv::Mat cov = SilhouetteRenderer({mesh}).coverage(cam);
    const double area = cv::sum(cov)[0];
    EXPECT_GT(area, lower - 0.5);
    EXPECT_LT(area, upper + 0.5);
    CoverageStats stats = measureCoverage(cov);
    EXPECT_NEAR(stats.areaPx, area, 1e-6 * area);
    EXPECT_FALSE(stats.touchesBorder);
}

TEST(Renderer, DistortedSphereHasNoCracks)
{
    // Subdivision must keep shared edges identical in neighbouring triangles:
    // the inside of the silhouette is fully covered.
    const std::vector<double> dist{-0.3, 0.15, 0.002, 0.001, -0.03};
    RigidTransform pose;
    pose.t = Vec3(40.0, 30.0, 300.0);
    CameraModel cam = makeCamera(1500.0, {1280, 1024}, pose, dist);
    // A finely tessellated sphere, and a large box whose faces are cut into
    // many pieces because their edges and diagonals bend.
    for (const auto& mesh : {model::makeSphere(Vec3::Zero(), 40.0, 96, 48), model::makeBox(kBoxLo * 2, kBoxHi * 2)}) {
        cv::Mat cov = SilhouetteRenderer({mesh}).coverage(cam);
        cv::Mat inside;
        cv::erode(cov > 0.0f, inside, cv::Mat(), cv::Point(-1, -1), 3);
        ASSERT_GT(cv::countNonZero(inside), 10000);
        double minInside = 0.0;
        cv::minMaxLoc(cov, &minInside, nullptr, nullptr, nullptr, inside);
        EXPECT_GT(minInside, 1.0 - 1e-5);
    }
}

TEST(Renderer, UnionOfOverlappingMeshesCountsOverlapOnce)
{
    CameraModel cam = makeCamera(1500.0, {1280, 1024}, generalPose());
    const Vec3 aLo(-30, -20, -15), aHi(10, 20, 15), bLo(-5, -10, -25), bHi(35, 15, 5);
    auto ca = boxCorners(aLo, aHi), cb = boxCorners(bLo, bHi);
    auto ha = hullOf(projectWithOpenCV(cam, {ca.begin(), ca.end()}));
    auto hb = hullOf(projectWithOpenCV(cam, {cb.begin(), cb.end()}));
    std::vector<cv::Point2f> both;
    const double overlap = cv::intersectConvexConvex(ha, hb, both, true);
    ASSERT_GT(overlap, 1000.0);
    const double expected = polygonArea(ha) + polygonArea(hb) - overlap;

    cv::Mat cov = SilhouetteRenderer({model::makeBox(aLo, aHi), model::makeBox(bLo, bHi)}).coverage(cam);
    double maxCov = 0.0;
    cv::minMaxLoc(cov, nullptr, &maxCov);
    EXPECT_LE(maxCov, 1.0);
    // Float rounding of the per-pixel sums only.
    EXPECT_NEAR(cv::sum(cov)[0], expected, 1e-4 * expected);
}

TEST(Renderer, InvertedMeshRendersTheSame)
{
    CameraModel cam = makeCamera(1500.0, {640, 512}, generalPose());
    model::TriangleMesh box = model::makeBox(kBoxLo, kBoxHi);
    cv::Mat a = SilhouetteRenderer({box}).coverage(cam);
    box.flip();
    cv::Mat b = SilhouetteRenderer({box}).coverage(cam);
    EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
}

TEST(Renderer, GeometryBehindTheCameraIsClipped)
{
    // A bar from 100 mm behind the camera to 300 mm in front, beside the
    // optical axis: only its part in front of the near plane is seen, which
    // is the box [x] x [y] x [near, 300].
    Intrinsics in;
    in.K << 800, 0, 319.5, 0, 800, 239.5, 0, 0, 1;
    in.imageSize = {640, 480};
    CameraModel cam(in, RigidTransform::identity());
    const Vec3 lo(10, -15, -100), hi(40, 25, 300);
    RenderOptions opt;
    opt.nearPlaneMm = 2.0;
    cv::Mat cov = SilhouetteRenderer({model::makeBox(lo, hi)}).coverage(cam, opt);
    auto corners = boxCorners(Vec3(lo.x(), lo.y(), 2.0), hi);
    auto hull = hullOf(projectWithOpenCV(cam, {corners.begin(), corners.end()}));
    std::vector<cv::Point2f> image{{-0.5f, -0.5f}, {639.5f, -0.5f}, {639.5f, 479.5f}, {-0.5f, 479.5f}}, inView;
    const double expected = cv::intersectConvexConvex(hull, image, inView, true);
    ASSERT_GT(expected, 10000.0);
    EXPECT_NEAR(cv::sum(cov)[0], expected, 1e-4 * expected);
}

TEST(Renderer, NoiseSigmaMeasuredOnBackground)
{
    CameraModel cam = makeCamera(1500.0, {800, 600}, generalPose());
    SilhouetteRenderer renderer({model::makeBox(Vec3(-5, -5, -5), Vec3(5, 5, 5))});
    RenderOptions opt;
    opt.noiseSigma = 3.0;
    opt.seed = 42;
    cv::Mat grey = renderer.render(cam, opt);
    cv::Mat background = grey(cv::Rect(0, 0, 800, 150)); // the part projects near the centre
    cv::Scalar mean, sd;
    cv::meanStdDev(background, mean, sd);
    // Rounding to integers adds the variance 1/12 of a uniform quantiser.
    EXPECT_NEAR(sd[0], std::sqrt(9.0 + 1.0 / 12.0), 0.05);
    EXPECT_NEAR(mean[0], 0.85 * 255, 0.05);

    EXPECT_EQ(cv::norm(grey, renderer.render(cam, opt), cv::NORM_INF), 0.0) << "same seed, same image";
    opt.seed = 43;
    EXPECT_GT(cv::norm(grey, renderer.render(cam, opt), cv::NORM_INF), 0.0);

    opt.bitDepth = 16;
    opt.noiseSigma = 40.0;
    cv::Mat deep = renderer.render(cam, opt);
    ASSERT_EQ(deep.type(), CV_16UC1);
    cv::meanStdDev(deep(cv::Rect(0, 0, 800, 150)), mean, sd);
    EXPECT_NEAR(sd[0], 40.0, 0.5);
    EXPECT_NEAR(mean[0], 0.85 * 65535, 0.5);
}

TEST(Renderer, BlurSpreadsEdgeByItsSigma)
{
    // The fronto-parallel set-up of the first test, edge at x = 10.2 (pixel 10
    // 30 % covered). The unblurred profile's derivative has variance
    // 0.3 * 0.7 = 0.21; a Gaussian blur adds σ² and keeps the edge in place.
    Intrinsics in;
    in.K << 1000, 0, 20, 0, 1000, 40, 0, 0, 1;
    in.imageSize = {60, 80};
    CameraModel cam(in, RigidTransform::identity());
    SilhouetteRenderer renderer({model::makeBox(Vec3(-1.96, -6.0, 200.0), Vec3(6.0, 6.0, 260.0))});
    RenderOptions opt;
    opt.bitDepth = 16;
    opt.backgroundLevel = 1.0;
    opt.objectLevel = 0.0;
    opt.blurSigmaPx = 2.0;
    cv::Mat grey = renderer.render(cam, opt);
    cv::Mat profile;
    grey.row(40).convertTo(profile, CV_64F, 1.0 / 65535); // 1 - coverage
    double mean = 0, second = 0, mass = 0;
    for (int c = 0; c + 1 < 30; ++c) {
        const double d = profile.at<double>(c) - profile.at<double>(c + 1); // background to object
        mean += d * (c + 0.5);
        second += d * (c + 0.5) * (c + 0.5);
        mass += d;
    }
    mean /= mass;
    const double variance = second / mass - mean * mean;
    EXPECT_NEAR(mass, 1.0, 1e-3);
    EXPECT_NEAR(mean, 10.2, 0.01);
    EXPECT_NEAR(variance, 4.0 + 0.21, 0.02);
}

TEST(Renderer, AWindowHasTheWholeImagesPixels)
{
    // A camera sending a region (docs/camera.md "Regions per grab") sees the
    // pixels the whole sensor would show there: the window rendered alone
    // against the whole image's crop, blurred (its kernel reaches past the
    // window) and distorted, inside the sensor and against its corner.
    const std::vector<double> dist{-0.25, 0.12, 0.001, -0.0008, -0.02};
    const CameraModel cam = makeCamera(1500.0, {1280, 1024}, generalPose(), dist);
    SilhouetteRenderer renderer({model::makeBox(kBoxLo, kBoxHi)});
    RenderOptions opt;
    opt.blurSigmaPx = 1.5;
    const cv::Mat whole = renderer.render(cam, opt);
    // Windows reaching into the box's silhouette: around its centre, and from
    // it to the sensor's first and last pixel.
    const cv::Rect box = cv::boundingRect(whole < 128);
    const cv::Point centre(box.x + box.width / 2, box.y + box.height / 2);
    for (const cv::Rect window : {cv::Rect(centre.x - 128, centre.y - 65, 257, 131), cv::Rect(cv::Point(0, 0), centre),
                                  cv::Rect(centre, cv::Point(1280, 1024))}) {
        const cv::Mat part = renderer.render(cam, opt, window);
        ASSERT_EQ(part.size(), window.size());
        cv::Mat difference;
        cv::absdiff(part, whole(window), difference);
        double largest = 0.0;
        cv::minMaxLoc(difference, nullptr, &largest);
        // The same geometry projected with the principal point moved: equal
        // but for a rounding of the last bit of a pixel's float grey now and then.
        EXPECT_LE(largest, 1.0) << window;
        EXPECT_LE(cv::countNonZero(difference), window.area() / 1000) << window;
        EXPECT_GT(cv::countNonZero(part < 128), 0) << window; // the box is in every window
    }
    EXPECT_THROW(renderer.render(cam, opt, cv::Rect(1200, 0, 100, 10)), std::invalid_argument);
    EXPECT_THROW(renderer.render(cam, opt, cv::Rect(10, 10, 0, 10)), std::invalid_argument);
}

TEST(Renderer, RejectsBadOptions)
{
    CameraModel cam = makeCamera(1000.0, {64, 48}, generalPose());
    SilhouetteRenderer renderer({model::makeBox(kBoxLo, kBoxHi)});
    RenderOptions opt;
    opt.subScanlines = 3;
    EXPECT_THROW(renderer.coverage(cam, opt), std::invalid_argument);
    opt = {};
    opt.bitDepth = 12;
    EXPECT_THROW(renderer.render(cam, opt), std::invalid_argument);
    opt = {};
    opt.noiseSigma = -1;
    EXPECT_THROW(renderer.render(cam, opt), std::invalid_argument);
    opt = {};
    opt.vignetting = 1.0;
    EXPECT_THROW(renderer.render(cam, opt), std::invalid_argument);
    opt = {};
    opt.haloPx = 11.0;
    EXPECT_THROW(renderer.render(cam, opt), std::invalid_argument);
    opt = {};
    opt.dust = {DustSpeck{10.0, 10.0, 2.0, 0.3}, DustSpeck{10.0, 10.0, 2.0, 1.5}};
    try {
        (void)renderer.render(cam, opt);
        ADD_FAILURE() << "a speck darker than black was accepted";
    } catch (const std::invalid_argument& e) {
        EXPECT_EQ(std::string(e.what()), "dust[1].depth must be within [0, 1], found 1.5");
    }
}

// The halo erodes a curved silhouette along its normals too: a disc of radius
// R, its coverage taken by 16 x 16 point samples per pixel, keeps the area of
// the disc of radius R - h (the curvature biases the distance by about σ_h² /
// 2R = 0.0125 px here).
TEST(Renderer, TheHaloErodesADiscToTheDiscOfItsRadiusLessTheHalo)
{
    constexpr double kR = 40.0;
    const cv::Point2d centre(60.3, 57.8);
    cv::Mat coverage(120, 120, CV_32FC1, cv::Scalar(0));
    for (int y = 0; y < coverage.rows; ++y)
        for (int x = 0; x < coverage.cols; ++x) {
            int inside = 0;
            for (int j = 0; j < 16; ++j)
                for (int i = 0; i < 16; ++i)
                    inside += std::hypot(x - 0.5 + (i + 0.5) / 16 - centre.x, y - 0.5 + (j + 0.5) / 16 - centre.y) < kR;
            coverage.at<float>(y, x) = static_cast<float>(inside / 256.0);
        }
    for (const double halo : {0.5, 1.5, 4.0}) {
        const double area = cv::sum(erodeCoverage(coverage, halo))[0];
        const double r = kR - halo;
        EXPECT_NEAR(area, std::numbers::pi * r * r, 2.0 * std::numbers::pi * r * 0.05) << "halo " << halo;
    }
    EXPECT_THROW(erodeCoverage(coverage, 0.0), std::invalid_argument);
}

} // namespace
} // namespace hg::sim
