// Volume-source voxel test: exact footprint background fractions against an
// independent per-pixel polygon clipping, and the 50 % rule on hand-computed
// perspective footprints.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <opencv2/imgproc.hpp>

#include "hullgauge/inspect/voxel_test.h"

using namespace hg::inspect;
using hg::geometry::CameraModel;
using hg::geometry::Intrinsics;
using hg::geometry::RigidTransform;

namespace {

/// Reference: area of `poly` (pixel coordinates, pixel (c, r) covers
/// [c-0.5, c+0.5] x [r-0.5, r+0.5]) over background pixels, by clipping the
/// polygon against every background pixel square on its own.
double referenceBackground(const std::vector<Vec2>& poly, const cv::Mat& sil)
{
    auto clip = [](std::vector<Vec2> p, int axis, double bound, double sign) {
        std::vector<Vec2> out;
        for (std::size_t i = 0; i < p.size(); ++i) {
            const Vec2 a = p[i], b = p[(i + 1) % p.size()];
            const double da = sign * (a[axis] - bound), db = sign * (b[axis] - bound);
            if (da >= 0) out.push_back(a);
            if ((da >= 0) != (db >= 0)) out.push_back(a + da / (da - db) * (b - a));
        }
        return out;
    };
    auto area = [](const std::vector<Vec2>& p) {
        double a = 0;
        for (std::size_t i = 0; i < p.size(); ++i)
            a += p[i].x() * p[(i + 1) % p.size()].y() - p[(i + 1) % p.size()].x() * p[i].y();
        return std::abs(a) / 2;
    };
    double total = 0;
    for (int r = 0; r < sil.rows; ++r)
        for (int c = 0; c < sil.cols; ++c) {
            if (sil.at<std::uint8_t>(r, c) != 0) continue;
            auto p = clip(poly, 0, c - 0.5, 1);
            p = clip(p, 0, c + 0.5, -1);
            p = clip(p, 1, r - 0.5, 1);
            p = clip(p, 1, r + 0.5, -1);
            if (p.size() >= 3) total += area(p);
        }
    return total;
}

CameraModel frontCamera(double f, double cx, double cy, cv::Size size, double distance)
{
    Intrinsics in;
    in.K << f, 0, cx, 0, f, cy, 0, 0, 1;
    in.imageSize = size;
    return CameraModel(in, RigidTransform{Eigen::Matrix3d::Identity(), Eigen::Vector3d(0, 0, distance)});
}

/// Object (255) at columns < `firstBackgroundColumn`, background from there on.
cv::Mat halfPlane(cv::Size size, int firstBackgroundColumn)
{
    cv::Mat s(size, CV_8U, cv::Scalar(255));
    s.colRange(firstBackgroundColumn, size.width).setTo(0);
    return s;
}

} // namespace

TEST(ConvexHull, KeepsOutlineOfProjectedCube)
{
    // A cube seen along its main diagonal projects to a hexagon; face-on to a square.
    const CameraModel diag = [] {
        const Eigen::Vector3d a = Eigen::Vector3d(1, 1, 1).normalized();
        const Eigen::Vector3d h = Eigen::Vector3d(1, -1, 0).normalized();
        const Eigen::Vector3d v = a.cross(h);
        return CameraModel::fromDissertation(500, 500, 50, 50, -100.0 * a, h, v, a, {101, 101});
    }();
    const std::vector<SilhouetteView> views{
        {diag, SilhouetteIndex::fromSilhouette(cv::Mat(101, 101, CV_8U, cv::Scalar(255)))}};
    VoxelTester t(&views);
    const Box3 cube(Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(1, 1, 1));
    EXPECT_EQ(t.measure(cube, 0).outlineVertices, 6);
    const std::vector<SilhouetteView> front{
        {frontCamera(500, 50, 50, {101, 101}, 100),
         SilhouetteIndex::fromSilhouette(cv::Mat(101, 101, CV_8U, cv::Scalar(255)))}};
    VoxelTester tf(&front);
    EXPECT_EQ(tf.measure(cube, 0).outlineVertices, 4);
}

TEST(BackgroundArea, MatchesPerPixelClippingOnHalfPlane)
{
    const cv::Mat sil = halfPlane({40, 30}, 20);
    const auto idx = SilhouetteIndex::fromSilhouette(sil);
    // Axis-aligned rectangle x in [16.2, 22.7], y in [3.1, 9.4]: background
    // from x = 19.5 (column 20 starts there): (22.7 - 19.5) * 6.3.
    const std::vector<Vec2> rect{{16.2, 3.1}, {22.7, 3.1}, {22.7, 9.4}, {16.2, 9.4}};
    EXPECT_NEAR(backgroundArea(rect, idx.regions()[0]), 3.2 * 6.3, 1e-9);
    EXPECT_NEAR(backgroundArea(rect, idx.regions()[0]), referenceBackground(rect, sil), 1e-9);
}

TEST(BackgroundArea, MatchesPerPixelClippingOnRandomPolygonsAndSilhouettes)
{
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(2.0, 28.0);
    cv::Mat sil(32, 32, CV_8U);
    cv::randu(sil, 0, 2);
    sil *= 255;
    cv::circle(sil, {16, 16}, 7, cv::Scalar(255), cv::FILLED);
    const auto idx = SilhouetteIndex::fromSilhouette(sil);
    for (int trial = 0; trial < 200; ++trial) {
        std::vector<Vec2> pts;
        for (int i = 0; i < 8; ++i) pts.emplace_back(u(rng), u(rng));
        const auto hull = convexHull(pts);
        ASSERT_GE(hull.size(), 3u);
        EXPECT_NEAR(backgroundArea(hull, idx.regions()[0]), referenceBackground(hull, sil), 1e-8) << "trial " << trial;
    }
}

TEST(BackgroundArea, UniformBlocksGiveZeroOrTheWholeArea)
{
    // Left half object, right half background, one boundary column at x = 16:
    // footprints wholly on one side take the uniform shortcut, footprints that
    // straddle it are integrated; both must agree with per-pixel clipping.
    cv::Mat sil(32, 32, CV_8U, cv::Scalar(0));
    sil(cv::Rect(0, 0, 16, 32)).setTo(255);
    const auto idx = SilhouetteIndex::fromSilhouette(sil);
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(1.0, 30.0);
    int inObject = 0, inBackground = 0, straddling = 0;
    for (int trial = 0; trial < 300; ++trial) {
        std::vector<Vec2> pts;
        const Vec2 c(u(rng), u(rng));
        for (int i = 0; i < 6; ++i) pts.push_back(c + Vec2(u(rng) - 15.5, u(rng) - 15.5) * 0.15);
        auto hull = convexHull(pts);
        ASSERT_GE(hull.size(), 3u);
        bool inside = true;
        for (const auto& v : hull) inside = inside && v.x() > 0 && v.x() < 31 && v.y() > 0 && v.y() < 31;
        if (!inside) continue;
        double xmin = 1e9, xmax = -1e9, area = 0;
        for (std::size_t i = 0; i < hull.size(); ++i) {
            xmin = std::min(xmin, hull[i].x());
            xmax = std::max(xmax, hull[i].x());
            const auto& a = hull[i];
            const auto& b = hull[(i + 1) % hull.size()];
            area += 0.5 * (a.x() * b.y() - b.x() * a.y());
        }
        const double bg = backgroundArea(hull, idx.regions()[0]);
        // Pixel c covers [c - 0.5, c + 0.5]: object pixels end at x = 15.5.
        if (xmax < 15.5) {
            ++inObject;
            EXPECT_EQ(bg, 0.0) << "trial " << trial;
        } else if (xmin > 15.5) {
            ++inBackground;
            EXPECT_NEAR(bg, std::abs(area), 1e-9) << "trial " << trial;
        } else {
            ++straddling;
        }
        EXPECT_NEAR(bg, referenceBackground(hull, sil), 1e-8) << "trial " << trial;
    }
    EXPECT_GT(inObject, 20);
    EXPECT_GT(inBackground, 20);
    EXPECT_GT(straddling, 5);
}

TEST(VoxelTest, FiftyPercentRuleOnFaceOnFootprint)
{
    // Camera on the z axis at 100 mm, f = 1000 px; a unit voxel at the origin
    // spans z_cam 99.5..100.5, so its footprint is the front face: a square of
    // half-width 1000 * 0.5 / 99.5 = 5.0251 px around the principal point.
    const Box3 voxel(Eigen::Vector3d(-0.5, -0.5, -0.5), Eigen::Vector3d(0.5, 0.5, 0.5));
    const double half = 1000.0 * 0.5 / 99.5;
    const cv::Size size(101, 101);
    struct Case {
        double cx;
        int firstBackground;
        VoxelLabel expected;
    };
    // Background begins at x = firstBackground - 0.5.
    for (const Case& c : {Case{50.0, 51, VoxelLabel::Object},    // 45.0 % background
                          Case{50.0, 50, VoxelLabel::Void},      // 55.0 % background
                          Case{49.5, 50, VoxelLabel::Void},      // exactly 50 %: void (>= 50 %)
                          Case{49.4, 50, VoxelLabel::Object}}) { // 49.0 %: object
        const std::vector<SilhouetteView> views{{frontCamera(1000, c.cx, 50, size, 100),
                                                 SilhouetteIndex::fromSilhouette(halfPlane(size, c.firstBackground))}};
        VoxelTester t(&views);
        const FootprintMeasure m = t.measure(voxel, 0);
        const double expectedFraction = (c.cx + half - (c.firstBackground - 0.5)) / (2 * half);
        EXPECT_NEAR(m.area, 4 * half * half, 1e-9);
        EXPECT_NEAR(m.background / m.area, expectedFraction, 1e-12) << "cx " << c.cx;
        EXPECT_EQ(t.classify(voxel), c.expected) << "cx " << c.cx << " fraction " << expectedFraction;
    }
}

TEST(VoxelTest, VoidInAnySingleViewWins)
{
    const Box3 voxel(Eigen::Vector3d(-0.5, -0.5, -0.5), Eigen::Vector3d(0.5, 0.5, 0.5));
    const cv::Size size(101, 101);
    const cv::Mat allObject(size, CV_8U, cv::Scalar(255));
    std::vector<SilhouetteView> views{
        {frontCamera(1000, 50, 50, size, 100), SilhouetteIndex::fromSilhouette(allObject)},
        {frontCamera(1000, 50, 50, size, 100), SilhouetteIndex::fromSilhouette(allObject)}};
    EXPECT_EQ(VoxelTester(&views).classify(voxel), VoxelLabel::Object);
    views.push_back({frontCamera(1000, 50, 50, size, 100), SilhouetteIndex::fromSilhouette(halfPlane(size, 48))});
    EXPECT_EQ(VoxelTester(&views).classify(voxel), VoxelLabel::Void);
}

TEST(VoxelTest, FootprintLeavingTheFrameIsUnknown)
{
    const Box3 voxel(Eigen::Vector3d(-0.5, -0.5, -0.5), Eigen::Vector3d(0.5, 0.5, 0.5));
    const double half = 1000.0 * 0.5 / 99.5;
    // Principal point at column 2: the footprint spans x in [-3.03, 7.03]; the
    // frame starts at -0.5, so 2.525 px of width are outside it.
    const cv::Size size(60, 101);
    const double outside = (half - 2.0 - 0.5) / (2 * half);
    {
        // All-object frame: background 0, unknown 25 %: background + unknown < 50 %
        // still decides object.
        const std::vector<SilhouetteView> views{
            {frontCamera(1000, 2, 50, size, 100),
             SilhouetteIndex::fromSilhouette(cv::Mat(size, CV_8U, cv::Scalar(255)))}};
        VoxelTester t(&views);
        const FootprintMeasure m = t.measure(voxel, 0);
        EXPECT_NEAR(m.unknown / m.area, outside, 1e-12);
        EXPECT_EQ(t.classify(voxel), VoxelLabel::Object);
    }
    {
        // Background from column 4 (x >= 3.5): 3.53 px of 10.05 known background
        // (35 %) + 25 % unknown: this view cannot decide, and it is the only one.
        const std::vector<SilhouetteView> views{
            {frontCamera(1000, 2, 50, size, 100), SilhouetteIndex::fromSilhouette(halfPlane(size, 4))}};
        VoxelTester t(&views);
        const FootprintMeasure m = t.measure(voxel, 0);
        EXPECT_NEAR(m.background / m.area, (2 + half - 3.5) / (2 * half), 1e-12);
        EXPECT_EQ(t.classify(voxel), VoxelLabel::Undecided);
    }
    {
        // A voxel behind the camera is not decided by it.
        const std::vector<SilhouetteView> views{
            {frontCamera(1000, 50, 50, {101, 101}, -100), SilhouetteIndex::fromSilhouette(halfPlane({101, 101}, 0))}};
        EXPECT_EQ(VoxelTester(&views).classify(voxel), VoxelLabel::Undecided);
    }
}

TEST(VoxelTest, CentrePointBaselineDisagreesWhereVolumeSourceUsesTheOverlap)
{
    // Fig. 3.11: a one-pixel background stripe under the voxel centre. The centre
    // point reads background and calls the voxel void; the footprint is only
    // 1 / 10.05 background, so the volume source keeps it object.
    const Box3 voxel(Eigen::Vector3d(-0.5, -0.5, -0.5), Eigen::Vector3d(0.5, 0.5, 0.5));
    const cv::Size size(101, 101);
    cv::Mat sil(size, CV_8U, cv::Scalar(255));
    sil.col(50).setTo(0);
    const std::vector<SilhouetteView> views{
        {frontCamera(1000, 50, 50, size, 100), SilhouetteIndex::fromSilhouette(sil)}};
    EXPECT_EQ(VoxelTester(&views, VoxelTestMethod::VolumeSource).classify(voxel), VoxelLabel::Object);
    EXPECT_EQ(VoxelTester(&views, VoxelTestMethod::CentrePoint).classify(voxel), VoxelLabel::Void);
}

TEST(VoxelTest, RegionsLimitWhatIsKnown)
{
    // Only a region of the frame is segmented; a footprint inside it is measured,
    // one outside every region is unknown (undecided).
    const cv::Size size(101, 101);
    SilhouetteIndex idx(size);
    idx.addRegion(cv::Rect(40, 40, 20, 20), cv::Mat(20, 20, CV_8U, cv::Scalar(0)));
    const std::vector<SilhouetteView> views{{frontCamera(1000, 50, 50, size, 100), idx}};
    VoxelTester t(&views);
    const Box3 centred(Eigen::Vector3d(-0.5, -0.5, -0.5), Eigen::Vector3d(0.5, 0.5, 0.5));
    EXPECT_EQ(t.classify(centred), VoxelLabel::Void);
    const Box3 aside(Eigen::Vector3d(3.5, 3.5, -0.5), Eigen::Vector3d(4.5, 4.5, 0.5));
    EXPECT_EQ(t.classify(aside), VoxelLabel::Undecided);
    EXPECT_EQ(t.testsPerformed(), 2u);
}
