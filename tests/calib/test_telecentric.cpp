// Telecentric calibration (docs/telecentric-calibration.md) on chessboard
// images rendered independently of the product: hgtest's exact chessboard
// renderer (each pixel's covered area integrated exactly through a lens
// described by its own code), 1 grey level of noise, the corners found by
// the product's detector as in the field.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include <Eigen/Geometry>

#include "hgtest/exact_render.h"
#include "hullgauge/calib/telecentric.h"
#include "hullgauge/common/error.h"
#include "telecentric_rig.h"

using namespace hg::calib;

namespace {

using namespace telecentrictest;

std::vector<TargetView> detectViews(const hgtest::TelecentricLens& lens, const std::vector<BoardPose>& poses)
{
    const auto spec = TargetSpec::parse(kPattern);
    std::vector<TargetView> views;
    for (std::size_t i = 0; i < poses.size(); ++i) {
        const auto v = detectTarget(renderView(lens, poses[i], 1000 + i), spec, "view" + std::to_string(i));
        if (!v)
            ADD_FAILURE() << "the chessboard was not found in view " << i;
        else
            views.push_back(*v);
    }
    return views;
}

/// Views from the corners' true pixels plus Gaussian noise (for the
/// refusals, where the images add nothing).
std::vector<TargetView> cornerViews(const hgtest::TelecentricLens& lens, const std::vector<BoardPose>& poses,
                                    double sigmaPx)
{
    const auto spec = TargetSpec::parse(kPattern);
    std::mt19937_64 rng(7);
    std::normal_distribution<double> noise(0.0, sigmaPx);
    std::vector<TargetView> views;
    for (std::size_t i = 0; i < poses.size(); ++i) {
        std::vector<cv::Point2f> pixels;
        for (int id = 0; id < spec.cornerCount(); ++id) {
            const auto o = spec.cornerPosition(id);
            const Eigen::Vector2d p = hgtest::telecentricPixel(lens, poses[i].R, poses[i].t, o.x, o.y);
            pixels.emplace_back(static_cast<float>(p.x() + noise(rng)), static_cast<float>(p.y() + noise(rng)));
        }
        views.push_back(viewFromCorners(spec, "corners" + std::to_string(i), pixels));
    }
    return views;
}

hg::geometry::Intrinsics intrinsicsOf(const hgtest::TelecentricLens& lens)
{
    hg::geometry::Intrinsics in;
    in.K << lens.fx, 0, lens.cx, 0, lens.fy, lens.cy, 0, 0, 1;
    in.dist.assign(lens.dist.begin(), lens.dist.end());
    in.imageSize = lens.imageSize;
    return in;
}

} // namespace

TEST(ExactChessboard, CoverageIsTheSquaresExactArea)
{
    // Without distortion a square of side s through diag(fx, fy)·(upper-left
    // block of R) has area s²·fx·fy·|det block| pixels; 104 of the 16 x 13
    // squares are black.
    auto lens = trueLens();
    lens.dist = {};
    const auto pose = boardPose(35.0, 20.0, 5.0, 0.3, -0.2);
    const cv::Mat coverage = hgtest::telecentricChessboardCoverage(kBoard, pose.R, pose.t, lens);
    const double block = pose.R(0, 0) * pose.R(1, 1) - pose.R(0, 1) * pose.R(1, 0);
    const double s = kBoard.squareMm;
    const double expected = 104 * s * s * lens.fx * lens.fy * std::abs(block);
    EXPECT_NEAR(cv::sum(coverage)[0], expected, 1e-6 * expected);

    // A face-on board at t = (−3 + 0.003, −2.1 + 0.0012) mm: square (0, 0),
    // black, spans [−s, 0] x [−s, 0] mm, so its right edge is at
    // u = cx + fx·(0 − 3 + 0.003) = 351.8 and its top edge at
    // v = cy + fy·(−s − 2.1 + 0.0012); square (1, 0) right of it is white.
    BoardPose flat;
    flat.R = Eigen::Matrix3d::Identity();
    flat.t = Eigen::Vector3d(-3.0 + 0.003, -2.1 + 0.0012, 0.0);
    const cv::Mat c = hgtest::telecentricChessboardCoverage(kBoard, flat.R, flat.t, lens);
    const int row = static_cast<int>(std::lround(lens.cy + lens.fy * (-s / 2 - 2.1 + 0.0012))); // mid-square
    EXPECT_NEAR(c.at<float>(row, 351), 1.0, 1e-6); // [350.5, 351.5]: all black
    EXPECT_NEAR(c.at<float>(row, 352), 0.3, 1e-5); // [351.5, 352.5]: black up to 351.8
    EXPECT_NEAR(c.at<float>(row, 353), 0.0, 1e-6);
    const double top = lens.cy + lens.fy * (-s - 2.1 + 0.0012);
    const int topRow = static_cast<int>(std::lround(top));
    EXPECT_NEAR(c.at<float>(topRow, 320), topRow + 0.5 - top, 1e-5);
}

TEST(TelecentricCalibration, TwelveRenderedTiltsGiveBackTheLens)
{
    const auto lens = trueLens();
    const auto views = detectViews(lens, twelveTilts());
    ASSERT_EQ(views.size(), 12u);
    const auto r = calibrateTelecentric(views, lens.imageSize);
    std::printf("%s", formatTelecentricReport(r).c_str());
    const auto& K = r.intrinsics.K;
    const double fxError = K(0, 0) / lens.fx - 1.0, fyError = K(1, 1) / lens.fy - 1.0;
    std::printf("magnification error fx %.5f %%, fy %.5f %%; principal point error %.3f, %.3f px; RMS %.4f px\n",
                100 * fxError, 100 * fyError, K(0, 2) - lens.cx, K(1, 2) - lens.cy, r.rmsPx);
    EXPECT_LT(std::abs(fxError), 5e-4);
    EXPECT_LT(std::abs(fyError), 5e-4);
    EXPECT_LT(std::abs(K(0, 2) - lens.cx), 0.3);
    EXPECT_LT(std::abs(K(1, 2) - lens.cy), 0.3);
    EXPECT_LE(r.rmsPx, 0.05);
    EXPECT_NEAR(r.intrinsics.dist[0], lens.dist[0], 0.05 * std::abs(lens.dist[0]));
    // The reported uncertainty covers the errors (4 standard deviations).
    EXPECT_LT(std::abs(K(0, 0) - lens.fx), 4 * r.stdDev[0]);
    EXPECT_LT(std::abs(K(0, 2) - lens.cx), 4 * r.stdDev[2]);
    EXPECT_LT(std::abs(K(1, 2) - lens.cy), 4 * r.stdDev[3]);
    ASSERT_EQ(r.perViewRmsPx.size(), 12u);
    for (double e : r.perViewRmsPx) EXPECT_LT(e, 0.08);
    // Every pose's tilt (the angle between the board's normal and the optical
    // axis, unchanged by the mirror pose and the detector's corner order).
    const auto truth = twelveTilts();
    for (std::size_t i = 0; i < truth.size(); ++i) {
        const double tilt = std::acos(std::abs(r.cameraFromTarget[i].R(2, 2))) / kDeg;
        const double trueTilt = std::acos(std::abs(truth[i].R(2, 2))) / kDeg;
        EXPECT_NEAR(tilt, trueTilt, 0.05) << "view " << i;
        EXPECT_EQ(r.cameraFromTarget[i].t.z(), 0.0);
        EXPECT_GE(r.cameraFromTarget[i].R(2, 0), 0.0);
    }
}

TEST(TelecentricCalibration, WithoutDistortionThePrincipalPointIsTheImageCentre)
{
    auto lens = trueLens();
    lens.dist = {};
    TelecentricOptions options;
    options.distortion = false;
    const auto r = calibrateTelecentric(cornerViews(lens, twelveTilts(), 0.02), lens.imageSize, options);
    EXPECT_DOUBLE_EQ(r.intrinsics.K(0, 2), 639.5);
    EXPECT_DOUBLE_EQ(r.intrinsics.K(1, 2), 511.5);
    EXPECT_EQ(r.stdDev[2], 0.0);
    EXPECT_NEAR(r.intrinsics.K(0, 0), lens.fx, 1e-4 * lens.fx);
    // The noise itself (0.02 px in x and in y: 0.028 px per corner): the
    // centre's offset went into the poses.
    EXPECT_NEAR(r.rmsPx, 0.02 * std::sqrt(2.0), 0.003);
}

TEST(TelecentricCalibration, ParallelViewsAreRefused)
{
    // Twelve views, one target plane: tilted 30° about the same axis, half
    // of them the mirror tilt, each turned and shifted in its plane.
    const auto lens = trueLens();
    std::vector<BoardPose> poses;
    for (int k = 0; k < 12; ++k) {
        const double tilt = k % 2 == 0 ? 30.0 : -30.0;
        auto p = boardPose(tilt, 20.0, 0.0, 0.5 * std::cos(k), 0.3 * std::sin(k));
        // A turn in the board's plane keeps the plane.
        p.R = p.R * Eigen::AngleAxisd((8.0 * k - 40.0) * kDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix();
        poses.push_back(p);
    }
    const auto views = cornerViews(lens, poses, 0.02);
    try {
        (void)calibrateTelecentric(views, lens.imageSize);
        ADD_FAILURE() << "parallel views were accepted";
    } catch (const hg::InputError& e) {
        EXPECT_EQ(e.field(), "--images");
        EXPECT_NE(std::string(e.what()).find("pixel aspect cannot be told"), std::string::npos) << e.what();
    }
    // With the aspect ratio fixed one plane suffices.
    auto square = lens;
    square.fy = square.fx;
    TelecentricOptions fixed;
    fixed.fixAspectRatio = true;
    const auto r = calibrateTelecentric(cornerViews(square, poses, 0.02), lens.imageSize, fixed);
    EXPECT_NEAR(r.intrinsics.K(0, 0), square.fx, 5e-4 * square.fx);
}

TEST(TelecentricCalibration, TooFewViewsAreRefused)
{
    const auto lens = trueLens();
    auto poses = twelveTilts();
    poses.resize(2);
    try {
        (void)calibrateTelecentric(cornerViews(lens, poses, 0.02), lens.imageSize);
        ADD_FAILURE() << "two views were accepted";
    } catch (const hg::InputError& e) {
        EXPECT_NE(std::string(e.what()).find("at least 3 views"), std::string::npos) << e.what();
    }
}

TEST(TelecentricRail, RenderedViewsAlongTheRailGiveItsDirection)
{
    // The rail runs 1.2° off the optical axis towards azimuth 40° in the
    // image; the board rides it through 20 mm in steps of 4 mm.
    const auto lens = trueLens();
    const double angle = 1.2 * kDeg, azimuth = 40.0 * kDeg;
    const Eigen::Vector3d rail(std::sin(angle) * std::cos(azimuth), std::sin(angle) * std::sin(azimuth),
                               std::cos(angle));
    const auto start = boardPose(20.0, 60.0, 3.0, -0.2, -0.15);
    const auto spec = TargetSpec::parse(kPattern);
    std::vector<std::vector<RailSample>> tracks(static_cast<std::size_t>(spec.cornerCount()));
    for (int step = 0; step <= 5; ++step) {
        const double d = 4.0 * step;
        BoardPose p = start;
        p.t += d * rail;
        const auto v = detectTarget(renderView(lens, p, 77 + step), spec, "rail" + std::to_string(step));
        ASSERT_TRUE(v) << "step " << step;
        // Bookkeeping only: each detected corner joins the track of the
        // true corner it lies on (the detector may number them backwards).
        for (const auto& px : v->imagePoints) {
            int best = -1;
            double bestDistance = 2.0;
            for (int id = 0; id < spec.cornerCount(); ++id) {
                const auto o = spec.cornerPosition(id);
                const Eigen::Vector2d q = hgtest::telecentricPixel(lens, p.R, p.t, o.x, o.y);
                const double distance = std::hypot(q.x() - px.x, q.y() - px.y);
                if (distance < bestDistance) best = id, bestDistance = distance;
            }
            ASSERT_GE(best, 0);
            tracks[static_cast<std::size_t>(best)].push_back({d, hg::geometry::Vec2(px.x, px.y)});
        }
    }
    const auto axis = calibrateTelecentricRail(tracks, intrinsicsOf(lens));
    std::printf("%s", formatTelecentricRailReport(axis).c_str());
    EXPECT_NEAR(axis.angleToAxisDeg, 1.2, 0.005);
    EXPECT_NEAR(axis.azimuthDeg, 40.0, 0.5);
    EXPECT_LT(std::acos(std::min(1.0, axis.direction.dot(rail))) / kDeg, 0.005);
    EXPECT_LE(axis.rmsPx, 0.05);
    EXPECT_GT(axis.stdDevAngleDeg, 0.0);
    EXPECT_EQ(axis.tracks, spec.cornerCount());
}

TEST(TelecentricRail, OneReadingIsRefused)
{
    std::vector<std::vector<RailSample>> tracks{{{10.0, {100.0, 100.0}}, {10.0, {100.2, 100.1}}}};
    EXPECT_THROW((void)calibrateTelecentricRail(tracks, intrinsicsOf(trueLens())), hg::InputError);
}
