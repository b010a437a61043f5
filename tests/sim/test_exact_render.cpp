// The independent test renderer (tests/support/hgtest/exact_render.h) against
// expectations that owe nothing to it: pixel areas of rectangles worked by
// hand, polygon areas by the shoelace formula over outlines projected with
// CameraModel::project, the product's renderer (a different method, each
// compared with the other and never with itself), and its own exhaustive
// mode (every pixel supersampled) for the acceleration.
#include "hgtest/exact_render.h"
#include "hgtest/parts.h"

#include "hullgauge/geometry/camera.h"
#include "hullgauge/model/primitives.h"
#include "hullgauge/sim/renderer.h"

#include <algorithm>
#include <cmath>
#include <gtest/gtest.h>
#include <iostream>
#include <opencv2/core.hpp>
#include <stdexcept>

namespace hgtest {
namespace {

using hg::geometry::CameraModel;
using hg::geometry::Intrinsics;
using hg::geometry::RigidTransform;
using hg::geometry::Vec2;
using hg::geometry::Vec3;
using hg::model::makeBox;
using hg::model::TriangleMesh;

/// A camera at the part origin looking along +z (identity pose) unless `pose` says otherwise.
CameraModel makeCamera(double f, double cx, double cy, cv::Size size, std::vector<double> dist = {},
                       const RigidTransform& pose = {})
{
    Intrinsics in;
    in.K << f, 0, cx, 0, f, cy, 0, 0, 1;
    in.dist = std::move(dist);
    in.imageSize = size;
    return CameraModel(in, pose);
}

/// Length of [lo, hi] ∩ [c - 0.5, c + 0.5]: a pixel's share of an interval.
double overlap(double lo, double hi, int c)
{
    return std::max(0.0, std::min(hi, c + 0.5) - std::max(lo, c - 0.5));
}

/// An axis-aligned rectangle in pixel coordinates.
struct PixelRect {
    double x0, x1, y0, y1;
    double area() const { return (x1 - x0) * (y1 - y0); }
    double share(int c, int r) const { return overlap(x0, x1, c) * overlap(y0, y1, r); }
    PixelRect intersected(const PixelRect& o) const
    {
        return {std::max(x0, o.x0), std::max(std::min(x1, o.x1), std::max(x0, o.x0)), std::max(y0, o.y0),
                std::max(std::min(y1, o.y1), std::max(y0, o.y0))};
    }
};

/// The near face of a box that straddles the optical axis of a camera at the
/// origin looking along +z: it is the box's silhouette (the far face and the
/// sides project inside it), f·x/z + c by hand.
PixelRect nearFace(const Vec3& lo, const Vec3& hi, double f, double cx, double cy)
{
    return {cx + f * lo.x() / lo.z(), cx + f * hi.x() / lo.z(), cy + f * lo.y() / lo.z(), cy + f * hi.y() / lo.z()};
}

/// Per-pixel comparison of a coverage image with expected coverages.
struct Comparison {
    int boundaryPixels = 0;
    int wrongInside = 0;  ///< expected 1, got anything else
    int wrongOutside = 0; ///< expected 0, got anything else
    double maxError = 0.0, sumSquared = 0.0, sumSigned = 0.0;
    double area = 0.0, expectedArea = 0.0;

    void add(double got, double expected)
    {
        area += got;
        expectedArea += expected;
        if (expected == 1.0)
            wrongInside += got != 1.0;
        else if (expected == 0.0)
            wrongOutside += got != 0.0;
        else {
            ++boundaryPixels;
            maxError = std::max(maxError, std::abs(got - expected));
            sumSquared += (got - expected) * (got - expected);
            sumSigned += got - expected;
        }
    }
    double rms() const { return std::sqrt(sumSquared / std::max(boundaryPixels, 1)); }
};

template <class Expected> Comparison compare(const cv::Mat& coverage, Expected expected)
{
    Comparison cmp;
    for (int r = 0; r < coverage.rows; ++r)
        for (int c = 0; c < coverage.cols; ++c) cmp.add(coverage.at<float>(r, c), expected(c, r));
    return cmp;
}

/// Area of a closed polygon (shoelace).
double shoelace(const std::vector<Vec2>& poly)
{
    double twice = 0.0;
    for (std::size_t i = 0; i < poly.size(); ++i) {
        const Vec2& a = poly[i];
        const Vec2& b = poly[(i + 1) % poly.size()];
        twice += a.x() * b.y() - a.y() * b.x();
    }
    return std::abs(twice) / 2.0;
}

double sumOf(const cv::Mat& coverage)
{
    return cv::sum(coverage)[0];
}

/// The standard-deviation bound of a pixel crossed by one straight edge (header).
double sigmaBound(int S)
{
    return std::sqrt(2.0 * S - 1.0) / (2.0 * S * S);
}

TEST(ExactRender, FaceOnBoxCoversEachPixelByItsRectangleOverlap)
{
    const double f = 1000.0, cx = 160.3, cy = 120.7;
    const Vec3 lo(-10.123, -5.311, 200.0), hi(7.77, 6.049, 230.0);
    const PixelRect rect = nearFace(lo, hi, f, cx, cy); // x 109.685..199.15, y 94.145..150.945
    ExactRenderOptions options;
    const int S = options.samplesPerSide;
    const cv::Mat coverage = exactCoverage({makeBox(lo, hi)}, makeCamera(f, cx, cy, {320, 240}), options);
    ASSERT_EQ(coverage.type(), CV_32FC1);
    ASSERT_EQ(coverage.size(), cv::Size(320, 240));

    const Comparison cmp = compare(coverage, [&](int c, int r) { return rect.share(c, r); });
    std::cout << "face-on box, S = " << S << ": " << cmp.boundaryPixels << " boundary pixels, max |error| "
              << cmp.maxError << ", rms " << cmp.rms() << ", mean " << cmp.sumSigned / cmp.boundaryPixels << "; area "
              << cmp.area << " px² against " << rect.area() << "\n";
    EXPECT_EQ(cmp.wrongInside, 0);
    EXPECT_EQ(cmp.wrongOutside, 0);
    EXPECT_GT(cmp.boundaryPixels, 250);
    EXPECT_LE(cmp.maxError, 4.0 / S);
    EXPECT_LE(cmp.rms(), sigmaBound(S)); // every pixel's σ is below the bound, corners aside
    EXPECT_NEAR(cmp.area, rect.area(), 1e-3 * rect.area());
    EXPECT_NEAR(cmp.expectedArea, rect.area(), 1e-9 * rect.area()); // the hand-worked shares add up
}

TEST(ExactRender, DiscOfATriangleFanHasItsPolygonArea)
{
    // A cylinder seen along its axis: its silhouette is the near cap, a
    // 256-gon (ear-clipped into a fan), the far cap and the sides inside it.
    const CameraModel camera = makeCamera(1000.0, 159.62, 121.13, {320, 240});
    const double zNear = 200.0;
    const TriangleMesh cylinder = hg::model::makeCylinder({0.37, -0.21, zNear}, 20.0, 15.0, 256);
    std::vector<Vec2> cap;
    for (const Vec3& v : cylinder.vertices)
        if (v.z() == zNear) cap.push_back(*camera.project(v));
    ASSERT_EQ(cap.size(), 256u);
    const double expected = shoelace(cap);

    const double area = sumOf(exactCoverage({cylinder}, camera));
    std::cout << "disc: area " << area << " px² against the polygon's " << expected << ", relative error "
              << (area - expected) / expected << "\n";
    EXPECT_NEAR(area, expected, 5e-4 * expected);
}

TEST(ExactRender, UndistortPixelIsExactEnoughForTheSamples)
{
    // The renderer undistorts every sample with CameraModel::undistortPixel:
    // its round trip through project() must be far below the sampling error.
    const std::vector<std::vector<double>> lenses = {{-0.2, 0.0, 0.0, 0.0},
                                                     {-0.25, 0.08, 0.001, -0.0008, 0.01, 0.02, 0.0, 0.001}};
    for (const auto& dist : lenses) {
        const CameraModel camera = makeCamera(800.0, 319.73, 239.09, {640, 480}, dist);
        double worst = 0.0;
        for (double v = -0.5; v <= 479.5; v += 6.7)
            for (double u = -0.5; u <= 639.5; u += 6.3) {
                const Vec2 q = camera.undistortPixel({u, v});
                const Vec2 back = *camera.projectCameraPoint(Vec3(q.x(), q.y(), 1.0));
                worst = std::max(worst, (back - Vec2(u, v)).norm());
            }
        std::cout << dist.size() << " coefficients: worst round trip " << worst << " px\n";
        EXPECT_LT(worst, 1e-9);
    }
}

TEST(ExactRender, DistortedSquareHasTheAreaOfItsDistortedOutline)
{
    const double f = 800.0;
    const CameraModel camera = makeCamera(f, 319.73, 239.09, {640, 480}, {-0.2, 0.0, 0.0, 0.0});
    const Vec3 lo(-45.3, -40.7, 200.0), hi(52.1, 38.2, 204.0);
    // The outline of the near face, 10 000 points per edge, through the lens.
    const Vec3 corners[4] = {
        {lo.x(), lo.y(), lo.z()}, {hi.x(), lo.y(), lo.z()}, {hi.x(), hi.y(), lo.z()}, {lo.x(), hi.y(), lo.z()}};
    std::vector<Vec2> outline;
    for (int e = 0; e < 4; ++e)
        for (int i = 0; i < 10000; ++i)
            outline.push_back(*camera.project(corners[e] + (corners[(e + 1) % 4] - corners[e]) * (i / 10000.0)));
    const double expected = shoelace(outline);
    const double pinhole = nearFace(lo, hi, f, 0, 0).area();
    ASSERT_GT(std::abs(pinhole - expected), 0.01 * expected) << "the lens must matter for this test";

    const double area = sumOf(exactCoverage({makeBox(lo, hi)}, camera));
    std::cout << "distorted square: area " << area << " px² against the outline's " << expected << " (pinhole "
              << pinhole << "), relative error " << (area - expected) / expected << "\n";
    EXPECT_NEAR(area, expected, 1e-3 * expected);
}

TEST(ExactRender, AgreesWithTheProductRendererWithinTheSamplingError)
{
    // This renderer at S = 32: σ ≤ 0.0039 per pixel, so 0.03 lies beyond 7σ
    // at every pixel (at S = 16, σ ≤ 0.011, the largest of ~4000 differences
    // reaches 0.025). The product's renderer at settings that make its own
    // error small against that: 64 sub-scanlines (its midpoint rule is
    // quantised to 1/(2·16) = 0.031 on a near-horizontal edge at its default
    // 16) and chords within 0.001 px of a distorted edge (its default 0.01 px
    // shifts distorted edges by ~0.0015 px on average, the size of the mean
    // difference this test bounds).
    ExactRenderOptions options;
    options.samplesPerSide = 32;
    hg::sim::RenderOptions fine;
    fine.subScanlines = 64;
    fine.maxEdgeSagPx = 0.001;
    struct Case {
        const char* name;
        TriangleMesh mesh;
        CameraModel camera;
    };
    const CameraModel boxView = lookAt({-150, -200, 180}, {10, 7, 4.5}, {0, 0, -1});
    const CameraModel cylinderView = lookAt({200, -150, 120}, {0, 0, 10}, {0, 0, -1});
    auto distorted = [](const CameraModel& c) {
        Intrinsics in = c.intrinsics();
        in.dist = {-0.15, 0.02, 0.0005, -0.0003};
        return CameraModel(in, c.cameraFromPart());
    };
    const std::vector<Case> cases = {
        {"tilted box", makeBox({0, 0, 0}, {20, 14, 9}), boxView},
        {"cylinder", hg::model::makeCylinder({0, 0, 0}, 8.0, 20.0, 64), cylinderView},
        {"tilted box, distorted", makeBox({0, 0, 0}, {20, 14, 9}), distorted(boxView)},
        {"cylinder, distorted", hg::model::makeCylinder({0, 0, 0}, 8.0, 20.0, 64), distorted(cylinderView)}};
    for (const Case& k : cases) {
        SCOPED_TRACE(k.name);
        const cv::Mat exact = exactCoverage({k.mesh}, k.camera, options);
        const cv::Mat product = hg::sim::SilhouetteRenderer({k.mesh}).coverage(k.camera, fine);
        double worst = 0.0, signedSum = 0.0;
        int boundary = 0;
        for (int r = 0; r < exact.rows; ++r)
            for (int c = 0; c < exact.cols; ++c) {
                const double a = exact.at<float>(r, c), b = product.at<float>(r, c);
                worst = std::max(worst, std::abs(a - b));
                if ((a > 0 && a < 1) || (b > 0 && b < 1)) {
                    ++boundary;
                    signedSum += a - b;
                }
            }
        std::cout << k.name << ": " << boundary << " boundary pixels, max |difference| " << worst
                  << ", mean signed difference " << signedSum / boundary << "\n";
        EXPECT_GT(boundary, 500);
        EXPECT_LE(worst, 0.03);
        EXPECT_LE(std::abs(signedSum / boundary), 0.002);
    }
}

TEST(ExactRender, OverlappingMeshesCountOnce)
{
    // Two intersecting boxes, both straddling the optical axis: the silhouette
    // is the union of their near faces, A + B − A∩B pixel by pixel.
    const double f = 1000.0, cx = 160.4, cy = 120.6;
    const Vec3 aLo(-10.2, -3.1, 200.0), aHi(4.3, 2.7, 212.0);
    const Vec3 bLo(-2.2, -8.3, 205.0), bHi(2.6, 9.4, 220.0);
    const PixelRect a = nearFace(aLo, aHi, f, cx, cy), b = nearFace(bLo, bHi, f, cx, cy);
    const PixelRect both = a.intersected(b);
    ASSERT_GT(both.area(), 100.0);
    const double expected = a.area() + b.area() - both.area();

    ExactRenderOptions options;
    const cv::Mat coverage =
        exactCoverage({makeBox(aLo, aHi), makeBox(bLo, bHi)}, makeCamera(f, cx, cy, {320, 240}), options);
    const Comparison cmp =
        compare(coverage, [&](int c, int r) { return a.share(c, r) + b.share(c, r) - both.share(c, r); });
    std::cout << "two boxes: area " << cmp.area << " px² against " << expected << ", max |error| " << cmp.maxError
              << " over " << cmp.boundaryPixels << " boundary pixels\n";
    EXPECT_EQ(cmp.wrongInside, 0);
    EXPECT_EQ(cmp.wrongOutside, 0);
    EXPECT_LE(cmp.maxError, 4.0 / options.samplesPerSide);
    EXPECT_NEAR(cmp.area, expected, 1e-3 * expected);
}

TEST(ExactRender, SameSeedSameImageWhateverTheThreads)
{
    const TriangleMesh cylinder = hg::model::makeCylinder({0, 0, 0}, 8.0, 20.0, 64);
    const CameraModel camera = lookAt({200, -150, 120}, {0, 0, 10}, {0, 0, -1});
    ExactRenderOptions one, two, other;
    one.threads = 1;
    two.threads = 2;
    other.seed = 7;
    const cv::Mat a = exactCoverage({cylinder}, camera, one);
    const cv::Mat b = exactCoverage({cylinder}, camera, two);
    const cv::Mat c = exactCoverage({cylinder}, camera, other);
    EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(a, exactCoverage({cylinder}, camera, one), cv::NORM_INF), 0.0);
    // Another seed moves the boundary pixels' estimates, never a whole pixel.
    int moved = 0, flipped = 0;
    for (int r = 0; r < a.rows; ++r)
        for (int k = 0; k < a.cols; ++k) {
            const float x = a.at<float>(r, k), y = c.at<float>(r, k);
            moved += x != y;
            flipped += std::abs(x - y) == 1.0f;
        }
    EXPECT_GT(moved, 100);
    EXPECT_EQ(flipped, 0);
}

TEST(ExactRender, AccelerationGivesTheImageOfSupersamplingEveryPixel)
{
    // Concave parts, an inside seen through the cup's mouth, a triangle soup
    // (no shared vertices: every edge a contour edge) overlapping another
    // mesh, a strong lens: the contour-marked image must equal, bit for bit,
    // the image with every pixel supersampled (same seeds per pixel).
    ExactRenderOptions fast, every;
    fast.samplesPerSide = every.samplesPerSide = 4;
    every.sampleEveryPixel = true;
    TriangleMesh soup;
    const TriangleMesh block = makeBox({-4, -6, -2}, {30, 3, 6}); // through the channel's end
    for (const auto& t : block.triangles) {
        const int base = static_cast<int>(soup.vertices.size());
        for (int k : t) soup.vertices.push_back(block.vertices[static_cast<std::size_t>(k)]);
        soup.triangles.push_back({base, base + 1, base + 2});
    }
    CameraSpec spec;
    spec.focalPx = 1100.0;
    spec.imageSize = {320, 240};
    struct Case {
        const char* name;
        std::vector<TriangleMesh> meshes;
        Vec3 from, target, down;
    };
    const std::vector<Case> cases = {
        {"cup", {cupPart().mesh}, {60, -90, 260}, {0, 0, 7}, {0, 1, 0}},
        {"channel and soup", {uChannelPart().mesh, soup}, {-260, -230, 210}, {10, 0, 4}, {0, 0, -1}}};
    for (const Case& k : cases) {
        SCOPED_TRACE(k.name);
        const CameraModel pinhole = lookAt(k.from, k.target, k.down, spec);
        Intrinsics lens = pinhole.intrinsics();
        lens.dist = {-0.3, 0.05, 0.0, 0.0};
        for (const CameraModel& camera : {pinhole, CameraModel(lens, pinhole.cameraFromPart())}) {
            const cv::Mat a = exactCoverage(k.meshes, camera, fast);
            const cv::Mat b = exactCoverage(k.meshes, camera, every);
            const double area = sumOf(a);
            EXPECT_GT(area, 2000.0);
            EXPECT_LT(area, 0.5 * 320 * 240);
            EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
        }
    }
}

TEST(ExactRender, RefusesGeometryAtTheCameraAndBadOptions)
{
    const CameraModel camera = makeCamera(1000.0, 160, 120, {320, 240});
    EXPECT_THROW(exactCoverage({makeBox({-1, -1, -5}, {1, 1, 5})}, camera), std::invalid_argument);
    EXPECT_THROW(exactCoverage({makeBox({-1, -1, 0.5}, {1, 1, 5})}, camera), std::invalid_argument);
    ExactRenderOptions near;
    near.nearPlaneMm = 0.25;
    EXPECT_NO_THROW(exactCoverage({makeBox({-1, -1, 0.5}, {1, 1, 5})}, camera, near));
    ExactRenderOptions bad;
    bad.samplesPerSide = 0;
    EXPECT_THROW(exactCoverage({makeBox({-1, -1, 10}, {1, 1, 12})}, camera, bad), std::invalid_argument);
    // Nothing in view: an empty image, no error.
    EXPECT_EQ(sumOf(exactCoverage({makeBox({500, 500, 10}, {501, 501, 12})}, camera)), 0.0);
    EXPECT_EQ(sumOf(exactCoverage({}, camera)), 0.0);
}

TEST(ExactRender, ShadeExactMapsCoverageToGreyLevels)
{
    cv::Mat1f coverage(1, 4);
    coverage << 0.0f, 1.0f, 0.25f, 0.5f;
    ExactShading s;
    s.background = 200.0;
    s.object = 20.0;
    const cv::Mat grey = shadeExact(coverage, s);
    ASSERT_EQ(grey.type(), CV_8UC1);
    EXPECT_EQ(grey.at<uchar>(0, 0), 200);
    EXPECT_EQ(grey.at<uchar>(0, 1), 20);
    EXPECT_EQ(grey.at<uchar>(0, 2), 155); // 200 − 180/4
    EXPECT_EQ(grey.at<uchar>(0, 3), 110);
    s.background = 300.0;
    s.object = -10.0;
    const cv::Mat saturated = shadeExact(coverage, s);
    EXPECT_EQ(saturated.at<uchar>(0, 0), 255);
    EXPECT_EQ(saturated.at<uchar>(0, 1), 0);
    EXPECT_THROW(shadeExact(cv::Mat1b(2, 2), {}), std::invalid_argument);

    // Blur keeps a uniform image; noise has its σ and its seed.
    cv::Mat1f half(200, 200, 0.5f);
    ExactShading noisy;
    noisy.background = 200.0;
    noisy.object = 20.0;
    noisy.blurSigmaPx = 1.5;
    EXPECT_EQ(cv::norm(shadeExact(half, noisy), cv::Mat1b(200, 200, 110), cv::NORM_INF), 0.0);
    noisy.noiseSigma = 3.0;
    noisy.seed = 11;
    const cv::Mat n1 = shadeExact(half, noisy);
    cv::Scalar mean, sd;
    cv::meanStdDev(n1, mean, sd);
    EXPECT_NEAR(mean[0], 110.0, 0.05);
    EXPECT_NEAR(sd[0], std::sqrt(9.0 + 1.0 / 12.0), 0.1); // noise and rounding
    EXPECT_EQ(cv::norm(n1, shadeExact(half, noisy), cv::NORM_INF), 0.0);
    noisy.seed = 12;
    EXPECT_GT(cv::norm(n1, shadeExact(half, noisy), cv::NORM_INF), 0.0);
}

} // namespace
} // namespace hgtest
